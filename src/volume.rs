//! Voxel volumes: a borrowed, strided, typed view of someone else's voxels (a numpy array, a
//! vtkImageData buffer, a file we read) plus its physical geometry, and an owned image for
//! results and file I/O.
//!
//! Strides are in elements and may be negative, so C- and Fortran-ordered arrays, sliced views
//! and flipped views are all used in place, never copied. Index i is the fastest axis by
//! convention (VTK, ITK), but any stride order works. Algorithms that need typed access use
//! [`Volume::dispatch`] with a [`VoxelVisitor`], which monomorphises them per scalar type.

use std::io::Read;
use std::marker::PhantomData;
use std::ptr::NonNull;

use glam::DVec3;

use crate::allocation;
use crate::error::{Error, Result};
use crate::geometry::Geometry;

/// The voxel types the library accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ScalarType {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    F32,
    F64,
}

impl ScalarType {
    pub const ALL: [ScalarType; 8] = [
        ScalarType::U8,
        ScalarType::I8,
        ScalarType::U16,
        ScalarType::I16,
        ScalarType::U32,
        ScalarType::I32,
        ScalarType::F32,
        ScalarType::F64,
    ];

    pub fn size_in_bytes(self) -> usize {
        match self {
            ScalarType::U8 | ScalarType::I8 => 1,
            ScalarType::U16 | ScalarType::I16 => 2,
            ScalarType::U32 | ScalarType::I32 | ScalarType::F32 => 4,
            ScalarType::F64 => 8,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            ScalarType::U8 => "uint8",
            ScalarType::I8 => "int8",
            ScalarType::U16 => "uint16",
            ScalarType::I16 => "int16",
            ScalarType::U32 => "uint32",
            ScalarType::I32 => "int32",
            ScalarType::F32 => "float32",
            ScalarType::F64 => "float64",
        }
    }
}

/// A voxel scalar: one of the [`ScalarType`]s.
pub trait Scalar: Copy + Send + Sync + PartialOrd + 'static {
    const TYPE: ScalarType;
    fn to_f64(self) -> f64;
    /// Rounds and saturates; NaN becomes zero for the integer types.
    fn from_f64(value: f64) -> Self;
}

macro_rules! impl_scalar {
    ($($t:ty => $variant:ident),* $(,)?) => {$(
        impl Scalar for $t {
            const TYPE: ScalarType = ScalarType::$variant;
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn from_f64(value: f64) -> Self {
                // `as` saturates and maps NaN to zero.
                value.round() as $t
            }
        }
    )*};
}
impl_scalar!(u8 => U8, i8 => I8, u16 => U16, i16 => I16, u32 => U32, i32 => I32);

impl Scalar for f32 {
    const TYPE: ScalarType = ScalarType::F32;
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn from_f64(value: f64) -> Self {
        value as f32
    }
}

impl Scalar for f64 {
    const TYPE: ScalarType = ScalarType::F64;
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline(always)]
    fn from_f64(value: f64) -> Self {
        value
    }
}

/// A typed, borrowed, strided 3-D array with its geometry.
///
/// It holds a pointer to voxel (0, 0, 0) rather than a slice: a slice would span every element
/// between the lowest and highest addressed one, and with steps those in between may belong to
/// someone else (the other half of an ndarray `multi_slice_mut`), whom a shared slice over them
/// would alias. It borrows only the addressed voxels, for `'a`, as `&'a [T]` would.
#[derive(Debug, Clone, Copy)]
pub struct TypedVolume<'a, T> {
    /// Voxel (0, 0, 0); voxel (i, j, k) is at `first + i·s0 + j·s1 + k·s2`.
    first: NonNull<T>,
    dims: [usize; 3],
    strides: [isize; 3],
    geometry: Geometry,
    voxels: PhantomData<&'a [T]>,
}

// SAFETY: a TypedVolume only reads its voxels, through shared access borrowed for 'a, like the
// `&'a [T]` it stands for: sending it to or sharing it with another thread is sending or sharing
// that borrow, which is safe when T is Sync.
unsafe impl<T: Sync> Send for TypedVolume<'_, T> {}
// SAFETY: as for Send; `&self` methods only read the voxels.
unsafe impl<T: Sync> Sync for TypedVolume<'_, T> {}

