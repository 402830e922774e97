//! File formats for volumes and meshes, chosen by file extension (feature `io`): MetaImage,
//! NRRD, NIfTI-1, legacy VTK and VTK XML images, and a folder holding a DICOM series; VTK, VTP,
//! PLY, STL, OBJ and OFF meshes.
//!
//! Every reader checks each count it reads against the bytes that remain before allocating for
//! it, and reports corrupt or truncated input as an error of kind `Format` that names the file
//! and the place, never as a panic. Most load the whole file and parse it from memory; NIfTI,
//! and MetaImage voxels that follow their header, are streamed from the file into the image's
//! buffer (checked against the file's size), so that a full-size volume is not held twice.
//! Images are in ITK's LPS world space (docs/interfaces.md, "Coordinates").

mod compression;
pub(crate) mod files;
mod point_data;
mod polygons;
mod progress;
mod scan;
#[cfg(test)]
mod test_images;
#[cfg(test)]
mod test_support;
mod text_header;
mod vtk_xml_data;
mod xml;

pub mod dicom;
pub mod metaimage;
pub mod nifti;
pub mod nrrd;
pub mod obj;
pub mod off;
pub mod ply;
pub mod stl;
pub mod vtk_legacy;
pub mod vtk_xml;

use std::path::Path;

use crate::{Error, Image, Result, TriMesh};
pub use point_data::{CellData, PointData, PointValues};
pub use progress::{ReadProgress, ReadStage};

/// The volume extensions [`read_image`] understands.
pub const IMAGE_READ_FORMATS: &str =
    ".mha, .mhd, .nrrd, .nhdr, .nii, .nii.gz, .vti, .vtk, or a folder holding a DICOM series";
/// The volume extensions [`write_image`] understands.
pub const IMAGE_WRITE_FORMATS: &str = ".mha, .nrrd, .nii.gz";
/// The mesh extensions [`read_mesh`] and [`write_mesh`] understand.
pub const MESH_FORMATS: &str = ".vtp, .vtk, .ply, .stl, .obj, .off";

/// The lower-case extension, with `.nii.gz` kept whole.
fn extension(path: &Path) -> String {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_lowercase())
        .unwrap_or_default();
    if name.ends_with(".nii.gz") {
        return "nii.gz".to_string();
    }
    path.extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default()
}

fn unsupported(path: &Path, what: &str, formats: &str) -> Error {
    Error::invalid_argument(format!(
        "{}: cannot tell the {what} format from the extension; use one of {formats}",
        path.display()
    ))
}

/// Reads a volume: a folder is a DICOM series (the one it holds), a file's format follows the
/// extension.
pub fn read_image(path: &Path) -> Result<Image> {
    read_image_series(path, None)
}

/// [`read_image`], with the DICOM series chosen by its SeriesInstanceUID when `series` is given
/// (for a folder holding several); a chosen series for a file is an error.
pub fn read_image_series(path: &Path, series: Option<&str>) -> Result<Image> {
    if path.is_dir() {
        return dicom::read(path, series);
    }
    if let Some(uid) = series {
        return Err(Error::invalid_argument(format!(
            "{}: a DICOM series ({uid}) can only be chosen in a folder of DICOM files, and this \
             is a file; drop the series choice or give the folder",
            path.display()
        )));
    }
    match extension(path).as_str() {
        "mha" | "mhd" => metaimage::read(path),
        "nrrd" | "nhdr" => nrrd::read(path),
        "nii" | "nii.gz" => nifti::read(path),
        "vti" => vtk_xml::read_vti(path),
        "vtk" => vtk_legacy::read_image(path),
        _ => Err(unsupported(path, "volume", IMAGE_READ_FORMATS)),
    }
}

/// [`read_image_series`], telling `progress` how far the read has come, stage by stage
/// (reading the file, inflating it, decoding a DICOM series); it may cancel the read, which
/// then ends with an error of kind `Cancelled`. The read reports on the calling thread.
pub fn read_image_reporting(
    path: &Path,
    series: Option<&str>,
    progress: ReadProgress,
) -> Result<Image> {
    progress::reporting(progress, || read_image_series(path, series))
}

