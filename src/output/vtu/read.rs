//! Reading back the `.vtu` files [`super::write_vtu`] writes (tests and checks of tlsmpm's
//! own output, not a general VTK reader).

use super::decode_base64;

/// What [`read_vtu_summary`] found in a `.vtu` file written by [`super::write_vtu`].
#[derive(Debug, Clone, PartialEq)]
pub struct VtuSummary {
    /// `NumberOfPoints` of the piece.
    pub n_points: usize,
    /// `NumberOfCells` of the piece.
    pub n_cells: usize,
    /// Point-data arrays in file order: `(name, NumberOfComponents, values)`, the values
    /// decoded and interleaved per point (`components * n_points` of them).
    pub arrays: Vec<(String, usize, Vec<f64>)>,
    /// Point coordinates, interleaved `x0 y0 z0 x1 y1 z1 ...` (`3 * n_points` values).
    pub points: Vec<f64>,
}

/// Parse a `.vtu` file written by [`super::write_vtu`] back into a [`VtuSummary`].
///
/// This is a minimal reader of tlsmpm's own output, for tests and sanity checks, not a
/// general VTK or XML parser: it finds the `Piece`, `Points`, `PointData` and `DataArray`
/// tags by string search, reads their double-quoted attributes, and decodes inline
/// `format="binary"` data (base64 of a `UInt64` byte count followed by the little-endian
/// values). Returns `None` if anything is missing or inconsistent: a missing tag or
/// attribute, a data array that is not inline binary `Float64`, a header byte count that
/// differs from the decoded length, or a value count other than
/// `NumberOfComponents * NumberOfPoints`.
pub fn read_vtu_summary(text: &str) -> Option<VtuSummary> {
    let (_, piece, after_piece) = find_start_tag(text, 0, "Piece")?;
    let n_points: usize = attribute(piece, "NumberOfPoints")?.parse().ok()?;
    let n_cells: usize = attribute(piece, "NumberOfCells")?.parse().ok()?;
    let body = &text[after_piece..];

    let point_arrays = raw_arrays_in(body, "PointData")?;
    let mut arrays = Vec::with_capacity(point_arrays.len());
    for raw in point_arrays {
        let values = raw.float64_values(n_points)?;
        arrays.push((raw.name, raw.components, values));
    }

    let mut points = raw_arrays_in(body, "Points")?;
    if points.len() != 1 || points[0].components != 3 {
        return None;
    }
    let points = points.pop()?.float64_values(n_points)?;

    Some(VtuSummary {
        n_points,
        n_cells,
        arrays,
        points,
    })
}

/// Inverse of [`super::escape_xml`].
fn unescape_xml(text: &str) -> String {
    text.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

// ---------------------------------------------------------------------------------------
// Reader internals (our own output only).

/// One decoded inline binary `DataArray`.
#[derive(Debug)]
pub(super) struct RawArray {
    pub(super) name: String,
    pub(super) type_name: String,
    pub(super) components: usize,
    /// The data bytes after the 8-byte header (whose count has been checked).
    pub(super) bytes: Vec<u8>,
}

impl RawArray {
    /// The values as `f64`, if the array is `Float64` with `components * n_points` values.
    fn float64_values(&self, n_points: usize) -> Option<Vec<f64>> {
        if self.type_name != "Float64" || self.bytes.len() != self.components * n_points * 8 {
            return None;
        }
        Some(
            self.bytes
                .chunks_exact(8)
                .map(|chunk| {
                    let mut word = [0u8; 8];
                    word.copy_from_slice(chunk);
                    f64::from_le_bytes(word)
                })
                .collect(),
        )
    }
}

/// Find the first start tag `<name ...>` at or after `from`: returns the index of `<`, the
/// tag text `<name ...>` (or `<name .../>`) and the index just past `>`.
pub(super) fn find_start_tag<'t>(
    text: &'t str,
    from: usize,
    name: &str,
) -> Option<(usize, &'t str, usize)> {
    let pattern = format!("<{name}");
    let mut search = from;
    loop {
        let start = search + text.get(search..)?.find(&pattern)?;
        let after_name = start + pattern.len();
        match text[after_name..].chars().next() {
            Some(c) if c.is_ascii_whitespace() || c == '>' || c == '/' => {
                let end = after_name + text[after_name..].find('>')? + 1;
                return Some((start, &text[start..end], end));
            }
            _ => search = after_name,
        }
    }
}

/// Value of the double-quoted attribute `name="..."` of a tag, unescaped.
pub(super) fn attribute(tag: &str, name: &str) -> Option<String> {
    let pattern = format!("{name}=\"");
    let mut search = 0;
    loop {
        let at = search + tag.get(search..)?.find(&pattern)?;
        let preceded_by_space = tag[..at]
            .chars()
            .next_back()
            .is_some_and(|c| c.is_ascii_whitespace());
        let value_start = at + pattern.len();
        if preceded_by_space {
            let value_len = tag[value_start..].find('"')?;
            return Some(unescape_xml(&tag[value_start..value_start + value_len]));
        }
        search = value_start;
    }
}

/// All inline binary `DataArray`s inside the first `<section>...</section>` of `text`
/// (none if the section is self-closing); `None` if the section is missing or an array is
/// malformed.
pub(super) fn raw_arrays_in(text: &str, section: &str) -> Option<Vec<RawArray>> {
    let (_, open, body_start) = find_start_tag(text, 0, section)?;
    if open.ends_with("/>") {
        return Some(Vec::new());
    }
    let body_end = body_start + text[body_start..].find(&format!("</{section}>"))?;
    let body = &text[body_start..body_end];
    let mut arrays = Vec::new();
    let mut from = 0;
    while let Some((_, tag, content_start)) = find_start_tag(body, from, "DataArray") {
        if tag.ends_with("/>") || attribute(tag, "format")? != "binary" {
            return None;
        }
        let content_len = body[content_start..].find("</DataArray>")?;
        let decoded = decode_base64(&body[content_start..content_start + content_len])?;
        if decoded.len() < 8 {
            return None;
        }
        let (header, bytes) = decoded.split_at(8);
        let mut count = [0u8; 8];
        count.copy_from_slice(header);
        if u64::from_le_bytes(count) != bytes.len() as u64 {
            return None;
        }
        let components = match attribute(tag, "NumberOfComponents") {
            Some(value) => value.parse().ok()?,
            None => 1,
        };
        arrays.push(RawArray {
            name: attribute(tag, "Name")?,
            type_name: attribute(tag, "type")?,
            components,
            bytes: bytes.to_vec(),
        });
        from = content_start + content_len + "</DataArray>".len();
    }
    Some(arrays)
}