impl<'a, T: Scalar> TypedVolume<'a, T> {
    /// A view of `data` where voxel (i, j, k) is `data[base + i·s0 + j·s1 + k·s2]`.
    ///
    /// Every addressed element must lie inside `data`; this is checked once here, without
    /// overflow, so that [`get`](Self::get) can index without further checks.
    pub fn new(
        data: &'a [T],
        base: usize,
        dims: [usize; 3],
        strides: [isize; 3],
        geometry: Geometry,
    ) -> Result<Self> {
        let (lowest, highest) = address_range(dims, strides)?;
        let len = data.len();
        let (lowest, highest) = (base as i128 + lowest, base as i128 + highest);
        if lowest < 0 || highest >= len as i128 {
            return Err(Error::invalid_volume(format!(
                "dims {dims:?} with strides {strides:?} (elements) from element {base} address \
                 elements {lowest}..={highest}, outside the {len} elements of the buffer; check \
                 the strides' units (elements, not bytes) and their order (i fastest)"
            )));
        }
        // SAFETY: every addressed element, voxel (0, 0, 0) at `base` among them, was just found
        // inside `data`, which is borrowed for 'a.
        let view =
            unsafe { Self::from_raw_parts(data.as_ptr().add(base), dims, strides, geometry) };
        Ok(view)
    }

    /// A contiguous view with i fastest (VTK/ITK order, numpy `volume[k, j, i]` in C order).
    pub fn contiguous(data: &'a [T], dims: [usize; 3], geometry: Geometry) -> Result<Self> {
        let s1 = dims[0] as isize;
        let s2 = s1.checked_mul(dims[1] as isize).unwrap_or(isize::MAX);
        Self::new(data, 0, dims, [1, s1, s2], geometry)
    }

    /// The view whose voxel (i, j, k) is at `first + i·s0 + j·s1 + k·s2` (strides in elements),
    /// for voxels in memory the caller manages (the C ABI's volumes); only the addressed
    /// elements are borrowed, never the ones between them.
    ///
    /// # Safety
    /// Every dim is at least 1, no voxel's offset `i·s0 + j·s1 + k·s2` (nor any partial sum of
    /// it) overflows `isize`, and every voxel address points to an initialised, aligned `T`
    /// inside one allocation, readable and not written for `'a`.
    pub unsafe fn from_raw_parts(
        first: *const T,
        dims: [usize; 3],
        strides: [isize; 3],
        geometry: Geometry,
    ) -> Self {
        TypedVolume {
            // SAFETY: the grid has a voxel (0, 0, 0), and it points into an allocation.
            first: unsafe { NonNull::new_unchecked(first.cast_mut()) },
            dims,
            strides,
            geometry,
            voxels: PhantomData,
        }
    }

    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    pub fn strides(&self) -> [isize; 3] {
        self.strides
    }

    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }

    /// The voxel at (i, j, k). Panics when out of range, like slice indexing.
    #[inline(always)]
    pub fn get(&self, i: usize, j: usize, k: usize) -> T {
        assert!(i < self.dims[0] && j < self.dims[1] && k < self.dims[2]);
        let offset = i as isize * self.strides[0]
            + j as isize * self.strides[1]
            + k as isize * self.strides[2];
        // SAFETY: (i, j, k) is a voxel of the grid, and every voxel's address lies in the one
        // allocation the constructor was promised, borrowed for 'a. Each partial sum of the
        // offset lies between the lowest and highest address too, so none overflows.
        unsafe { *self.first.as_ptr().offset(offset) }
    }

    /// The row of voxels (0..dims[0], j, k) as a slice, when the voxels are laid out with
    /// i fastest and contiguous; `None` otherwise. Panics when (j, k) is out of range.
    pub fn row(&self, j: usize, k: usize) -> Option<&'a [T]> {
        if self.strides[0] != 1 {
            return None;
        }
        assert!(j < self.dims[1] && k < self.dims[2]);
        let start = j as isize * self.strides[1] + k as isize * self.strides[2];
        // SAFETY: with an i-stride of 1 the slice's elements are exactly the row's voxels, all
        // addressed, so all borrowed for 'a (and only those: the elements between rows, which
        // may be someone else's, stay outside it).
        Some(unsafe { std::slice::from_raw_parts(self.first.as_ptr().offset(start), self.dims[0]) })
    }

    /// Trilinear interpolation at a continuous index, the edge voxels' values held for half a
    /// voxel beyond them; `None` outside `[-0.5, dims-0.5]` on any axis.
    pub fn sample_index(&self, p: DVec3) -> Option<f64> {
        let cell = Cell::around(p, self.dims)?;
        let ([i0, j0, k0], [i1, j1, k1]) = (cell.lo, cell.hi);
        let v = |i, j, k| self.get(i, j, k).to_f64();
        // Spelled out rather than mapped over `Cell::corners`, whose closure the compiler does
        // not always inline here; the same order, x fastest.
        let corners = [
            v(i0, j0, k0),
            v(i1, j0, k0),
            v(i0, j1, k0),
            v(i1, j1, k0),
            v(i0, j0, k1),
            v(i1, j0, k1),
            v(i0, j1, k1),
            v(i1, j1, k1),
        ];
        Some(cell.interpolate(corners))
    }

    /// Trilinear interpolation at a world position (mm).
    pub fn sample_world(&self, world: DVec3) -> Option<f64> {
        self.sample_index(self.geometry.world_to_index(world))
    }
}

