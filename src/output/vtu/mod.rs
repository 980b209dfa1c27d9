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

mod base64;
mod read;
#[cfg(test)]
mod tests;

use base64::Base64Encoder;
pub use base64::{decode_base64, encode_base64};
pub use read::{read_vtu_summary, VtuSummary};

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
