//! Fallible allocation for the buffers whose size follows from the input: one element or more
//! per voxel of a volume or of a grid laid over the balloon (distance maps, masks, labels,
//! marching cubes' bits and cases), or per triangle of a caller's mesh (self-intersection
//! search, simplification). Those are the allocations that can reach gigabytes, and Rust's `Vec`
//! aborts the process when one fails — inside a host application such as Slicer. Here a failure
//! becomes [`ErrorKind::OutOfMemory`](crate::ErrorKind::OutOfMemory) (`BALLOON_OUT_OF_MEMORY` at
//! the C ABI) naming the buffer and its size. The balloon's own arrays, which the vertex cap
//! bounds, stay ordinary allocations.

use std::collections::TryReserveError;

use crate::error::{Error, Result};

/// An empty vector with room for `capacity` elements, or an error naming `what`.
pub(crate) fn with_capacity<T>(capacity: usize, what: &str) -> Result<Vec<T>> {
    let mut v = Vec::new();
    reserved::<T>(v.try_reserve_exact(capacity), capacity, what)?;
    Ok(v)
}

/// The outcome of a collection's `try_reserve` towards `count` elements of `T` in all, as an
/// error naming `what` when it failed: for buffers that grow in steps (a queue, a hash map).
pub(crate) fn reserved<T>(
    outcome: std::result::Result<(), TryReserveError>,
    count: usize,
    what: &str,
) -> Result<()> {
    outcome.map_err(|_| out_of_memory(count, std::mem::size_of::<T>(), what))
}

/// `len` copies of `value` (`vec![value; len]`), or an error naming `what`.
pub(crate) fn filled<T: Clone>(len: usize, value: T, what: &str) -> Result<Vec<T>> {
    let mut v = with_capacity(len, what)?;
    v.resize(len, value);
    Ok(v)
}

/// Types whose every bit zero is a valid value, equal to their zero (`0`, `0.0`, `false`).
///
/// # Safety
/// An implementing type must be valid with all bits zero.
pub(crate) unsafe trait ZeroBits: Copy {}

// SAFETY: all zero bits are 0.0, 0 and false.
unsafe impl ZeroBits for f64 {}
// SAFETY: as above.
unsafe impl ZeroBits for u8 {}
// SAFETY: as above.
unsafe impl ZeroBits for bool {}

/// `len` zeros (`vec![0.0; len]`), or an error naming `what`. Like `vec!`, it takes memory the
/// system hands out zeroed: pages are mapped lazily, so each is first touched by the thread
/// that fills it, not all by this one.
pub(crate) fn zeroed<T: ZeroBits>(len: usize, what: &str) -> Result<Vec<T>> {
    let refused = || out_of_memory(len, std::mem::size_of::<T>(), what);
    let layout = std::alloc::Layout::array::<T>(len).map_err(|_| refused())?;
    if layout.size() == 0 {
        return Ok(Vec::new());
    }
    // SAFETY: the layout's size is not zero.
    let data = unsafe { std::alloc::alloc_zeroed(layout) }.cast::<T>();
    if data.is_null() {
        return Err(refused());
    }
    // SAFETY: `data` comes from the global allocator with `T`'s alignment and room for exactly
    // `len` of them, all zero bits, which `ZeroBits` makes valid values.
    Ok(unsafe { Vec::from_raw_parts(data, len, len) })
}

/// The elements of an iterator that knows its length (as `collect` would build them), or an
/// error naming `what` when their buffer cannot be allocated.
pub(crate) fn collect<T>(items: impl ExactSizeIterator<Item = T>, what: &str) -> Result<Vec<T>> {
    let mut v = with_capacity(items.len(), what)?;
    v.extend(items);
    Ok(v)
}

/// The elements a filter lets through, counted in a first pass so that their buffer is
/// allocated once (`items` must give the same elements twice).
pub(crate) fn collect_counted<T>(
    items: impl Iterator<Item = T> + Clone,
    what: &str,
) -> Result<Vec<T>> {
    let mut v = with_capacity(items.clone().count(), what)?;
    v.extend(items);
    Ok(v)
}

/// The elements of a parallel iterator of known length, in order, in a buffer allocated
/// fallibly (rayon's `collect_into_vec` reuses the capacity it is given).
pub(crate) fn par_collect<T: Send>(
    items: impl rayon::iter::IndexedParallelIterator<Item = T>,
    what: &str,
) -> Result<Vec<T>> {
    let mut v = with_capacity(items.len(), what)?;
    items.collect_into_vec(&mut v);
    Ok(v)
}

fn out_of_memory(count: usize, element_size: usize, what: &str) -> Error {
    let bytes = count as f64 * element_size as f64;
    Error::out_of_memory(format!(
        "could not allocate {:.1} MiB for {what} ({count} elements of {element_size} bytes); \
         free memory, or give a smaller input: a volume cropped to the region of interest, a \
         lower max_vertices, a smaller mesh",
        bytes / (1024.0 * 1024.0)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ErrorKind;
    use rayon::prelude::*;

    #[test]
    fn an_impossible_buffer_is_an_error_that_names_it() {
        let e = filled(usize::MAX / 2, 0u64, "the distance map").unwrap_err();
        assert_eq!(e.kind(), ErrorKind::OutOfMemory);
        assert!(e.message().contains("for the distance map"), "{e}");
        assert!(e.message().contains("elements of 8 bytes"), "{e}");
    }

    #[test]
    fn the_buffers_hold_what_vec_would() {
        assert_eq!(filled(3, 7u8, "x").unwrap(), vec![7u8; 3]);
        assert_eq!(
            collect((0..4).map(|i| i * 2), "x").unwrap(),
            vec![0, 2, 4, 6]
        );
        let squares = par_collect((0..1000u32).into_par_iter().map(|i| i * i), "x").unwrap();
        assert_eq!(squares, (0..1000u32).map(|i| i * i).collect::<Vec<_>>());
        assert!(with_capacity::<f64>(10, "x").unwrap().capacity() >= 10);
        let odd = collect_counted((0..10).filter(|i| i % 2 == 1), "x").unwrap();
        assert_eq!((odd.len(), odd.capacity()), (5, 5));
        assert_eq!(zeroed::<f64>(5, "x").unwrap(), vec![0.0; 5]);
        assert_eq!(zeroed::<bool>(0, "x").unwrap(), Vec::<bool>::new());
        let e = zeroed::<f64>(usize::MAX / 4, "the field").unwrap_err();
        assert_eq!(e.kind(), ErrorKind::OutOfMemory);
        assert!(e.message().contains("for the field"), "{e}");
    }
}
