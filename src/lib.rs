//! balloonseg: segmentation of an anatomical structure from a CT or MR volume by inflating a
//! triangulated balloon from a seed point, with topology repair by a signed-distance map and
//! marching cubes (see `README.md`, `docs/method.md` and the paper it follows).
//!
//! The geometry kernels are public on their own: marching cubes, self-intersection detection,
//! signed distance and mesh checks. Everything works on borrowed, strided volumes of any
//! supported scalar type and produces meshes in world millimetres.

pub mod balloon;
pub mod closest_point;
pub mod digital_topology;
mod disjoint_sets;
pub mod error;
pub mod evaluation;
pub mod ffi;
pub mod geometry;
#[cfg(feature = "io")]
pub mod io;
pub mod marching_cubes;
pub mod mesh;
pub mod mesh_checks;
pub mod morphology;
#[cfg(feature = "ndarray")]
pub mod ndarray_volume;
pub mod phantom;
pub mod predicates;
#[cfg(feature = "io")]
pub mod render;
pub mod self_intersection;
pub mod signed_distance;
pub mod smoothed_volume;
pub mod spatial_hash;
#[doc(hidden)]
pub mod test_data;
pub mod triangle_intersection;
pub mod volume;
pub mod winding_number;

pub use error::{Error, ErrorKind, Result};
pub use geometry::Geometry;
pub use mesh::TriMesh;
#[cfg(feature = "ndarray")]
pub use ndarray_volume::AxisOrder;
pub use signed_distance::{signed_distance, SignedDistanceOptions};
pub use volume::{Image, Scalar, ScalarType, TypedVolume, Volume, VoxelBuffer, VoxelVisitor};
