//! Reproducible random draws for the phantoms: SplitMix64 (Steele, Lea & Flood 2014) and what
//! the phantoms build on it — uniform and normal numbers (Box–Muller), directions uniform on
//! the sphere and rotations uniform on SO(3) (Shoemake's unit quaternion, 1992).
//!
//! Our own generator rather than a crate's, so that a phantom stays bit-identical across
//! versions, platforms and thread counts: the stream depends on nothing but its seed. (The sines,
//! cosines and logarithms come from the platform's libm, as everywhere in Rust.)

use glam::{DMat3, DQuat, DVec3};

/// SplitMix64: tiny, fast and stable forever.
#[derive(Debug, Clone)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    pub fn new(seed: u64) -> SplitMix64 {
        SplitMix64(seed)
    }

    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in (0, 1], never 0 so that the logarithm of Box–Muller is finite.
    pub fn unit(&mut self) -> f64 {
        ((self.next() >> 11) + 1) as f64 / (1u64 << 53) as f64
    }

    /// A standard normal sample (Box–Muller).
    pub fn gaussian(&mut self) -> f64 {
        let (u, v) = (self.unit(), self.unit());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    /// Uniform in (lo, hi].
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// A whole number in lo..=hi (the modulo's bias is below 2⁻⁵⁰ for the small ranges here).
    pub fn integer(&mut self, lo: u64, hi: u64) -> u64 {
        lo + self.next() % (hi - lo + 1)
    }

    /// True with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        self.unit() <= p
    }

    /// Plus or minus one, evenly.
    pub fn sign(&mut self) -> f64 {
        if self.chance(0.5) {
            1.0
        } else {
            -1.0
        }
    }

    /// A direction uniform on the unit sphere (Archimedes: z is uniform in [−1, 1]).
    pub fn direction(&mut self) -> DVec3 {
        let z = self.uniform(-1.0, 1.0);
        let (s, c) = self.uniform(0.0, std::f64::consts::TAU).sin_cos();
        let ring = (1.0 - z * z).max(0.0).sqrt();
        DVec3::new(ring * c, ring * s, z)
    }

    /// A rotation uniform on SO(3), from a unit quaternion uniform on S³ (Shoemake).
    pub fn rotation(&mut self) -> DMat3 {
        let u = self.unit();
        let (s1, c1) = self.uniform(0.0, std::f64::consts::TAU).sin_cos();
        let (s2, c2) = self.uniform(0.0, std::f64::consts::TAU).sin_cos();
        let (a, b) = ((1.0 - u).sqrt(), u.sqrt());
        DMat3::from_quat(DQuat::from_xyzw(a * s1, a * c1, b * s2, b * c2).normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_stay_in_their_ranges() {
        let mut rng = SplitMix64::new(7);
        for _ in 0..10_000 {
            let x = rng.uniform(-2.0, 3.0);
            assert!(x > -2.0 && x <= 3.0);
            let n = rng.integer(6, 10);
            assert!((6..=10).contains(&n));
            assert!((rng.direction().length() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn rotations_are_proper_and_cover_the_sphere_evenly() {
        let mut rng = SplitMix64::new(11);
        let n = 20_000;
        let mut mean = DVec3::ZERO;
        let mut upper = 0;
        for _ in 0..n {
            let r = rng.rotation();
            assert!((r.determinant() - 1.0).abs() < 1e-12);
            assert!((r * r.transpose() - DMat3::IDENTITY).abs_diff_eq(DMat3::ZERO, 1e-12));
            // The image of a fixed axis is uniform on the sphere: zero mean, and its z uniform
            // in [−1, 1] (a quarter of the draws above z = 0.5).
            let axis = r * DVec3::Z;
            mean += axis;
            upper += usize::from(axis.z > 0.5);
        }
        assert!((mean / n as f64).length() < 0.03, "{mean}");
        let share = upper as f64 / n as f64;
        assert!((share - 0.25).abs() < 0.015, "{share}");
    }

    #[test]
    fn the_same_seed_gives_the_same_stream() {
        let (mut a, mut b) = (SplitMix64::new(3), SplitMix64::new(3));
        for _ in 0..100 {
            assert_eq!(a.gaussian().to_bits(), b.gaussian().to_bits());
        }
    }
}
