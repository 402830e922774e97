//! Fairing of the finished surface: Taubin's λ|μ smoothing (G. Taubin, "A signal processing
//! approach to fair surface design", SIGGRAPH 1995).
//!
//! Each vertex of the balloon stops where the smoothed intensity along its own path first
//! leaves the window (`border`): one noisy threshold crossing per vertex, so the finished
//! surface ripples from triangle to triangle (fairing moves the vmtk aorta's surface by 0.07 mm
//! on average across itself, 0.18 mm at the 95th percentile). The structures it
//! segments are smooth at that scale, so the ripple is error: Taubin's filter removes it —
//! a low-pass filter on the surface, alternating a shrinking umbrella step (λ) with an
//! inflating one (μ), which unlike plain Laplacian smoothing leaves the surface's size and
//! shape alone. Its constants are the usual ones, also VTK's defaults for its windowed-sinc
//! variant: pass band 0.1, 20 passes.
//!
//! Measured with the analytic phantoms as ground truth, the mean distance falls by 14–46%
//! (sphere 0.063 → 0.034 mm, Y vessel 0.088 → 0.069 mm, touching tubes 0.157 → 0.135 mm;
//! BENCHMARKS.md). Fairing can bring two close sheets into contact: `restore` puts the
//! unfaired positions back around them.

use glam::DVec3;

use crate::balloon::surface::Surface;

/// Taubin's filter: λ, μ = 1/(k − 1/λ) for pass band k = 0.1, and λ|μ passes.
const LAMBDA: f64 = 0.5;
const MU: f64 = -0.53;
const PASSES: usize = 20;

/// Fairs `surface` in place; returns the positions before, by slot, for [`restore`]. The
/// same result for any thread count ([`Surface::umbrella_pass`]).
pub(in crate::balloon) fn fair(surface: &mut Surface) -> Vec<DVec3> {
    let before = surface.positions().to_vec();
    let live: Vec<u32> = surface.live_vertices().collect();
    fair_vertices(surface, &live);
    before
}

/// Fairs only `vertices` of `surface`, the others held where they are.
pub(in crate::balloon) fn fair_vertices(surface: &mut Surface, vertices: &[u32]) {
    // The rings, gathered once: walking the half-edges on every pass cost three times more.
    let rings = surface.rings(vertices);
    for _ in 0..PASSES {
        for factor in [LAMBDA, MU] {
            surface.umbrella_pass(vertices, &rings, factor);
        }
    }
}

/// Puts the vertices `around` and `rings` rings of neighbours around them back at `before`
/// (by slot, as [`fair`] returned it).
pub(in crate::balloon) fn restore(
    surface: &mut Surface,
    before: &[DVec3],
    around: impl IntoIterator<Item = u32>,
    rings: usize,
) {
    for v in surface.neighbourhood(around, rings) {
        surface.positions_mut()[v as usize] = before[v as usize];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn radii(surface: &Surface) -> Vec<f64> {
        surface.positions().iter().map(|p| p.length()).collect()
    }

    /// An icosphere of radius 10 (edges of about 0.8 mm) with a ripple of ±0.1 mm in stripes
    /// `period` mm apart.
    fn rippled(period: f64) -> Surface {
        let mut s = Surface::icosphere(DVec3::ZERO, 10.0, 4).unwrap();
        for p in s.positions_mut() {
            let ripple = 0.1 * (std::f64::consts::TAU * p.x / period).cos();
            *p *= 1.0 + ripple / 10.0;
        }
        s
    }

    #[test]
    fn fairing_some_vertices_holds_the_others() {
        let mut s = rippled(2.0);
        let before = s.positions().to_vec();
        let top: Vec<u32> = s
            .live_vertices()
            .filter(|&v| before[v as usize].z > 0.0)
            .collect();
        // The held vertices pull their faired neighbours; a few rings away the ripple is gone.
        let far: Vec<u32> = top
            .iter()
            .copied()
            .filter(|&v| before[v as usize].z > 3.0)
            .collect();
        let spread = |s: &Surface| {
            let r: Vec<f64> = far
                .iter()
                .map(|&v| s.positions()[v as usize].length())
                .collect();
            let mean = r.iter().sum::<f64>() / r.len() as f64;
            (r.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / r.len() as f64).sqrt()
        };
        let rippled = spread(&s);
        fair_vertices(&mut s, &top);
        assert!(spread(&s) < 0.3 * rippled, "{} of {rippled}", spread(&s));
        for v in s.live_vertices().filter(|v| !top.contains(v)) {
            assert_eq!(s.positions()[v as usize], before[v as usize]);
        }
    }

    /// The ripple left after fairing, as a fraction of the ripple before: the spread of the
    /// radii about their mean.
    fn ripple_left(period: f64) -> f64 {
        let spread = |s: &Surface| {
            let r = radii(s);
            let mean = r.iter().sum::<f64>() / r.len() as f64;
            (r.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / r.len() as f64).sqrt()
        };
        let mut s = rippled(period);
        let before = spread(&s);
        fair(&mut s);
        spread(&s) / before
    }

    #[test]
    fn fairing_removes_ripples_of_a_few_triangles_and_keeps_the_shape() {
        // Measured: 0.18, 0.30, 0.51, 0.95 and 1.01 of the ripple left at periods of 1, 1.6,
        // 2.5, 5 and 10 mm. Two triangles: the ripple that noisy threshold crossings leave.
        assert!(ripple_left(1.6) < 0.35, "{}", ripple_left(1.6));
        // A dozen triangles: shape.
        assert!(ripple_left(10.0) > 0.95, "{}", ripple_left(10.0));
        let mut s = rippled(1.6);
        fair(&mut s);
        let r = radii(&s);
        let mean = r.iter().sum::<f64>() / r.len() as f64;
        assert!((mean - 10.0).abs() < 0.02, "mean radius {mean}");
    }

    #[test]
    fn fairing_a_sphere_is_the_same_for_any_thread_count() {
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let mut s = rippled(1.6);
            pool.install(|| fair(&mut s));
            s.positions().to_vec()
        };
        assert_eq!(run(1), run(3));
    }

    #[test]
    fn restoring_puts_back_only_the_patch() {
        let mut s = rippled(1.6);
        let before = fair(&mut s);
        let faired = s.positions().to_vec();
        restore(&mut s, &before, [0], 1);
        let mut patch: Vec<u32> = s.neighbours(0).collect();
        patch.push(0);
        for v in 0..s.positions().len() as u32 {
            let expected = if patch.contains(&v) {
                before[v as usize]
            } else {
                faired[v as usize]
            };
            assert_eq!(s.positions()[v as usize], expected, "vertex {v}");
        }
    }
}