/// The cell of a grid of `dims` points that holds a continuous index, for trilinear
/// interpolation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Cell {
    /// The lowest and highest corner (equal on an axis of one point).
    pub lo: [usize; 3],
    pub hi: [usize; 3],
    /// The index's place in the cell, 0–1 per axis.
    pub t: DVec3,
}

impl Cell {
    /// The cell around `p`; `None` outside `[-0.5, dims-0.5]` on any axis.
    #[inline(always)]
    pub fn around(p: DVec3, dims: [usize; 3]) -> Option<Cell> {
        let mut lo = [0usize; 3];
        let mut t = DVec3::ZERO;
        for a in 0..3 {
            let max = (dims[a] - 1) as f64;
            if !(p[a] >= -0.5 && p[a] <= max + 0.5) {
                return None;
            }
            // A voxel covers half a spacing on either side of its centre (ITK's buffered
            // region, `IsInsideBuffer`): within that half voxel beyond the last centre the
            // edge voxel's value holds, so a structure cut by the volume fills its edge voxels.
            let p_a = p[a].clamp(0.0, max);
            // On the last plane the cell below is used with weight 1 on its upper corner. The
            // coordinate is not negative, so truncating it is its floor, without the call to
            // libm's `floor` that baseline x86-64 makes (the stepper samples millions of times).
            let cell = (p_a as usize).min(dims[a].saturating_sub(2));
            lo[a] = cell;
            t[a] = p_a - cell as f64;
        }
        let hi = [0, 1, 2].map(|a| (lo[a] + 1).min(dims[a] - 1));
        Some(Cell { lo, hi, t })
    }

    /// The eight corners, x fastest, then y, then z.
    #[inline(always)]
    pub fn corners(&self) -> [[usize; 3]; 8] {
        std::array::from_fn(|n| {
            [0, 1, 2].map(|a| {
                if n >> a & 1 == 0 {
                    self.lo[a]
                } else {
                    self.hi[a]
                }
            })
        })
    }

    /// The trilinear interpolation of the values at [`Cell::corners`].
    #[inline(always)]
    pub fn interpolate(&self, c: [f64; 8]) -> f64 {
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let t = self.t;
        let [e00, e10, e01, e11] = [0, 2, 4, 6].map(|n| lerp(c[n], c[n + 1], t.x));
        lerp(lerp(e00, e10, t.y), lerp(e01, e11, t.y), t.z)
    }
}

