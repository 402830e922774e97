//! balloonseg: segmentation of an anatomical structure from a CT or MR volume by inflating a
//! triangulated balloon from a seed point, with topology repair by a signed-distance map and
//! marching cubes (see `README.md`, `docs/method.md` and the paper it follows).
//!
//! The geometry kernels are public on their own: marching cubes, self-intersection detection,
//! signed distance and mesh checks. Everything works on borrowed, strided volumes of any
//! supported scalar type and produces meshes in world millimetres.

mod allocation;
pub mod balloon;
pub mod error;
pub mod evaluation;
pub mod ffi;
pub mod geometry;
#[cfg(feature = "io")]
pub mod io;
mod kernels;
pub mod mesh;
#[cfg(feature = "ndarray")]
pub mod ndarray_volume;
pub mod phantom;
#[cfg(feature = "io")]
pub mod render;
mod thread_pool;
pub mod volume;

// The kernels live together in src/kernels/ and are reached from the root, as before.
pub(crate) use kernels::disjoint_sets;
pub use kernels::{
    closest_point, digital_topology, distance_transform, marching_cubes, mesh_checks, morphology,
    predicates, self_intersection, signed_distance, simplification, smoothed_volume, spatial_hash,
    triangle_intersection, winding_number,
};

pub use error::{Error, ErrorKind, Result};
pub use geometry::Geometry;
pub use mesh::TriMesh;
#[cfg(feature = "ndarray")]
pub use ndarray_volume::AxisOrder;
pub use signed_distance::{signed_distance, SignedDistanceOptions};
pub use volume::{Image, Scalar, ScalarType, TypedVolume, Volume, VoxelBuffer, VoxelVisitor};
