//! The geometry and image kernels, each usable on its own and each its own module: marching
//! cubes, self-intersection detection (with the exact triangle-pair test and the predicates under
//! it), signed distance (with closest points and winding numbers), mesh checks, the Gaussian
//! smoothing the balloon reads the image through, and the distance transforms, voxel morphology
//! and digital topology the finishing steps use. The crate root re-exports them
//! (`balloonseg::marching_cubes`, ...); this folder only keeps them together on disk.

pub mod closest_point;
pub mod digital_topology;
pub(crate) mod disjoint_sets;
pub mod distance_transform;
pub mod marching_cubes;
pub(crate) mod mask_voxels;
pub mod mesh_checks;
pub mod morphology;
pub mod predicates;
pub mod self_intersection;
pub mod signed_distance;
pub mod simplification;
pub mod smoothed_volume;
pub mod spatial_hash;
pub mod triangle_intersection;
pub mod winding_number;
