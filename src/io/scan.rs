//! Reading words, lines, numbers and voxels out of a file held in memory, for the text and
//! binary parts of the formats. Every count is checked against the bytes that remain before
//! anything is allocated for it, so a corrupt header cannot trigger a huge allocation.

use std::str::FromStr;

use crate::error::{Error, Result};
use crate::volume::{ScalarType, VoxelBuffer};

/// The error for input that stops in the middle of something.
pub(crate) fn eof() -> Error {
    Error::format("unexpected end of file")
}

/// A word for an error message: lossy UTF-8, shortened.
pub(crate) fn show(word: &[u8]) -> String {
    let text = String::from_utf8_lossy(word);
    match text.char_indices().nth(40) {
        Some((cut, _)) => format!("{:?}...", &text[..cut]),
        None => format!("{text:?}"),
    }
}

/// Parses a whole word as `T`; `what` names it in the error.
pub(crate) fn parse<T: FromStr>(word: &[u8], what: &str) -> Result<T> {
    std::str::from_utf8(word)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| Error::format(format!("{what}: {} is not a valid number", show(word))))
}

/// A number written as text for a value of type `ty`: float32 values are parsed as float32,
/// so that they widen to the same f64 as their binary form (and as VTK reads them).
pub(crate) fn text_number(word: &[u8], ty: NumType, what: &str) -> Result<f64> {
    match ty {
        NumType::F32 => parse::<f32>(word, what).map(f64::from),
        _ => parse(word, what),
    }
}

/// A position in a byte buffer.
#[derive(Debug, Clone)]
pub(crate) struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Cursor { bytes, pos: 0 }
    }

    pub fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    fn skip_whitespace(&mut self) {
        while self
            .bytes
            .get(self.pos)
            .is_some_and(|b| b.is_ascii_whitespace())
        {
            self.pos += 1;
        }
    }

    /// The next whitespace-separated word, `None` at the end.
    pub fn word(&mut self) -> Option<&'a [u8]> {
        self.skip_whitespace();
        let start = self.pos;
        while self
            .bytes
            .get(self.pos)
            .is_some_and(|b| !b.is_ascii_whitespace())
        {
            self.pos += 1;
        }
        (self.pos > start).then(|| &self.bytes[start..self.pos])
    }

    /// The next word, which must exist.
    pub fn expect_word(&mut self) -> Result<&'a [u8]> {
        self.word().ok_or_else(eof)
    }

    pub fn peek_word(&self) -> Option<&'a [u8]> {
        self.clone().word()
    }

    /// The next word parsed as `T`.
    pub fn number<T: FromStr>(&mut self, what: &str) -> Result<T> {
        let word = self
            .word()
            .ok_or_else(|| Error::format(format!("{what}: unexpected end of file")))?;
        parse(word, what)
    }

    /// The rest of the current line without its line break (`\n` or `\r\n`), moving past the
    /// break; `None` at the end.
    pub fn line(&mut self) -> Option<&'a [u8]> {
        if self.pos >= self.bytes.len() {
            return None;
        }
        let rest = &self.bytes[self.pos..];
        let (line, advance) = match rest.iter().position(|&b| b == b'\n') {
            Some(n) => (&rest[..n], n + 1),
            None => (rest, rest.len()),
        };
        self.pos += advance;
        Some(line.strip_suffix(b"\r").unwrap_or(line))
    }

    /// The next `n` bytes.
    pub fn take(&mut self, n: usize) -> Result<&'a [u8]> {
        if n > self.remaining() {
            return Err(eof());
        }
        self.pos += n;
        Ok(&self.bytes[self.pos - n..self.pos])
    }

    /// Fails unless `count` items of at least `min_bytes` each can still follow.
    pub fn check_room(&self, count: usize, min_bytes: usize, what: &str) -> Result<()> {
        match count.checked_mul(min_bytes) {
            Some(need) if need <= self.remaining() => Ok(()),
            _ => Err(Error::format(format!(
                "{count} {what} need at least {} bytes but only {} remain; the count is wrong or \
                 the file is truncated",
                count.saturating_mul(min_bytes),
                self.remaining()
            ))),
        }
    }
}

/// Binary number types, as the formats name them in their own ways.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum NumType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

fn array<const N: usize>(bytes: &[u8]) -> [u8; N] {
    let mut a = [0u8; N];
    a.copy_from_slice(&bytes[..N]);
    a
}

