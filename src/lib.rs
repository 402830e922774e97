//! balloonseg: segmentation of an anatomical structure from a CT or MR volume by inflating a
//! triangulated balloon from a seed point, with topology repair by a signed-distance map and
//! marching cubes (see `README.md` and the paper it follows).
//!
//! The geometry kernels are public on their own: marching cubes, self-intersection detection,
//! signed distance and mesh checks. Everything works on borrowed, strided volumes of any
//! supported scalar type and produces meshes in world millimetres.

pub mod error;
pub mod geometry;
#[cfg(feature = "io")]
pub mod io;
pub mod mesh;
pub mod predicates;
pub mod self_intersection;
pub mod spatial_hash;
pub mod triangle_intersection;
pub mod volume;

pub use error::{Error, ErrorKind, Result};
pub use geometry::Geometry;
pub use mesh::TriMesh;
pub use volume::{Image, Scalar, ScalarType, TypedVolume, Volume, VoxelBuffer, VoxelVisitor};
