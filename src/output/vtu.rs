//! VTK XML particle output for ParaView / VisIt.
//!
//! * [`write_vtu`] writes one `.vtu` file: a VTK XML `UnstructuredGrid` (file format
//!   version 1.0, `byte_order="LittleEndian"`, `header_type="UInt64"`) with one piece whose
//!   `n` points are the particles and whose `n` cells are `VTK_VERTEX` cells (cell type 1,
//!   cell `i` = point `i`), plus one `Float64` point-data array per [`PointArray`].
//! * [`write_pvd`] writes a `.pvd` collection (ParaView's time-series index) that lists
//!   the `.vtu` files of a run with their times.
//!
//! Every `DataArray` is stored inline with `format="binary"`: the text of the element is the
//! base64 encoding (RFC 4648, standard alphabet, `=` padding) of one byte stream made of
//!
//! ```text
//! [ byte count N: u64, little-endian (8 bytes) ][ N bytes: the values, little-endian ]
//! ```
//!
//! encoded as a whole (header and data together, as VTK's own writer does for uncompressed
//! data). Multi-component arrays are interleaved per point: `v0x v0y v0z v1x v1y v1z ...`.
//! The files are written atomically ([`crate::output::write_atomic`]).
//!
//! [`decode_base64`] and [`read_vtu_summary`] read back what this module writes; they are
//! meant for tests and checks of tlsmpm's own files, not as a general VTK reader.
//!
//! References:
//! * VTK file formats, "XML File Formats":
//!   <https://docs.vtk.org/en/latest/vtk_file_formats/vtkxml_file_format.html>
//! * Kitware wiki, "VTK XML Formats" (binary data header, `header_type`):
//!   <https://itk.org/Wiki/VTK_XML_Formats>
//! * ParaView wiki, "PVD File Format":
//!   <https://www.paraview.org/Wiki/ParaView/Data_formats#PVD_File_Format>
//! * RFC 4648, "The Base16, Base32, and Base64 Data Encodings", §4.

use super::write_atomic;
use crate::error::{Error, Result};
use std::path::Path;

/// One point-data array of a `.vtu` file, in structure-of-arrays form.
///
/// `components[c][i]` is component `c` of the value at point `i`; one slice means a scalar
/// field, three a vector, nine a (row-major) tensor, and so on. Every slice must have the
/// length `n` of the coordinate slices given to [`write_vtu`]. In the file the array is
/// written as `Float64` with `NumberOfComponents = components.len()`, interleaved per point.
#[derive(Debug, Clone)]
pub struct PointArray<'a> {
    /// Array name shown by ParaView, e.g. `"velocity"`, `"stress"`, `"mass"`. Must be
    /// non-empty and unique within one file; XML special characters are escaped.
    pub name: &'a str,
    /// One slice per component, each of length `n` (number of points).
    pub components: Vec<&'a [f64]>,
}

impl<'a> PointArray<'a> {
    /// An array named `name` with the given component slices.
    pub fn new(name: &'a str, components: Vec<&'a [f64]>) -> Self {
        Self { name, components }
    }
}