/// The lowest and highest element offset from voxel (0, 0, 0) that a `dims` grid with
/// `strides` addresses, once checked that the grid has voxels and that their count fits an
/// `isize`.
pub(crate) fn address_range(dims: [usize; 3], strides: [isize; 3]) -> Result<(i128, i128)> {
    if let Some(axis) = dims.iter().position(|&d| d == 0) {
        return Err(Error::invalid_volume(format!(
            "dims[{axis}] is 0; a volume needs at least one voxel along every axis (dims {dims:?})"
        )));
    }
    let fits = dims
        .iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .is_some_and(|n| n <= isize::MAX as usize);
    if !fits {
        return Err(Error::invalid_volume(format!(
            "dims {dims:?} overflow the address space"
        )));
    }
    // In i128 so that no product can overflow.
    let (mut lowest, mut highest) = (0i128, 0i128);
    for a in 0..3 {
        let extent = (dims[a] as i128 - 1) * strides[a] as i128;
        if extent < 0 {
            lowest += extent;
        } else {
            highest += extent;
        }
    }
    Ok((lowest, highest))
}

/// A volume of any supported scalar type.
#[derive(Debug, Clone, Copy)]
pub enum Volume<'a> {
    U8(TypedVolume<'a, u8>),
    I8(TypedVolume<'a, i8>),
    U16(TypedVolume<'a, u16>),
    I16(TypedVolume<'a, i16>),
    U32(TypedVolume<'a, u32>),
    I32(TypedVolume<'a, i32>),
    F32(TypedVolume<'a, f32>),
    F64(TypedVolume<'a, f64>),
}

/// An operation generic over the voxel type, run by [`Volume::dispatch`].
pub trait VoxelVisitor {
    type Output;
    fn visit<T: Scalar>(self, volume: &TypedVolume<'_, T>) -> Self::Output;
}

macro_rules! each_variant {
    ($value:expr, $v:ident => $body:expr) => {
        match $value {
            Volume::U8($v) => $body,
            Volume::I8($v) => $body,
            Volume::U16($v) => $body,
            Volume::I16($v) => $body,
            Volume::U32($v) => $body,
            Volume::I32($v) => $body,
            Volume::F32($v) => $body,
            Volume::F64($v) => $body,
        }
    };
}

impl<'a> Volume<'a> {
    pub fn dispatch<V: VoxelVisitor>(&self, visitor: V) -> V::Output {
        each_variant!(self, v => visitor.visit(v))
    }

    pub fn scalar_type(&self) -> ScalarType {
        each_variant!(self, v => scalar_type_of(v))
    }

    pub fn dims(&self) -> [usize; 3] {
        each_variant!(self, v => v.dims())
    }

    pub fn geometry(&self) -> &Geometry {
        each_variant!(self, v => v.geometry())
    }

    pub fn voxel_count(&self) -> usize {
        self.dims().iter().product()
    }

    /// The voxel at (i, j, k) as f64.
    pub fn get_f64(&self, i: usize, j: usize, k: usize) -> f64 {
        each_variant!(self, v => v.get(i, j, k).to_f64())
    }

    pub fn sample_index(&self, p: DVec3) -> Option<f64> {
        each_variant!(self, v => v.sample_index(p))
    }

    pub fn sample_world(&self, world: DVec3) -> Option<f64> {
        each_variant!(self, v => v.sample_world(world))
    }
}

fn scalar_type_of<T: Scalar>(_: &TypedVolume<'_, T>) -> ScalarType {
    T::TYPE
}

macro_rules! impl_from_typed {
    ($($t:ty => $variant:ident),*) => {$(
        impl<'a> From<TypedVolume<'a, $t>> for Volume<'a> {
            fn from(v: TypedVolume<'a, $t>) -> Self {
                Volume::$variant(v)
            }
        }
    )*};
}
impl_from_typed!(u8 => U8, i8 => I8, u16 => U16, i16 => I16, u32 => U32, i32 => I32, f32 => F32, f64 => F64);

/// Owned voxels of one scalar type, i fastest.
#[derive(Debug, Clone, PartialEq)]
pub enum VoxelBuffer {
    U8(Vec<u8>),
    I8(Vec<i8>),
    U16(Vec<u16>),
    I16(Vec<i16>),
    U32(Vec<u32>),
    I32(Vec<i32>),
    F32(Vec<f32>),
    F64(Vec<f64>),
}

macro_rules! each_buffer {
    ($value:expr, $v:ident => $body:expr) => {
        match $value {
            VoxelBuffer::U8($v) => $body,
            VoxelBuffer::I8($v) => $body,
            VoxelBuffer::U16($v) => $body,
            VoxelBuffer::I16($v) => $body,
            VoxelBuffer::U32($v) => $body,
            VoxelBuffer::I32($v) => $body,
            VoxelBuffer::F32($v) => $body,
            VoxelBuffer::F64($v) => $body,
        }
    };
}

impl VoxelBuffer {
    pub fn len(&self) -> usize {
        each_buffer!(self, v => v.len())
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    pub fn scalar_type(&self) -> ScalarType {
        match self {
            VoxelBuffer::U8(_) => ScalarType::U8,
            VoxelBuffer::I8(_) => ScalarType::I8,
            VoxelBuffer::U16(_) => ScalarType::U16,
            VoxelBuffer::I16(_) => ScalarType::I16,
            VoxelBuffer::U32(_) => ScalarType::U32,
            VoxelBuffer::I32(_) => ScalarType::I32,
            VoxelBuffer::F32(_) => ScalarType::F32,
            VoxelBuffer::F64(_) => ScalarType::F64,
        }
    }

    /// Decodes little- or big-endian bytes of `scalar_type` into a buffer.
    pub fn from_bytes(scalar_type: ScalarType, bytes: &[u8], little_endian: bool) -> Result<Self> {
        let size = scalar_type.size_in_bytes();
        if bytes.len() % size != 0 {
            return Err(Error::format(format!(
                "{} bytes is not a whole number of {} voxels",
                bytes.len(),
                scalar_type.name()
            )));
        }
        Self::read_from(
            scalar_type,
            bytes.len() / size,
            little_endian,
            &mut &bytes[..],
        )
    }

    /// Reads exactly `count` voxels of `scalar_type`, little- or big-endian, from `source` a
    /// chunk at a time: a reader streams a file (or its inflater) into the buffer, holding no
    /// more than the voxels and one chunk. The buffer is allocated fallibly.
    pub(crate) fn read_from(
        scalar_type: ScalarType,
        count: usize,
        little_endian: bool,
        source: &mut impl Read,
    ) -> Result<Self> {
        const CHUNK_BYTES: usize = 1 << 20;
        let size = scalar_type.size_in_bytes();
        let total = count.checked_mul(size).ok_or_else(|| {
            Error::invalid_volume(format!("{count} voxels are more than memory can address"))
        })?;
        let mut chunk = vec![0u8; total.min(CHUNK_BYTES / size * size)];
        let failed = |e: std::io::Error| {
            Error::format(if e.kind() == std::io::ErrorKind::UnexpectedEof {
                format!(
                    "the voxel data ends within the {total} bytes the header's sizes and type \
                     need: the file is truncated or its header is wrong"
                )
            } else {
                format!("cannot read the voxel data ({e})")
            })
        };
        macro_rules! fill {
            ($t:ty, $variant:ident) => {{
                let mut voxels: Vec<$t> = allocation::with_capacity(count, "the voxels")?;
                while voxels.len() < count {
                    let n = ((count - voxels.len()) * size).min(chunk.len());
                    source.read_exact(&mut chunk[..n]).map_err(failed)?;
                    voxels.extend(chunk[..n].chunks_exact(size).map(|c| {
                        let bytes = c.try_into().expect("chunks have the element size");
                        if little_endian {
                            <$t>::from_le_bytes(bytes)
                        } else {
                            <$t>::from_be_bytes(bytes)
                        }
                    }));
                }
                VoxelBuffer::$variant(voxels)
            }};
        }
        Ok(match scalar_type {
            ScalarType::U8 => fill!(u8, U8),
            ScalarType::I8 => fill!(i8, I8),
            ScalarType::U16 => fill!(u16, U16),
            ScalarType::I16 => fill!(i16, I16),
            ScalarType::U32 => fill!(u32, U32),
            ScalarType::I32 => fill!(i32, I32),
            ScalarType::F32 => fill!(f32, F32),
            ScalarType::F64 => fill!(f64, F64),
        })
    }

    /// Little-endian bytes of the voxels.
    pub fn to_le_bytes(&self) -> Vec<u8> {
        each_buffer!(self, v => v.iter().flat_map(|x| x.to_le_bytes()).collect())
    }
}

/// An owned image: voxels (i fastest, contiguous) with dims and geometry.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    buffer: VoxelBuffer,
    dims: [usize; 3],
    geometry: Geometry,
}

impl Image {
    /// A test volume: intensity `profile(x)` along x on an `n`³ grid of 1 mm voxels, the same
    /// across y and z.
    #[cfg(test)]
    pub(crate) fn along_x(n: usize, profile: impl Fn(f64) -> f64) -> Image {
        let values = (0..n * n * n).map(|i| profile((i % n) as f64)).collect();
        Image::new(VoxelBuffer::F64(values), [n, n, n], Geometry::identity()).unwrap()
    }

    pub fn new(buffer: VoxelBuffer, dims: [usize; 3], geometry: Geometry) -> Result<Self> {
        let expected = dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d));
        if expected != Some(buffer.len()) || buffer.is_empty() {
            return Err(Error::invalid_volume(format!(
                "dims {dims:?} need {} voxels but the buffer holds {}",
                expected.map_or("more than usize::MAX".to_string(), |n| n.to_string()),
                buffer.len()
            )));
        }
        Ok(Image {
            buffer,
            dims,
            geometry,
        })
    }

    /// A float image filled by evaluating `f` at every voxel index (i fastest).
    pub fn from_fn(
        dims: [usize; 3],
        geometry: Geometry,
        f: impl Fn(usize, usize, usize) -> f32 + Sync,
    ) -> Result<Self> {
        use rayon::prelude::*;
        let plane = dims[0] * dims[1];
        let mut data = vec![0.0f32; dims.iter().product()];
        data.par_chunks_mut(plane.max(1))
            .enumerate()
            .for_each(|(k, slab)| {
                for (n, v) in slab.iter_mut().enumerate() {
                    *v = f(n % dims[0], n / dims[0], k);
                }
            });
        Image::new(VoxelBuffer::F32(data), dims, geometry)
    }

    pub fn buffer(&self) -> &VoxelBuffer {
        &self.buffer
    }

    pub fn into_buffer(self) -> VoxelBuffer {
        self.buffer
    }

    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }

    pub fn scalar_type(&self) -> ScalarType {
        self.buffer.scalar_type()
    }

    /// A borrowed view of the whole image.
    pub fn view(&self) -> Volume<'_> {
        let (dims, g) = (self.dims, self.geometry);
        let view = each_buffer!(&self.buffer, v => Volume::from(
            TypedVolume::contiguous(v, dims, g).expect("an Image's buffer matches its dims")
        ));
        view
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(dims: [usize; 3]) -> Vec<f64> {
        let mut v = Vec::new();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    v.push(i as f64 + 10.0 * j as f64 + 100.0 * k as f64);
                }
            }
        }
        v
    }

    #[test]
    fn fortran_c_and_negative_strides_address_the_same_voxels() {
        let dims = [4, 3, 2];
        let data = ramp(dims);
        let g = Geometry::identity();
        let c = TypedVolume::contiguous(&data, dims, g).unwrap();
        // The same buffer seen with k reversed: base at the last slab, negative k stride.
        let flipped = TypedVolume::new(&data, 12, dims, [1, 4, -12], g).unwrap();
        // Transposed storage (k fastest), as a Fortran-ordered numpy array of volume[k, j, i].
        let mut t = vec![0.0; data.len()];
        for k in 0..2 {
            for j in 0..3 {
                for i in 0..4 {
                    t[k + 2 * j + 6 * i] = c.get(i, j, k);
                }
            }
        }
        let f = TypedVolume::new(&t, 0, dims, [6, 2, 1], g).unwrap();
        for k in 0..2 {
            for j in 0..3 {
                for i in 0..4 {
                    assert_eq!(f.get(i, j, k), c.get(i, j, k));
                    assert_eq!(flipped.get(i, j, k), c.get(i, j, 1 - k));
                }
            }
        }
    }

    #[test]
    fn layout_outside_the_buffer_is_an_error_not_a_panic() {
        let data = vec![0u8; 24];
        let g = Geometry::identity();
        assert!(TypedVolume::contiguous(&data, [4, 3, 2], g).is_ok());
        let e = TypedVolume::contiguous(&data, [4, 3, 3], g).unwrap_err();
        assert!(e.message().contains("outside"), "{e}");
        assert!(TypedVolume::new(&data, 0, [4, 3, 2], [1, 4, -12], g).is_err());
        assert!(TypedVolume::contiguous(&data, [0, 3, 2], g).is_err());
        let huge = usize::MAX / 2;
        assert!(TypedVolume::new(&data, 0, [huge, huge, 2], [1, 1, 1], g).is_err());
        assert!(TypedVolume::new(&data, 0, [2, 2, 2], [isize::MAX, 1, 1], g).is_err());
    }

    #[test]
    fn trilinear_sampling_is_exact_on_linear_fields_and_holds_the_edge_half_a_voxel_beyond() {
        let dims = [4, 3, 2];
        let data = ramp(dims);
        let g = Geometry::new(
            [0.5, 2.0, 3.0],
            [1.0, 2.0, 3.0],
            [0., 1., 0., -1., 0., 0., 0., 0., 1.],
        )
        .unwrap();
        let v: Volume = TypedVolume::contiguous(&data, dims, g).unwrap().into();
        for p in [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.25, 0.5, 0.75),
            DVec3::new(3.0, 2.0, 1.0),
            DVec3::new(3.0, 1.5, 0.0),
        ] {
            let expected = p.x + 10.0 * p.y + 100.0 * p.z;
            assert!((v.sample_index(p).unwrap() - expected).abs() < 1e-12);
            let w = g.index_to_world(p);
            assert!((v.sample_world(w).unwrap() - expected).abs() < 1e-9);
        }
        // Within half a voxel beyond the last centres the edge voxels' values hold.
        assert_eq!(
            v.sample_index(DVec3::new(3.5, 0.0, 0.0)),
            v.sample_index(DVec3::new(3.0, 0.0, 0.0))
        );
        assert_eq!(
            v.sample_index(DVec3::new(-0.5, 2.4, 0.0)),
            v.sample_index(DVec3::new(0.0, 2.0, 0.0))
        );
        assert_eq!(v.sample_index(DVec3::new(3.5001, 0.0, 0.0)), None);
        assert_eq!(v.sample_index(DVec3::new(-0.5001, 0.0, 0.0)), None);
        assert_eq!(v.sample_index(DVec3::new(f64::NAN, 0.0, 0.0)), None);
    }

    #[test]
    fn single_voxel_axes_sample_without_neighbours() {
        let data = [7i16, 9];
        let v = TypedVolume::contiguous(&data, [2, 1, 1], Geometry::identity()).unwrap();
        assert_eq!(v.sample_index(DVec3::new(0.5, 0.0, 0.0)), Some(8.0));
    }

    #[test]
    fn every_scalar_type_round_trips_through_bytes_and_views() {
        for t in ScalarType::ALL {
            let bytes: Vec<u8> = (0..8 * t.size_in_bytes()).map(|b| b as u8).collect();
            let le = VoxelBuffer::from_bytes(t, &bytes, true).unwrap();
            assert_eq!(le.scalar_type(), t);
            assert_eq!(le.to_le_bytes(), bytes);
            let img = Image::new(le, [2, 2, 2], Geometry::identity()).unwrap();
            assert_eq!(img.view().scalar_type(), t);
            assert_eq!(img.view().dims(), [2, 2, 2]);
        }
        assert!(VoxelBuffer::from_bytes(ScalarType::F32, &[0u8; 7], true).is_err());
        assert!(Image::new(VoxelBuffer::U8(vec![0; 7]), [2, 2, 2], Geometry::identity()).is_err());
    }

    #[test]
    fn integer_conversion_rounds_and_saturates() {
        assert_eq!(u8::from_f64(300.0), 255);
        assert_eq!(u8::from_f64(-3.0), 0);
        assert_eq!(i16::from_f64(2.5), 3);
        assert_eq!(i32::from_f64(f64::NAN), 0);
    }
}
