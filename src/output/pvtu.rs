//! The `.pvtu` index of a distributed run's VTU output (`docs/distributed.md`): every rank
//! writes its particles as one `.vtu` piece ([`super::vtu::write_vtu`]) and rank 0 writes
//! a VTK XML `PUnstructuredGrid` that names the pieces and declares their point-data
//! arrays, so that ParaView opens the pieces of one time as one data set (and the run's
//! `.pvd` lists the `.pvtu` files).
//!
//! Reference: VTK file formats, "Parallel File Formats":
//! <https://docs.vtk.org/en/latest/vtk_file_formats/vtkxml_file_format.html#parallel-file-formats>

use super::vtu::escape_xml;
use super::write_atomic;
use crate::error::{Error, Result};
use std::path::Path;

/// Write `path`, a `.pvtu` over the `pieces` (file names relative to the directory of
/// `path`, one per rank), whose point data are `arrays` = `(name, components)`, the
/// `Float64` arrays of [`super::vtu::write_vtu`] in the same order.
///
/// ```
/// # let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("particles_0001.pvtu");
/// let pieces = ["particles_0001_0000.vtu".to_string(), "particles_0001_0001.vtu".to_string()];
/// tlsmpm::output::pvtu::write_pvtu(&path, &[("velocity", 2)], &pieces).unwrap();
/// let text = std::fs::read_to_string(&path).unwrap();
/// assert!(text.contains("<Piece Source=\"particles_0001_0001.vtu\"/>"));
/// assert!(text.contains("Name=\"velocity\" NumberOfComponents=\"2\""));
/// ```
///
/// # Errors
/// [`Error::WriteOutput`] naming `path` for no pieces, an empty piece or array name, or if
/// the file cannot be written.
pub fn write_pvtu(path: &Path, arrays: &[(&str, usize)], pieces: &[String]) -> Result<()> {
    if pieces.is_empty() || pieces.iter().any(String::is_empty) {
        return Err(Error::write(path, "a .pvtu needs named pieces"));
    }
    if arrays.iter().any(|(name, c)| name.is_empty() || *c == 0) {
        return Err(Error::write(path, "an array without a name or components"));
    }
    let mut out = String::with_capacity(512 + 64 * (arrays.len() + pieces.len()));
    out.push_str("<?xml version=\"1.0\"?>\n");
    out.push_str(
        "<VTKFile type=\"PUnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" \
         header_type=\"UInt64\">\n",
    );
    out.push_str("  <PUnstructuredGrid GhostLevel=\"0\">\n");
    out.push_str("    <PPointData>\n");
    for (name, components) in arrays {
        out.push_str(&format!(
            "      <PDataArray type=\"Float64\" Name=\"{}\" NumberOfComponents=\"{components}\"/>\n",
            escape_xml(name)
        ));
    }
    out.push_str("    </PPointData>\n");
    out.push_str("    <PPoints>\n");
    out.push_str("      <PDataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\"/>\n");
    out.push_str("    </PPoints>\n");
    out.push_str("    <PCells>\n");
    out.push_str("      <PDataArray type=\"Int64\" Name=\"connectivity\"/>\n");
    out.push_str("      <PDataArray type=\"Int64\" Name=\"offsets\"/>\n");
    out.push_str("      <PDataArray type=\"UInt8\" Name=\"types\"/>\n");
    out.push_str("    </PCells>\n");
    for piece in pieces {
        out.push_str(&format!("    <Piece Source=\"{}\"/>\n", escape_xml(piece)));
    }
    out.push_str("  </PUnstructuredGrid>\n");
    out.push_str("</VTKFile>\n");
    write_atomic(path, out.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_index_names_every_piece_and_array_and_refuses_an_empty_one() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.pvtu");
        let pieces: Vec<String> = (0..3).map(|r| format!("p_{r:04}.vtu")).collect();
        write_pvtu(&path, &[("stress", 6), ("mass", 1)], &pieces).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text.matches("<Piece Source=").count(), 3);
        assert!(text.contains("Name=\"stress\" NumberOfComponents=\"6\""));
        assert!(text.find("stress").unwrap() < text.find("mass").unwrap());
        assert!(write_pvtu(&path, &[("mass", 1)], &[]).is_err());
        assert!(write_pvtu(&path, &[("", 1)], &pieces).is_err());
    }
}
