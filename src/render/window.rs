//! The display window: the grey ramp from intensities to pixels, with its own colours for
//! places outside the volume and for unknown (NaN) voxels, and its default, the 1st to 99th
//! percentile of what the panels show (robust to a few very bright or dark voxels, as viewers'
//! automatic windows are).

use super::raster::Rgb;

/// Where a plane leaves the volume: dark blue-grey, so the volume's edge shows against black
/// tissue.
pub(crate) const OUTSIDE: Rgb = [38, 46, 64];
/// An unknown (NaN) voxel.
pub(crate) const UNKNOWN: Rgb = [255, 0, 255];

/// Intensities from `lo` (black) to `hi` (white).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Window {
    pub lo: f64,
    pub hi: f64,
}

impl Window {
    pub fn colour(&self, sample: Option<f64>) -> Rgb {
        match sample {
            None => OUTSIDE,
            Some(v) if v.is_nan() => UNKNOWN,
            Some(v) => {
                let grey = ((v - self.lo) / (self.hi - self.lo)).clamp(0.0, 1.0) * 255.0;
                [grey.round() as u8; 3]
            }
        }
    }

    /// The 1st and 99th percentiles of the known samples; a window of one unit around a
    /// constant image, and 0–1 when nothing is known.
    pub fn percentiles(samples: impl Iterator<Item = Option<f64>>) -> Window {
        let mut values: Vec<f64> = samples.flatten().filter(|v| !v.is_nan()).collect();
        if values.is_empty() {
            return Window { lo: 0.0, hi: 1.0 };
        }
        let mut rank = |q: f64| {
            let n = ((values.len() - 1) as f64 * q).round() as usize;
            *values.select_nth_unstable_by(n, f64::total_cmp).1
        };
        let (lo, hi) = (rank(0.01), rank(0.99));
        if lo < hi {
            Window { lo, hi }
        } else {
            Window {
                lo: lo - 0.5,
                hi: lo + 0.5,
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_ignore_outliers_outside_and_unknown_samples() {
        let mut samples: Vec<Option<f64>> = (0..1000).map(|v| Some(v as f64)).collect();
        samples.extend([Some(1e9), Some(-1e9), None, Some(f64::NAN)]);
        let w = Window::percentiles(samples.into_iter());
        assert!(
            (w.lo - 10.0).abs() <= 1.0 && (w.hi - 990.0).abs() <= 1.0,
            "{w:?}"
        );
        assert_eq!(w.colour(Some(-5.0)), [0; 3]);
        assert_eq!(w.colour(Some(2000.0)), [255; 3]);
        assert_eq!(w.colour(Some(500.0)), [128; 3]);
        assert_eq!(w.colour(None), OUTSIDE);
        assert_eq!(w.colour(Some(f64::NAN)), UNKNOWN);
    }

    #[test]
    fn constant_and_empty_images_get_a_usable_window() {
        let w = Window::percentiles([Some(7.0); 50].into_iter());
        assert!(w.lo < 7.0 && 7.0 < w.hi);
        let w = Window::percentiles([None, Some(f64::NAN)].into_iter());
        assert!(w.lo < w.hi);
    }
}
