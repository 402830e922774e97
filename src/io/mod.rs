//! File formats: surface meshes (legacy VTK, VTK XML PolyData, PLY, STL, OBJ) and images
//! (legacy VTK structured points, VTK XML ImageData).
//!
//! Every reader loads the whole file, checks each count it reads against the bytes that remain
//! before allocating for it, and reports corrupt or truncated input as an [`Error`] of kind
//! `Format` that names the file and the place, never as a panic.
//!
//! [`Error`]: crate::Error

mod files;
mod point_data;
mod polygons;
mod scan;
#[cfg(test)]
mod test_support;
mod vtk_xml_data;
mod xml;

pub mod obj;
pub mod ply;
pub mod stl;
pub mod vtk_legacy;
pub mod vtk_xml;

pub use point_data::{PointData, PointValues};