/// Writes a volume; the format follows the extension.
pub fn write_image(path: &Path, image: &Image) -> Result<()> {
    match extension(path).as_str() {
        "mha" => metaimage::write(path, image),
        "nrrd" => nrrd::write(path, image),
        "nii.gz" => nifti::write(path, image),
        _ => Err(unsupported(path, "volume", IMAGE_WRITE_FORMATS)),
    }
}

/// Reads a triangle mesh (polygons are fan-triangulated); the format follows the extension.
pub fn read_mesh(path: &Path) -> Result<TriMesh> {
    match extension(path).as_str() {
        "vtp" => vtk_xml::read_vtp(path),
        "vtk" => vtk_legacy::read_mesh(path),
        "ply" => ply::read(path),
        "stl" => stl::read(path),
        "obj" => obj::read(path),
        "off" => off::read(path),
        _ => Err(unsupported(path, "mesh", MESH_FORMATS)),
    }
}

/// Writes a mesh with optional per-point arrays (kept by .vtp, .vtk and .ply; the other formats
/// have no place for them).
pub fn write_mesh(path: &Path, mesh: &TriMesh, point_data: &[PointData]) -> Result<()> {
    write_mesh_with_cells(path, mesh, point_data, &[])
}

/// Whether the mesh format of `path` can hold the triangle array `name` (.vtp, .vtk and .ply
/// can): a caller about to compute one checks before the work, not after it.
pub fn check_holds_cell_data(path: &Path, name: &str) -> Result<()> {
    let extension = extension(path);
    if matches!(extension.as_str(), "stl" | "obj" | "off") {
        return Err(Error::invalid_argument(format!(
            "{}: {} cannot hold the triangle array {name:?}; write .vtp, .vtk or .ply, or one \
             file per object",
            path.display(),
            extension.to_uppercase(),
        )));
    }
    Ok(())
}

/// [`write_mesh`] with per-triangle integer arrays too, such as `object`, the label of each
/// triangle when several segmented objects share one file. Only .vtp, .vtk and .ply can hold
/// them; for .stl, .obj and .off, cell data is an error and nothing is written, since dropping
/// the labels would leave one unlabelled surface.
pub fn write_mesh_with_cells(
    path: &Path,
    mesh: &TriMesh,
    point_data: &[PointData],
    cell_data: &[CellData],
) -> Result<()> {
    if let Some(data) = cell_data.first() {
        check_holds_cell_data(path, data.name)?;
    }
    match extension(path).as_str() {
        "vtp" => {
            let compression = vtk_xml::Compression::default();
            vtk_xml::write_vtp_with_cells(path, mesh, point_data, cell_data, compression)
        }
        "vtk" => vtk_legacy::write_mesh_with_cells(path, mesh, point_data, cell_data),
        "ply" => ply::write_with_cells(path, mesh, point_data, cell_data),
        "stl" => stl::write(path, mesh, point_data),
        "obj" => obj::write(path, mesh, point_data),
        "off" => off::write(path, mesh),
        _ => Err(unsupported(path, "mesh", MESH_FORMATS)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_shapes::cube;
    use crate::ErrorKind;
    use glam::DVec3;

    #[test]
    fn cell_data_is_refused_before_anything_is_written_where_it_cannot_be_kept() {
        let dir = test_images::scratch_dir();
        let mesh = cube(DVec3::ZERO, DVec3::ONE);
        let labels = [1; 12];
        let object = |values| {
            [CellData {
                name: "object",
                values,
            }]
        };
        for extension in ["vtp", "vtk", "ply", "stl", "obj", "off"] {
            let path = dir.path().join(format!("mesh.{extension}"));
            let e = write_mesh_with_cells(&path, &mesh, &[], &object(&labels[..11])).unwrap_err();
            assert_eq!(e.kind(), ErrorKind::InvalidArgument, "{e}");
            assert!(!path.exists(), "{extension}");
            let written = write_mesh_with_cells(&path, &mesh, &[], &object(&labels));
            if matches!(extension, "vtp" | "vtk" | "ply") {
                written.unwrap();
                assert_eq!(read_mesh(&path).unwrap(), mesh);
            } else {
                let e = written.unwrap_err();
                assert_eq!(e.kind(), ErrorKind::InvalidArgument, "{e}");
                let format = extension.to_uppercase();
                let needle = format!("{format} cannot hold the triangle array \"object\"");
                assert!(e.message().contains(&needle), "{e}");
                assert!(!path.exists(), "{extension}");
            }
        }
    }
}