/// Write `path` (a `.vtu` file) with `n` particles as `VTK_VERTEX` cells.
///
/// * Points: point `i` has coordinates `(x, y, z)` with `x_a = coordinates[a][i]` for
///   `a < coordinates.len()` and `0.0` for the missing axes (a 1D or 2D run is embedded in
///   3D, as VTK points always have three coordinates). `n = coordinates[0].len()`.
/// * Cells: `connectivity = 0, 1, ..., n-1` (`Int64`), `offsets = 1, 2, ..., n` (`Int64`,
///   the end of each cell's connectivity), `types = 1` for all cells (`UInt8`, `VTK_VERTEX`).
/// * Point data: one `Float64` array per entry of `arrays`, with
///   `NumberOfComponents = components.len()`, interleaved per point.
///
/// All data arrays are inline base64 binary with a `UInt64` byte-count header (see the
/// module documentation). The raw bytes are never materialised: values are streamed
/// through the base64 encoder into one pre-sized output buffer, which is then written
/// atomically.
///
/// # Errors
/// [`Error::WriteOutput`] naming `path` if the input is inconsistent (no coordinate slice or
/// more than three, coordinate or component slices whose length differs from `n`, an array
/// with no component, an empty or duplicated array name), if the output buffer cannot be
/// allocated, or if the file cannot be written.
pub fn write_vtu(path: &Path, coordinates: &[&[f64]], arrays: &[PointArray<'_>]) -> Result<()> {
    let n = validate(path, coordinates, arrays)?;
    let mut out = Vec::new();
    out.try_reserve_exact(estimated_vtu_size(n, arrays).ok_or_else(|| too_large(path))?)
        .map_err(|e| Error::write(path, format!("cannot allocate the output buffer: {e}")))?;

    push(&mut out, "<?xml version=\"1.0\"?>\n");
    push(
        &mut out,
        "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" \
         header_type=\"UInt64\">\n",
    );
    push(&mut out, "  <UnstructuredGrid>\n");
    push(
        &mut out,
        &format!("    <Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{n}\">\n"),
    );

    push(&mut out, "      <PointData>\n");
    for array in arrays {
        let components = &array.components;
        let byte_count = n * components.len() * 8;
        data_array(
            &mut out,
            "Float64",
            array.name,
            components.len(),
            byte_count,
            |encoder| {
                for i in 0..n {
                    for component in components {
                        encoder.push(&component[i].to_le_bytes());
                    }
                }
            },
        );
    }
    push(&mut out, "      </PointData>\n");

    push(&mut out, "      <Points>\n");
    data_array(&mut out, "Float64", "Points", 3, n * 24, |encoder| {
        for i in 0..n {
            for axis in 0..3 {
                let value = coordinates.get(axis).map_or(0.0, |x| x[i]);
                encoder.push(&value.to_le_bytes());
            }
        }
    });
    push(&mut out, "      </Points>\n");

    push(&mut out, "      <Cells>\n");
    data_array(&mut out, "Int64", "connectivity", 1, n * 8, |encoder| {
        for i in 0..n as u64 {
            encoder.push(&(i as i64).to_le_bytes());
        }
    });
    data_array(&mut out, "Int64", "offsets", 1, n * 8, |encoder| {
        for i in 1..=n as u64 {
            encoder.push(&(i as i64).to_le_bytes());
        }
    });
    data_array(&mut out, "UInt8", "types", 1, n, |encoder| {
        const VTK_VERTEX: u8 = 1;
        let ones = [VTK_VERTEX; 1024];
        let mut left = n;
        while left > 0 {
            let take = left.min(ones.len());
            encoder.push(&ones[..take]);
            left -= take;
        }
    });
    push(&mut out, "      </Cells>\n");

    push(&mut out, "    </Piece>\n");
    push(&mut out, "  </UnstructuredGrid>\n");
    push(&mut out, "</VTKFile>\n");
    write_atomic(path, &out)
}

/// Write `path` (a `.pvd` collection) listing the time series `entries = [(t, file), ...]`.
///
/// One `<DataSet timestep="t" group="" part="0" file="file"/>` element per entry, in the
/// given order; `file` is a path relative to the directory of the `.pvd` (as ParaView
/// resolves it), e.g. `"particles_0003.vtu"`. Times are written with Rust's shortest
/// round-trip formatting, so they read back as the same `f64`.
///
/// # Errors
/// [`Error::WriteOutput`] naming `path` for a non-finite time, an empty file name, or if the
/// file cannot be written.
pub fn write_pvd(path: &Path, entries: &[(f64, String)]) -> Result<()> {
    let mut out = String::with_capacity(256 + entries.len() * 96);
    out.push_str("<?xml version=\"1.0\"?>\n");
    out.push_str(
        "<VTKFile type=\"Collection\" version=\"1.0\" byte_order=\"LittleEndian\" \
         header_type=\"UInt64\">\n",
    );
    out.push_str("  <Collection>\n");
    for (time, file) in entries {
        if !time.is_finite() {
            return Err(Error::write(
                path,
                format!("time step {time} of `{file}` is not finite"),
            ));
        }
        if file.is_empty() {
            return Err(Error::write(path, format!("empty file name at t = {time}")));
        }
        out.push_str(&format!(
            "    <DataSet timestep=\"{}\" group=\"\" part=\"0\" file=\"{}\"/>\n",
            format_time(*time),
            escape_xml(file)
        ));
    }
    out.push_str("  </Collection>\n");
    out.push_str("</VTKFile>\n");
    write_atomic(path, out.as_bytes())
}

/// Encode `bytes` as base64 (RFC 4648 §4: standard alphabet `A–Z a–z 0–9 + /`, `=` padding,
/// no line breaks); the result has `4 * ceil(len / 3)` characters.
///
/// ```
/// use tlsmpm::output::vtu::encode_base64;
/// assert_eq!(encode_base64(b"foobar"), "Zm9vYmFy");
/// assert_eq!(encode_base64(b"fo"), "Zm8=");
/// ```
pub fn encode_base64(bytes: &[u8]) -> String {
    let mut out = Vec::with_capacity(bytes.len().div_ceil(3) * 4);
    let mut encoder = Base64Encoder::new(&mut out);
    encoder.push(bytes);
    encoder.finish();
    out.into_iter().map(char::from).collect()
}

/// Decode base64 text (RFC 4648 §4: standard alphabet, `=` padding), ignoring ASCII
/// whitespace anywhere in the text.
///
/// Every group of four characters gives three bytes, `xxxxxx|xx xxxx|xxxx xx|xxxxxx`; a
/// final group `ab==` gives one byte and `abc=` two. Returns `None` for a character outside
/// the alphabet, a character count (without whitespace) that is not a multiple of four,
/// misplaced padding, or data after a padded group.
///
/// ```
/// use tlsmpm::output::vtu::decode_base64;
/// assert_eq!(decode_base64("Zm9v YmE=").as_deref(), Some(&b"fooba"[..]));
/// assert_eq!(decode_base64("Zm9"), None);
/// ```
pub fn decode_base64(text: &str) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let mut quad = [0u8; 4];
    let mut filled = 0;
    let mut finished = false;
    for &ch in text.as_bytes() {
        if ch.is_ascii_whitespace() {
            continue;
        }
        if finished {
            return None;
        }
        quad[filled] = ch;
        filled += 1;
        if filled < 4 {
            continue;
        }
        filled = 0;
        let padding = match (quad[2], quad[3]) {
            (b'=', b'=') => 2,
            (b'=', _) => return None,
            (_, b'=') => 1,
            _ => 0,
        };
        let s0 = sextet(quad[0])?;
        let s1 = sextet(quad[1])?;
        let s2 = if padding >= 2 { 0 } else { sextet(quad[2])? };
        let s3 = if padding >= 1 { 0 } else { sextet(quad[3])? };
        let word = (s0 << 18) | (s1 << 12) | (s2 << 6) | s3;
        out.push((word >> 16) as u8);
        if padding < 2 {
            out.push((word >> 8) as u8);
        }
        if padding < 1 {
            out.push(word as u8);
        }
        finished = padding > 0;
    }
    (filled == 0).then_some(out)
}

