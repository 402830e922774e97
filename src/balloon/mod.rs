//! The balloon of the paper (section 2): a closed triangulated surface that starts as a small
//! sphere at a seed and is inflated by per-vertex forces. `surface` holds its dynamic mesh — a
//! half-edge structure whose edges are split when they grow too long and collapsed when they
//! become too short, always staying a closed, oriented 2-manifold — on which the forces work.

pub mod border;
mod contact_search;
mod curvature_offset;
mod fairing;
mod fast_hash;
pub mod forces;
mod front;
mod hounsfield;
mod inflation;
pub mod params;
mod remesh;
mod reparametrize;
pub mod seed_statistics;
mod segmenter;
mod settling;
pub mod surface;
mod thin_layer;
mod touching;
mod untangle;

pub use params::BalloonParams;
pub use segmenter::{Phase, PhaseSeconds, ProgressCallback, SegmentationStats, Segmenter};
pub use surface::VertexState;
