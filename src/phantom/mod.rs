//! Synthetic test volumes with known answers.
//!
//! - `shapes`: six fixed analytic shapes (sphere, torus, double torus, Y vessel, touching tubes,
//!   fading tube) on a grid the caller chooses — [`render`] with [`PhantomOptions`].
//! - `families`: families of scenes drawn at random from a variant number (a CT-like scene, thin
//!   walls, touching tubes, thin vessels around a ring, a stent) with random grids, blur and
//!   noise — [`Family::variant`] — to judge the balloon on scans it was never tuned on.
//! - `angiogram`: a CT angiogram of the abdomen at clinical size (an aorta with its renal and
//!   iliac branches, 512×512×600 voxels or any size asked for) — [`Angiogram::new`].
//!
//! Underneath: `sdf` (signed distances of the solids and their set operations), `tube`
//! (polyline tubes with the arc length of the nearest point), `scene` (layers of solids
//! composited with partial-volume voxels), `grid` (the voxel grid around what matters),
//! `imaging` (blur, bias, noise, rounding) and `random` (SplitMix64 and the draws built on it).
//! Everything is deterministic: the same inputs give the same bytes for any thread count.

use crate::error::{Error, Result};

mod angiogram;
mod families;
mod grid;
mod imaging;
pub(crate) mod random;
mod scene;
mod sdf;
mod shapes;
mod tube;

pub use angiogram::Angiogram;
pub use families::{Family, Parameter, Variant, VOXEL_BUDGET};
pub use shapes::{oblique_direction, render, Phantom, PhantomOptions, Shape};

/// The item of `all` called `wanted`, or an error that lists the names (`what` says of what).
fn named<T: Copy>(all: &[T], name: fn(T) -> &'static str, wanted: &str, what: &str) -> Result<T> {
    all.iter()
        .copied()
        .find(|&t| name(t) == wanted)
        .ok_or_else(|| {
            let names: Vec<_> = all.iter().map(|&t| name(t)).collect();
            Error::invalid_argument(format!(
                "unknown {what} '{wanted}'; choose one of {}",
                names.join(", ")
            ))
        })
}