impl NumType {
    pub fn size(self) -> usize {
        match self {
            NumType::I8 | NumType::U8 => 1,
            NumType::I16 | NumType::U16 => 2,
            NumType::I32 | NumType::U32 | NumType::F32 => 4,
            NumType::I64 | NumType::U64 | NumType::F64 => 8,
        }
    }

    /// The value in the first `size()` bytes of `bytes`. 64-bit integers beyond 2^53 round,
    /// which no valid index or voxel count reaches.
    #[inline]
    pub fn decode(self, bytes: &[u8], big_endian: bool) -> f64 {
        macro_rules! get {
            ($t:ty) => {{
                let a = array(bytes);
                (if big_endian {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }) as f64
            }};
        }
        match self {
            NumType::I8 => bytes[0] as i8 as f64,
            NumType::U8 => bytes[0] as f64,
            NumType::I16 => get!(i16),
            NumType::U16 => get!(u16),
            NumType::I32 => get!(i32),
            NumType::U32 => get!(u32),
            NumType::I64 => get!(i64),
            NumType::U64 => get!(u64),
            NumType::F32 => get!(f32),
            NumType::F64 => get!(f64),
        }
    }

    /// Every value of `bytes`, whose length is a multiple of `size()`.
    pub fn decode_all(self, bytes: &[u8], big_endian: bool) -> Vec<f64> {
        // One loop per type, so the type is not matched again for every value.
        macro_rules! all {
            ($t:ty) => {
                bytes
                    .chunks_exact(std::mem::size_of::<$t>())
                    .map(|b| {
                        let a = array(b);
                        (if big_endian {
                            <$t>::from_be_bytes(a)
                        } else {
                            <$t>::from_le_bytes(a)
                        }) as f64
                    })
                    .collect()
            };
        }
        match self {
            NumType::I8 => all!(i8),
            NumType::U8 => all!(u8),
            NumType::I16 => all!(i16),
            NumType::U16 => all!(u16),
            NumType::I32 => all!(i32),
            NumType::U32 => all!(u32),
            NumType::I64 => all!(i64),
            NumType::U64 => all!(u64),
            NumType::F32 => all!(f32),
            NumType::F64 => all!(f64),
        }
    }

    /// The voxel type with the same layout, if the library has one.
    pub fn scalar_type(self) -> Option<ScalarType> {
        Some(match self {
            NumType::I8 => ScalarType::I8,
            NumType::U8 => ScalarType::U8,
            NumType::I16 => ScalarType::I16,
            NumType::U16 => ScalarType::U16,
            NumType::I32 => ScalarType::I32,
            NumType::U32 => ScalarType::U32,
            NumType::F32 => ScalarType::F32,
            NumType::F64 => ScalarType::F64,
            NumType::I64 | NumType::U64 => return None,
        })
    }
}

/// How an array of numbers is stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Encoding {
    /// Whitespace-separated decimal text.
    Text,
    Binary {
        big_endian: bool,
    },
}

/// `count` numbers of type `ty` as f64. `what` names them in errors.
pub(crate) fn numbers(
    cursor: &mut Cursor,
    count: usize,
    ty: NumType,
    encoding: Encoding,
    what: &str,
) -> Result<Vec<f64>> {
    match encoding {
        Encoding::Text => {
            // A number and its separator take at least two bytes, except the last.
            cursor.check_room(count.saturating_sub(1), 2, what)?;
            let mut values = Vec::with_capacity(count);
            for i in 0..count {
                let word = cursor.word().ok_or_else(|| {
                    Error::format(format!(
                        "{what}: unexpected end of file after {i} of {count}"
                    ))
                })?;
                values.push(text_number(word, ty, what)?);
            }
            Ok(values)
        }
        Encoding::Binary { big_endian } => {
            cursor.check_room(count, ty.size(), what)?;
            let bytes = cursor.take(count * ty.size())?;
            Ok(ty.decode_all(bytes, big_endian))
        }
    }
}

