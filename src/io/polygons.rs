//! Turning the faces a file stores (polygons, triangle strips) into the triangles of a
//! [`TriMesh`], the same way VTK's `vtkTriangleFilter` does.

use glam::DVec3;

use crate::error::{Error, Result};
use crate::mesh::TriMesh;

/// A vertex index read from a file as a number. Every integer type the formats use converts to
/// f64 exactly in the u32 range, so out-of-range and fractional values are caught here.
pub(crate) fn index(value: f64) -> Result<u32> {
    // `as` saturates, so the round trip is exact only for integers in range (not NaN).
    let index = value as u32;
    if index as f64 == value {
        Ok(index)
    } else {
        Err(Error::format(format!(
            "vertex index {value} is not an index of the 32-bit range"
        )))
    }
}

/// Fan-triangulates a polygon from its first corner; polygons with fewer than three corners
/// (points and lines) give no triangle.
pub(crate) fn push_polygon(triangles: &mut Vec<[u32; 3]>, corners: &[u32]) {
    if let [first, rest @ ..] = corners {
        triangles.extend(rest.windows(2).map(|w| [*first, w[0], w[1]]));
    }
}

/// Decomposes a triangle strip, flipping every second triangle so that all keep the strip's
/// orientation. Triangles with a repeated corner only turn the strip and are dropped.
pub(crate) fn push_strip(triangles: &mut Vec<[u32; 3]>, corners: &[u32]) {
    for (i, w) in corners.windows(3).enumerate() {
        let t = if i % 2 == 0 {
            [w[0], w[1], w[2]]
        } else {
            [w[0], w[2], w[1]]
        };
        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
            triangles.push(t);
        }
    }
}

/// The mesh of what a file held: an out-of-range index or a non-finite point is corrupt input,
/// hence a format error.
pub(crate) fn mesh(points: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Result<TriMesh> {
    TriMesh::new(points, triangles).map_err(|e| Error::format(e.message()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polygons_fan_and_short_polygons_vanish() {
        let mut t = Vec::new();
        push_polygon(&mut t, &[4, 5, 6, 7, 8]);
        push_polygon(&mut t, &[1, 2]);
        push_polygon(&mut t, &[]);
        assert_eq!(t, [[4, 5, 6], [4, 6, 7], [4, 7, 8]]);
    }

    #[test]
    fn strips_keep_one_orientation_and_drop_turns() {
        let mut t = Vec::new();
        push_strip(&mut t, &[0, 1, 2, 3, 3, 4]);
        // (0,1,2) ccw, (1,3,2) ccw for a zig-zag strip; (2,3,3) and (3,3,4) are turns.
        assert_eq!(t, [[0, 1, 2], [1, 3, 2]]);
    }

    #[test]
    fn indices_outside_u32_or_fractional_are_errors() {
        assert_eq!(index(7.0).unwrap(), 7);
        for bad in [-1.0, 0.5, 4294967296.0, f64::NAN] {
            assert!(index(bad).is_err(), "{bad}");
        }
        let e = mesh(vec![DVec3::ZERO], vec![[0, 0, 1]]).unwrap_err();
        assert_eq!(e.kind(), crate::ErrorKind::Format);
    }
}
