//! File formats. The image readers and writers (MetaImage, NRRD, NIfTI-1) produce and consume
//! [`crate::volume::Image`] in ITK's LPS world space (SPEC "Coordinates"); each module has
//! `read(path)` and `write(path, image)`.

mod compression;
pub mod metaimage;
pub mod nifti;
pub mod nrrd;
#[cfg(test)]
mod test_images;
mod text_header;
