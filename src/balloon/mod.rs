//! The balloon of the paper (docs/method.md maps its sections to these modules): a closed
//! triangulated surface that starts as a small sphere at each seed and is inflated by
//! per-vertex forces until it meets the structure's border or itself.
//!
//! | the paper | here |
//! |---|---|
//! | the balloon's dynamic mesh (section 2, Figure 1) | [`surface`]: the half-edge mesh, its remeshing and its moving front |
//! | where it may go (section 2's reference value and threshold) | [`image_model`]: the intensity window from the seed, and the border rule |
//! | step 1, inflation (section 2) | [`inflation`]: forces, steps, the leak guard, equilibrium |
//! | step 2, contacts and freezing (section 3) | `contacts`: the contact search, folds told from contacts |
//! | step 3, re-parametrisation (section 3) | `reparametrization`: signed distance and marching cubes |
//! | step 4, refinement (section 3) | [`inflation`] again, from the new surface |
//! | what follows | `finishing`: the touching cut, fairing, settling, the curvature offset, validation |
//! | the conclusion's future work: balloons from several seeds that stop at each other | [`objects`] |
//!
//! [`Segmenter`] drives them (`segmenter`), step by step or to completion, with [`params`] and
//! [`progress`].

mod contacts;
pub(crate) mod fast_hash;
mod finishing;
pub mod image_model;
pub mod inflation;
pub mod objects;
pub mod params;
pub mod progress;
mod reparametrization;
mod segmenter;
pub mod surface;

pub use image_model::region::Region;
pub use inflation::forces::ForceWeights;
pub use objects::{
    segment_objects, simplify_objects, ObjectSeeds, ObjectsRequest, SegmentedObject,
};
pub use params::BalloonParams;
pub use progress::{Phase, PhaseSeconds, ProgressCallback};
pub use segmenter::{SegmentationStats, Segmenter};
pub use surface::VertexState;
