//! A fast hasher for the integer keys of the balloon's bookkeeping: grid cells, vertex and
//! triangle ids. Not resistant to chosen keys, which these never are.

use std::hash::{BuildHasherDefault, Hasher};

/// Multiply-rotate hashing of integer keys (as in Firefox's FxHash): SipHash's defence against
/// chosen keys buys nothing here, and its cost was a third of a contact search.
#[derive(Default, Clone, Copy)]
pub(crate) struct IntegerHasher(u64);

impl Hasher for IntegerHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }

    fn write_u64(&mut self, n: u64) {
        self.0 = (self.0.rotate_left(5) ^ n).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn write_i64(&mut self, n: i64) {
        self.write_u64(n as u64);
    }

    fn write_u32(&mut self, n: u32) {
        self.write_u64(u64::from(n));
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

/// A `HashMap`/`HashSet` hasher for integer keys.
pub(crate) type FastHash = BuildHasherDefault<IntegerHasher>;