/// What [`read_vtu_summary`] found in a `.vtu` file written by [`write_vtu`].
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

/// Parse a `.vtu` file written by [`write_vtu`] back into a [`VtuSummary`].
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

// ---------------------------------------------------------------------------------------
// Writer internals.

/// Check the shapes of the input of [`write_vtu`]; returns the number of points `n`.
fn validate(path: &Path, coordinates: &[&[f64]], arrays: &[PointArray<'_>]) -> Result<usize> {
    if coordinates.is_empty() || coordinates.len() > 3 {
        return Err(Error::write(
            path,
            format!(
                "{} coordinate slices given, expected 1, 2 or 3",
                coordinates.len()
            ),
        ));
    }
    let n = coordinates[0].len();
    for (axis, x) in coordinates.iter().enumerate() {
        if x.len() != n {
            return Err(Error::write(
                path,
                format!(
                    "coordinate {axis} has {} values, coordinate 0 has {n}",
                    x.len()
                ),
            ));
        }
    }
    for (k, array) in arrays.iter().enumerate() {
        if array.name.is_empty() {
            return Err(Error::write(path, format!("point array {k} has no name")));
        }
        if arrays[..k].iter().any(|other| other.name == array.name) {
            return Err(Error::write(
                path,
                format!("point array `{}` given twice", array.name),
            ));
        }
        if array.components.is_empty() {
            return Err(Error::write(
                path,
                format!("point array `{}` has no component", array.name),
            ));
        }
        for (c, component) in array.components.iter().enumerate() {
            if component.len() != n {
                return Err(Error::write(
                    path,
                    format!(
                        "component {c} of point array `{}` has {} values, expected {n} (one per point)",
                        array.name,
                        component.len()
                    ),
                ));
            }
        }
    }
    Ok(n)
}

fn too_large(path: &Path) -> Error {
    Error::write(path, "output size overflows usize")
}

/// Upper bound of the `.vtu` size in bytes, or `None` on overflow.
fn estimated_vtu_size(n: usize, arrays: &[PointArray<'_>]) -> Option<usize> {
    const TAG_OVERHEAD: usize = 256;
    let mut total: usize = 1024;
    let mut add_array = |name_len: usize, byte_count: Option<usize>| -> Option<()> {
        let encoded = byte_count?.checked_add(8)?.div_ceil(3).checked_mul(4)?;
        let escaped_name = name_len.checked_mul(6)?;
        total = total
            .checked_add(encoded)?
            .checked_add(escaped_name)?
            .checked_add(TAG_OVERHEAD)?;
        Some(())
    };
    for array in arrays {
        add_array(
            array.name.len(),
            n.checked_mul(array.components.len())
                .and_then(|v| v.checked_mul(8)),
        )?;
    }
    add_array(6, n.checked_mul(24))?;
    add_array(12, n.checked_mul(8))?;
    add_array(7, n.checked_mul(8))?;
    add_array(5, Some(n))?;
    Some(total)
}

fn push(out: &mut Vec<u8>, text: &str) {
    out.extend_from_slice(text.as_bytes());
}

/// Write one inline binary `<DataArray>`: the opening tag, the base64 of the `u64`
/// little-endian `byte_count` followed by the bytes that `fill` pushes (exactly
/// `byte_count` of them), and the closing tag.
fn data_array(
    out: &mut Vec<u8>,
    type_name: &str,
    name: &str,
    components: usize,
    byte_count: usize,
    fill: impl FnOnce(&mut Base64Encoder<'_>),
) {
    push(
        out,
        &format!(
            "        <DataArray type=\"{type_name}\" Name=\"{}\" NumberOfComponents=\"{components}\" format=\"binary\">\n          ",
            escape_xml(name)
        ),
    );
    let mut encoder = Base64Encoder::new(out);
    encoder.push(&(byte_count as u64).to_le_bytes());
    fill(&mut encoder);
    encoder.finish();
    push(out, "\n        </DataArray>\n");
}

const BASE64_ALPHABET: &[u8; 64] =
    b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Bytes staged before encoding (a multiple of 3, so only the final block needs padding).
const STAGE_BYTES: usize = 3 * 1024;

/// Streaming base64 encoder: bytes pushed in any chunking are staged in a small fixed
/// buffer and encoded in whole 3-byte blocks straight into `out`; [`Self::finish`] encodes
/// the last 1 or 2 bytes with `=` padding. The output equals the one-shot encoding of the
/// concatenation of all pushed bytes.
struct Base64Encoder<'o> {
    out: &'o mut Vec<u8>,
    stage: [u8; STAGE_BYTES],
    staged: usize,
}

impl<'o> Base64Encoder<'o> {
    fn new(out: &'o mut Vec<u8>) -> Self {
        Base64Encoder {
            out,
            stage: [0; STAGE_BYTES],
            staged: 0,
        }
    }

    fn push(&mut self, mut bytes: &[u8]) {
        while !bytes.is_empty() {
            let take = (STAGE_BYTES - self.staged).min(bytes.len());
            let (head, tail) = bytes.split_at(take);
            self.stage[self.staged..self.staged + take].copy_from_slice(head);
            self.staged += take;
            bytes = tail;
            if self.staged == STAGE_BYTES {
                encode_blocks(self.out, &self.stage);
                self.staged = 0;
            }
        }
    }

    fn finish(self) {
        let whole = self.staged / 3 * 3;
        encode_blocks(self.out, &self.stage[..whole]);
        let sym = |v: u8| BASE64_ALPHABET[usize::from(v & 63)];
        match self.stage[whole..self.staged] {
            [a] => self
                .out
                .extend_from_slice(&[sym(a >> 2), sym(a << 4), b'=', b'=']),
            [a, b] => self.out.extend_from_slice(&[
                sym(a >> 2),
                sym((a << 4) | (b >> 4)),
                sym(b << 2),
                b'=',
            ]),
            _ => {}
        }
    }
}

/// Encode whole 3-byte blocks (`bytes.len()` must be a multiple of 3; a remainder is
/// ignored).
fn encode_blocks(out: &mut Vec<u8>, bytes: &[u8]) {
    for block in bytes.chunks_exact(3) {
        let word = (u32::from(block[0]) << 16) | (u32::from(block[1]) << 8) | u32::from(block[2]);
        out.extend_from_slice(&[
            BASE64_ALPHABET[(word >> 18) as usize & 63],
            BASE64_ALPHABET[(word >> 12) as usize & 63],
            BASE64_ALPHABET[(word >> 6) as usize & 63],
            BASE64_ALPHABET[word as usize & 63],
        ]);
    }
}

/// Value of one base64 symbol, `None` outside the alphabet (including `=`).
fn sextet(ch: u8) -> Option<u32> {
    let value = match ch {
        b'A'..=b'Z' => ch - b'A',
        b'a'..=b'z' => ch - b'a' + 26,
        b'0'..=b'9' => ch - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => return None,
    };
    Some(u32::from(value))
}

/// Shortest round-trip decimal form of a finite time, in plain notation for ordinary
/// magnitudes and in scientific notation (`1e-9`) otherwise.
fn format_time(t: f64) -> String {
    if t == 0.0 || (1e-4..1e15).contains(&t.abs()) {
        format!("{t}")
    } else {
        format!("{t:e}")
    }
}

/// Escape the five XML special characters for use in a double-quoted attribute.
pub(crate) fn escape_xml(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for ch in text.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            _ => out.push(ch),
        }
    }
    out
}