/// `count` voxels of `scalar_type`, parsed as that type (text) or decoded (binary).
pub(crate) fn voxels(
    cursor: &mut Cursor,
    count: usize,
    scalar_type: ScalarType,
    encoding: Encoding,
) -> Result<VoxelBuffer> {
    let what = "voxels";
    match encoding {
        Encoding::Binary { big_endian } => {
            cursor.check_room(count, scalar_type.size_in_bytes(), what)?;
            let bytes = cursor.take(count * scalar_type.size_in_bytes())?;
            VoxelBuffer::from_bytes(scalar_type, bytes, !big_endian)
        }
        Encoding::Text => {
            cursor.check_room(count.saturating_sub(1), 2, what)?;
            macro_rules! text {
                ($t:ty, $variant:ident) => {{
                    let mut values: Vec<$t> = Vec::with_capacity(count);
                    for i in 0..count {
                        let word = cursor.word().ok_or_else(|| {
                            Error::format(format!(
                                "voxels: unexpected end of file after {i} of {count}"
                            ))
                        })?;
                        let what = format!("voxel {i} ({})", scalar_type.name());
                        values.push(parse(word, &what)?);
                    }
                    VoxelBuffer::$variant(values)
                }};
            }
            Ok(match scalar_type {
                ScalarType::U8 => text!(u8, U8),
                ScalarType::I8 => text!(i8, I8),
                ScalarType::U16 => text!(u16, U16),
                ScalarType::I16 => text!(i16, I16),
                ScalarType::U32 => text!(u32, U32),
                ScalarType::I32 => text!(i32, I32),
                ScalarType::F32 => text!(f32, F32),
                ScalarType::F64 => text!(f64, F64),
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_lines_and_binary_share_one_position() {
        let mut c = Cursor::new(b"  POINTS 2 float\r\n\x3f\x80\x00\x00\x40\x00\x00\x00\nnext");
        assert_eq!(c.word(), Some(&b"POINTS"[..]));
        assert_eq!(c.line(), Some(&b" 2 float"[..]));
        let v = numbers(
            &mut c,
            2,
            NumType::F32,
            Encoding::Binary { big_endian: true },
            "p",
        );
        assert_eq!(v.unwrap(), [1.0, 2.0]);
        assert_eq!(c.peek_word(), Some(&b"next"[..]));
        assert_eq!(c.word(), Some(&b"next"[..]));
        assert_eq!(c.word(), None);
        assert_eq!(c.line(), None);
    }

    #[test]
    fn lying_counts_fail_before_allocating() {
        let mut c = Cursor::new(b"1 2 3");
        let e = numbers(&mut c, usize::MAX, NumType::F64, Encoding::Text, "points").unwrap_err();
        assert!(e.message().contains("truncated"), "{e}");
        let e = numbers(
            &mut c,
            usize::MAX / 2,
            NumType::F64,
            Encoding::Binary { big_endian: false },
            "points",
        )
        .unwrap_err();
        assert!(e.message().contains("truncated"), "{e}");
        let e = voxels(&mut c, 1 << 40, ScalarType::F32, Encoding::Text).unwrap_err();
        assert!(e.message().contains("truncated"), "{e}");
    }

    #[test]
    fn float32_text_widens_like_float32_binary() {
        let mut c = Cursor::new(b"0.1 0.1");
        let v = numbers(&mut c, 1, NumType::F32, Encoding::Text, "p").unwrap();
        assert_eq!(v, [0.1f32 as f64]);
        let v = numbers(&mut c, 1, NumType::F64, Encoding::Text, "p").unwrap();
        assert_eq!(v, [0.1]);
    }

    #[test]
    fn text_voxels_are_parsed_in_their_own_type() {
        let mut c = Cursor::new(b"-50 7\n 300");
        let v = voxels(&mut c, 2, ScalarType::I16, Encoding::Text).unwrap();
        assert_eq!(v, VoxelBuffer::I16(vec![-50, 7]));
        let e = voxels(&mut c, 1, ScalarType::U8, Encoding::Text).unwrap_err();
        assert!(e.message().contains("\"300\""), "{e}");
    }

    #[test]
    fn every_type_decodes_both_byte_orders() {
        for (ty, bytes_le, value) in [
            (NumType::I8, vec![0xfe], -2.0),
            (NumType::U16, vec![0x01, 0x02], 513.0),
            (NumType::I32, (-7i32).to_le_bytes().to_vec(), -7.0),
            (NumType::U64, 5u64.to_le_bytes().to_vec(), 5.0),
            (NumType::F32, 1.5f32.to_le_bytes().to_vec(), 1.5),
            (NumType::F64, 0.1f64.to_le_bytes().to_vec(), 0.1),
        ] {
            assert_eq!(ty.decode(&bytes_le, false), value);
            let be: Vec<u8> = bytes_le.iter().rev().copied().collect();
            assert_eq!(ty.decode(&be, true), value);
            let two_le = [&bytes_le[..], &bytes_le[..]].concat();
            assert_eq!(ty.decode_all(&two_le, false), [value, value]);
            assert_eq!(
                ty.decode_all(&[&be[..], &be[..]].concat(), true),
                [value, value]
            );
        }
    }
}
