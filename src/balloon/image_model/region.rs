//! The region of interest: a box in world millimetres beyond which no balloon grows, like the
//! editable region of 3D Slicer's segment editor. Its faces stop the balloon as the volume's
//! faces do.

use glam::DVec3;

use crate::error::{Error, Result};

/// An axis-aligned box in world millimetres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Region {
    lo: DVec3,
    hi: DVec3,
}

impl Region {
    /// The box with opposite corners `a` and `b` (world mm, in any order).
    pub fn new(a: DVec3, b: DVec3) -> Result<Region> {
        if !a.is_finite() || !b.is_finite() {
            return Err(Error::invalid_argument(format!(
                "the region of interest {a} – {b} mm is not finite; give two opposite corners \
                 of a box in world millimetres"
            )));
        }
        let (lo, hi) = (a.min(b), a.max(b));
        if (hi - lo).min_element() <= 0.0 {
            return Err(Error::invalid_argument(format!(
                "the region of interest {lo} – {hi} mm is flat; give two opposite corners of a \
                 box that has a size along x, y and z"
            )));
        }
        Ok(Region { lo, hi })
    }

    pub fn lo(&self) -> DVec3 {
        self.lo
    }

    pub fn hi(&self) -> DVec3 {
        self.hi
    }

    pub fn contains(&self, x: DVec3) -> bool {
        x.cmpge(self.lo).all() && x.cmple(self.hi).all()
    }

    /// How far `x` is inside the box (mm) — to its nearest face — negative outside.
    pub fn depth(&self, x: DVec3) -> f64 {
        (x - self.lo).min(self.hi - x).min_element()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_in_any_order_give_the_same_box() {
        let a = Region::new(DVec3::new(1.0, 5.0, -2.0), DVec3::new(4.0, 2.0, 3.0)).unwrap();
        let b = Region::new(DVec3::new(4.0, 2.0, 3.0), DVec3::new(1.0, 5.0, -2.0)).unwrap();
        assert_eq!(a, b);
        assert!(a.contains(DVec3::new(2.0, 3.0, 0.0)));
        assert!(!a.contains(DVec3::new(0.0, 3.0, 0.0)));
        assert_eq!(a.depth(DVec3::new(2.0, 3.0, 0.0)), 1.0);
        assert_eq!(a.depth(DVec3::new(0.0, 3.0, 0.0)), -1.0);
    }

    #[test]
    fn flat_or_nan_boxes_are_refused() {
        let flat = Region::new(DVec3::ZERO, DVec3::new(1.0, 0.0, 1.0)).unwrap_err();
        assert!(flat.message().contains("flat"), "{flat}");
        let nan = Region::new(DVec3::ZERO, DVec3::new(1.0, f64::NAN, 1.0)).unwrap_err();
        assert!(nan.message().contains("not finite"), "{nan}");
    }
}