/// Inverse of [`escape_xml`].
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
struct RawArray {
    name: String,
    type_name: String,
    components: usize,
    /// The data bytes after the 8-byte header (whose count has been checked).
    bytes: Vec<u8>,
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
fn find_start_tag<'t>(text: &'t str, from: usize, name: &str) -> Option<(usize, &'t str, usize)> {
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
fn attribute(tag: &str, name: &str) -> Option<String> {
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
fn raw_arrays_in(text: &str, section: &str) -> Option<Vec<RawArray>> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Awkward values: signed zeros, extremes, subnormals, non-representable decimals,
    /// infinities.
    const AWKWARD: [f64; 12] = [
        -0.0,
        0.0,
        1e-300,
        1e300,
        -1e300,
        0.1,
        1.0 / 3.0,
        -2.0 / 3.0,
        f64::MIN_POSITIVE / 3.0,
        f64::MAX,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];

    fn bits(values: &[f64]) -> Vec<u64> {
        values.iter().map(|v| v.to_bits()).collect()
    }

    /// Every opened tag is closed in order, `<?...?>` declarations skipped, `<.../>`
    /// self-closing; exactly one root element; no text outside the root.
    fn assert_balanced(text: &str) {
        let mut stack: Vec<&str> = Vec::new();
        let mut roots = 0;
        let mut rest = text;
        while let Some(lt) = rest.find('<') {
            if stack.is_empty() {
                assert!(
                    rest[..lt].trim().is_empty(),
                    "text outside the root element"
                );
            }
            rest = &rest[lt..];
            if rest.starts_with("<?") {
                let end = rest.find("?>").expect("unterminated declaration");
                rest = &rest[end + 2..];
                continue;
            }
            let gt = rest.find('>').expect("unterminated tag");
            let tag = &rest[1..gt];
            assert!(!tag.contains('<'), "`<` inside tag {tag}");
            if let Some(name) = tag.strip_prefix('/') {
                assert_eq!(stack.pop(), Some(name.trim()), "mismatched </{name}>");
            } else {
                let name = tag
                    .split(|c: char| c.is_ascii_whitespace() || c == '/')
                    .next()
                    .unwrap();
                assert!(!name.is_empty(), "empty tag name");
                if stack.is_empty() {
                    roots += 1;
                }
                if !tag.ends_with('/') {
                    stack.push(name);
                }
            }
            rest = &rest[gt + 1..];
        }
        assert!(stack.is_empty(), "unclosed tags {stack:?}");
        assert!(rest.trim().is_empty(), "text after the root element");
        assert_eq!(roots, 1, "expected exactly one root element");
    }

    /// Decoded `Int64` / `UInt8` cell arrays of a file.
    fn cells(text: &str) -> (Vec<i64>, Vec<i64>, Vec<u8>) {
        let arrays = raw_arrays_in(text, "Cells").unwrap();
        assert_eq!(arrays.len(), 3);
        let ints = |a: &RawArray| -> Vec<i64> {
            assert_eq!(a.type_name, "Int64");
            a.bytes
                .chunks_exact(8)
                .map(|c| i64::from_le_bytes(c.try_into().unwrap()))
                .collect()
        };
        assert_eq!(arrays[0].name, "connectivity");
        assert_eq!(arrays[1].name, "offsets");
        assert_eq!(arrays[2].name, "types");
        assert_eq!(arrays[2].type_name, "UInt8");
        (ints(&arrays[0]), ints(&arrays[1]), arrays[2].bytes.clone())
    }

    fn check_round_trip(dims: usize) {
        let n = AWKWARD.len();
        let coords: Vec<Vec<f64>> = (0..dims)
            .map(|a| (0..n).map(|i| AWKWARD[(i + 5 * a) % n]).collect())
            .collect();
        let coord_slices: Vec<&[f64]> = coords.iter().map(Vec::as_slice).collect();
        let mass: Vec<f64> = AWKWARD.iter().map(|v| -v).collect();
        let vel: Vec<Vec<f64>> = (0..3)
            .map(|c| (0..n).map(|i| AWKWARD[(i + c + 1) % n] * 0.7).collect())
            .collect();
        let stress: Vec<Vec<f64>> = (0..4)
            .map(|c| {
                (0..n)
                    .map(|i| AWKWARD[(3 * i + c) % n] + i as f64 * 1e-17)
                    .collect()
            })
            .collect();
        let arrays = [
            PointArray {
                name: "mass",
                components: vec![&mass],
            },
            PointArray {
                name: "velocity",
                components: vel.iter().map(Vec::as_slice).collect(),
            },
            PointArray {
                name: "stress <2x2> & \"more\"",
                components: stress.iter().map(Vec::as_slice).collect(),
            },
        ];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(format!("particles_{dims}d.vtu"));
        write_vtu(&path, &coord_slices, &arrays).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_balanced(&text);
        assert!(text.contains(
            "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">"
        ));
        assert!(text.contains(&format!("NumberOfPoints=\"{n}\" NumberOfCells=\"{n}\"")));

        let summary = read_vtu_summary(&text).unwrap();
        assert_eq!(summary.n_points, n);
        assert_eq!(summary.n_cells, n);
        let axes = coord_slices.as_slice();
        let expected_points: Vec<f64> = (0..n)
            .flat_map(|i| (0..3).map(move |a| axes.get(a).map_or(0.0, |x| x[i])))
            .collect();
        assert_eq!(bits(&summary.points), bits(&expected_points));
        assert_eq!(summary.arrays.len(), 3);
        for (array, (name, components, values)) in arrays.iter().zip(&summary.arrays) {
            assert_eq!(name, array.name);
            assert_eq!(*components, array.components.len());
            let interleaved: Vec<f64> = (0..n)
                .flat_map(|i| array.components.iter().map(move |c| c[i]))
                .collect();
            assert_eq!(bits(values), bits(&interleaved), "array {name}");
        }

        let (connectivity, offsets, types) = cells(&text);
        assert_eq!(connectivity, (0..n as i64).collect::<Vec<_>>());
        assert_eq!(offsets, (1..=n as i64).collect::<Vec<_>>());
        assert_eq!(types, vec![1u8; n]);
        // Atomic write leaves no temporary file behind.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn round_trip_2d() {
        check_round_trip(2);
    }

    #[test]
    fn round_trip_3d() {
        check_round_trip(3);
    }

    #[test]
    fn round_trip_1d_and_nan_bits() {
        let x = [0.5, -0.0, 2.5];
        let payload_nan = f64::from_bits(0x7ff8_0000_dead_beef);
        let s = [f64::NAN, payload_nan, -f64::NAN];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.vtu");
        let arrays = [PointArray {
            name: "s",
            components: vec![&s],
        }];
        write_vtu(&path, &[&x], &arrays).unwrap();
        let summary = read_vtu_summary(&std::fs::read_to_string(&path).unwrap()).unwrap();
        assert_eq!(
            bits(&summary.points),
            bits(&[0.5, 0.0, 0.0, -0.0, 0.0, 0.0, 2.5, 0.0, 0.0])
        );
        assert_eq!(bits(&summary.arrays[0].2), bits(&s));
    }

    #[test]
    fn larger_than_the_encoder_stage() {
        // Several stage flushes, with a byte count that is not a multiple of 3.
        let n = 1000;
        let x: Vec<f64> = (0..n).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.vtu");
        let arrays = [PointArray {
            name: "v",
            components: vec![&y, &x],
        }];
        write_vtu(&path, &[&x, &y], &arrays).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_balanced(&text);
        let summary = read_vtu_summary(&text).unwrap();
        assert_eq!(summary.n_points, n);
        let expected: Vec<f64> = (0..n).flat_map(|i| [y[i], x[i]]).collect();
        assert_eq!(bits(&summary.arrays[0].2), bits(&expected));
        let (_, _, types) = cells(&text);
        assert_eq!(types, vec![1u8; n]);
    }

    #[test]
    fn zero_points_writes_a_valid_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("empty.vtu");
        let empty: &[f64] = &[];
        let arrays = [PointArray {
            name: "velocity",
            components: vec![empty, empty],
        }];
        write_vtu(&path, &[empty, empty], &arrays).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_balanced(&text);
        assert!(text.contains("NumberOfPoints=\"0\" NumberOfCells=\"0\""));
        let summary = read_vtu_summary(&text).unwrap();
        assert_eq!(
            summary,
            VtuSummary {
                n_points: 0,
                n_cells: 0,
                arrays: vec![("velocity".to_string(), 2, vec![])],
                points: vec![],
            }
        );
        let (c, o, t) = cells(&text);
        assert!(c.is_empty() && o.is_empty() && t.is_empty());
        // No arrays at all is fine too.
        write_vtu(&path, &[empty], &[]).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_balanced(&text);
        assert!(read_vtu_summary(&text).unwrap().arrays.is_empty());
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.vtu");
        let a = [1.0, 2.0, 3.0];
        let b = [1.0, 2.0];
        let ok = PointArray {
            name: "m",
            components: vec![&a],
        };
        let cases: Vec<(Vec<&[f64]>, Vec<PointArray>)> = vec![
            (vec![], vec![]),
            (vec![&a, &a, &a, &a], vec![]),
            (vec![&a, &b], vec![]),
            (
                vec![&a],
                vec![PointArray {
                    name: "m",
                    components: vec![&b],
                }],
            ),
            (
                vec![&a, &a],
                vec![PointArray {
                    name: "v",
                    components: vec![&a, &b, &a],
                }],
            ),
            (
                vec![&a],
                vec![PointArray {
                    name: "m",
                    components: vec![],
                }],
            ),
            (
                vec![&a],
                vec![PointArray {
                    name: "",
                    components: vec![&a],
                }],
            ),
            (vec![&a], vec![ok.clone(), ok.clone()]),
        ];
        for (coords, arrays) in &cases {
            let err = write_vtu(&path, coords, arrays).unwrap_err();
            assert!(matches!(err, Error::WriteOutput { .. }), "{err}");
            assert!(err.to_string().contains("bad.vtu"), "{err}");
        }
        assert!(!path.exists());
        // A missing directory is an error too.
        let missing = dir.path().join("no/such/dir/p.vtu");
        assert!(write_vtu(&missing, &[&a], &[ok]).is_err());
        assert!(write_pvd(&dir.path().join("no/x.pvd"), &[]).is_err());
        // Bad pvd entries.
        let pvd = dir.path().join("bad.pvd");
        assert!(write_pvd(&pvd, &[(f64::NAN, "a.vtu".into())]).is_err());
        assert!(write_pvd(&pvd, &[(0.0, String::new())]).is_err());
        assert!(!pvd.exists());
    }

    #[test]
    fn pvd_lists_every_entry_with_its_timestep() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("particles.pvd");
        let times = [0.0, 1e-9, 0.1, 1.0 / 3.0, 2.5, 1e20];
        let entries: Vec<(f64, String)> = times
            .iter()
            .enumerate()
            .map(|(k, &t)| (t, format!("particles_{k:04}.vtu")))
            .collect();
        write_pvd(&path, &entries).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_balanced(&text);
        assert!(text.contains("<VTKFile type=\"Collection\""));
        let mut from = 0;
        let mut found = Vec::new();
        while let Some((_, tag, end)) = find_start_tag(&text, from, "DataSet") {
            assert!(tag.ends_with("/>"));
            assert_eq!(attribute(tag, "group").as_deref(), Some(""));
            assert_eq!(attribute(tag, "part").as_deref(), Some("0"));
            let t: f64 = attribute(tag, "timestep").unwrap().parse().unwrap();
            found.push((t, attribute(tag, "file").unwrap()));
            from = end;
        }
        assert_eq!(found.len(), entries.len());
        for ((t, file), (t0, file0)) in found.iter().zip(&entries) {
            assert_eq!(t.to_bits(), t0.to_bits());
            assert_eq!(file, file0);
        }
        // Empty collection is valid.
        write_pvd(&path, &[]).unwrap();
        assert_balanced(&std::fs::read_to_string(&path).unwrap());
    }

    #[test]
    fn base64_rfc4648_vectors() {
        let vectors = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (plain, encoded) in vectors {
            assert_eq!(encode_base64(plain.as_bytes()), encoded);
            assert_eq!(decode_base64(encoded).unwrap(), plain.as_bytes());
        }
        assert_eq!(encode_base64(&[0xfb, 0xff, 0xbf]), "+/+/");
    }

    #[test]
    fn base64_rejects_malformed_text() {
        for bad in [
            "Zm9", "Zg=", "Z===", "=g==", "Zg==Zg==", "Zm=v", "Zm9v!A==", "Zm9vYg",
        ] {
            assert_eq!(decode_base64(bad), None, "{bad}");
        }
        assert_eq!(decode_base64(" Zm\n9v\tYg== \n").unwrap(), b"foob");
    }

    #[test]
    fn reader_rejects_inconsistent_files() {
        assert_eq!(read_vtu_summary(""), None);
        assert_eq!(read_vtu_summary("<VTKFile>"), None);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.vtu");
        let x = [1.0, 2.0];
        write_vtu(&path, &[&x], &[]).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(read_vtu_summary(&text).is_some());
        let wrong_count = text.replace("NumberOfPoints=\"2\"", "NumberOfPoints=\"3\"");
        assert_eq!(read_vtu_summary(&wrong_count), None);
    }

    proptest! {
        #[test]
        fn base64_round_trips(bytes in proptest::collection::vec(any::<u8>(), 0..5000)) {
            let encoded = encode_base64(&bytes);
            prop_assert_eq!(encoded.len(), bytes.len().div_ceil(3) * 4);
            prop_assert_eq!(decode_base64(&encoded), Some(bytes));
        }

        #[test]
        fn streaming_encoder_matches_one_shot(
            bytes in proptest::collection::vec(any::<u8>(), 0..8000),
            cuts in proptest::collection::vec(0usize..8000, 0..12),
        ) {
            let mut cuts: Vec<usize> = cuts.into_iter().map(|c| c.min(bytes.len())).collect();
            cuts.sort_unstable();
            let mut out = Vec::new();
            let mut encoder = Base64Encoder::new(&mut out);
            let mut start = 0;
            for cut in cuts.into_iter().chain([bytes.len()]) {
                encoder.push(&bytes[start..cut]);
                start = cut;
            }
            encoder.finish();
            prop_assert_eq!(String::from_utf8(out).unwrap(), encode_base64(&bytes));
        }
    }
}
