//! Placing a solid next to a tube at a drawn wall-to-wall gap.
//!
//! The gap between a tube of constant radius and a convex solid is the smallest distance from
//! the tube's centre line to the solid, minus the radius. The distance to a convex solid is a
//! convex function along each straight segment of the centre line, so a golden-section search
//! finds its minimum there (segments whose ends are too far to beat the best so far are
//! skipped: the distance is 1-Lipschitz). Moving the solid away along a direction opens the gap;
//! bisection finds the offset at which it is the drawn one.

use glam::DVec3;

use crate::error::{Error, Result};
use crate::phantom::sdf::Sdf;

/// The smallest value of `solid`'s distance along the polyline `line`, assuming it is convex
/// along each segment.
pub fn min_along(line: &[DVec3], solid: &dyn Sdf) -> f64 {
    let mut best = line
        .iter()
        .map(|&p| solid.distance(p))
        .fold(f64::INFINITY, f64::min);
    for w in line.windows(2) {
        let (a, b) = (w[0], w[1]);
        let half = 0.5 * a.distance(b);
        if solid.distance(a).min(solid.distance(b)) - half >= best {
            continue;
        }
        best = best.min(golden_section(|t| solid.distance(a.lerp(b, t))));
    }
    best
}

/// The minimum over [0, 1] of a convex function.
fn golden_section(f: impl Fn(f64) -> f64) -> f64 {
    let ratio = 0.5 * (5f64.sqrt() - 1.0);
    let (mut lo, mut hi) = (0.0, 1.0);
    let mut x1 = hi - ratio * (hi - lo);
    let mut x2 = lo + ratio * (hi - lo);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..60 {
        if f1 <= f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - ratio * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + ratio * (hi - lo);
            f2 = f(x2);
        }
    }
    f1.min(f2).min(f(0.0)).min(f(1.0))
}

/// The solid `at(t)` whose gap to the tube of `radius` along `line` is `gap`. Moving away as t
/// grows, it must reach the tube's wall (gap ≤ 0) at t = `touching`; an error when no offset up
/// to 10 mm beyond the drawn gap opens it that far.
pub fn place_beside<S: Sdf>(
    line: &[DVec3],
    radius: f64,
    gap: f64,
    touching: f64,
    at: impl Fn(f64) -> S,
) -> Result<S> {
    let gap_at = |t: f64| min_along(line, &at(t)) - radius;
    let (mut lo, mut hi) = (touching, touching + gap + 10.0);
    if !(gap_at(lo) <= gap && gap_at(hi) >= gap) {
        return Err(Error::internal(format!(
            "no offset in {lo}..{hi} gives a gap of {gap} mm (gaps {} and {})",
            gap_at(lo),
            gap_at(hi)
        )));
    }
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if gap_at(mid) < gap {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(at(0.5 * (lo + hi)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phantom::sdf::Capsule;

    #[test]
    fn a_capsule_is_placed_at_the_drawn_gap_from_a_bent_line() {
        let line: Vec<DVec3> = (0..=40)
            .map(|i| {
                let a = (i as f64 - 20.0) * 0.02;
                DVec3::new(60.0 * (1.0 - a.cos()), 0.0, 60.0 * a.sin())
            })
            .collect();
        let direction = DVec3::new(1.0, 1.0, 0.0).normalize();
        let place = |t: f64| Capsule {
            a: direction * t - DVec3::Z * 20.0,
            b: direction * t + DVec3::Z * 20.0,
            radius: 3.0,
        };
        let placed = place_beside(&line, 5.0, 2.0, 8.0, place).unwrap();
        assert!((min_along(&line, &placed) - 5.0 - 2.0).abs() < 1e-9);
        // Against a scan of fine samples of the line.
        let fine = line
            .windows(2)
            .flat_map(|w| (0..=1000).map(move |i| w[0].lerp(w[1], i as f64 / 1000.0)))
            .map(|p| placed.distance(p))
            .fold(f64::INFINITY, f64::min);
        assert!((fine - 5.0 - 2.0).abs() < 1e-6, "{fine}");
        assert!(place_beside(&line, 5.0, 2.0, 20.0, place).is_err());
    }
}
