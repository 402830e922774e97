//! File formats for volumes and meshes, chosen by file extension (feature `io`).
//!
//! Every reader turns a corrupt or truncated file into an error that names the file and what is
//! wrong; none of them panics or trusts a size it has not checked against the file.

mod compression;
pub mod metaimage;
pub mod nifti;
pub mod nrrd;
#[cfg(test)]
mod test_images;
mod text_header;

use std::path::Path;

use crate::{Error, Image, Result};

/// The volume extensions [`read_image`] understands.
pub const IMAGE_READ_FORMATS: &str = ".mha, .mhd, .nrrd, .nhdr, .nii, .nii.gz";
/// The volume extensions [`write_image`] understands.
pub const IMAGE_WRITE_FORMATS: &str = ".mha, .nrrd, .nii.gz";
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

/// Reads a volume; the format follows the extension.
pub fn read_image(path: &Path) -> Result<Image> {
    match extension(path).as_str() {
        "mha" | "mhd" => metaimage::read(path),
        "nrrd" | "nhdr" => nrrd::read(path),
        "nii" | "nii.gz" => nifti::read(path),
        _ => Err(unsupported(path, "volume", IMAGE_READ_FORMATS)),
    }
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
