//! Per-point values written next to a mesh (vertex state, distances, ...): the one type every
//! mesh writer takes, and the checks they share.

use std::collections::HashSet;

use crate::error::{Error, Result};
use crate::mesh::TriMesh;

/// A named array with one value per mesh point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointData<'a> {
    pub name: &'a str,
    pub values: PointValues<'a>,
}

/// The values of a [`PointData`], one per point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PointValues<'a> {
    U8(&'a [u8]),
    F64(&'a [f64]),
}

impl PointValues<'_> {
    pub fn len(&self) -> usize {
        match self {
            PointValues::U8(v) => v.len(),
            PointValues::F64(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Checks that every array has one value per point and a name that every format can store:
/// non-empty, no whitespace or control characters (PLY headers and legacy VTK separate words
/// by spaces), unique, and not in `reserved` (names the format already uses).
pub(crate) fn check(mesh: &TriMesh, point_data: &[PointData], reserved: &[&str]) -> Result<()> {
    let mut seen = HashSet::new();
    for data in point_data {
        let name = data.name;
        if name.is_empty() || name.chars().any(|c| c.is_whitespace() || c.is_control()) {
            return Err(Error::invalid_argument(format!(
                "point data name {name:?} must be non-empty and without spaces or control \
                 characters; use e.g. underscores instead of spaces"
            )));
        }
        if reserved.contains(&name) {
            return Err(Error::invalid_argument(format!(
                "point data name {name:?} is reserved by this file format; rename the array"
            )));
        }
        if !seen.insert(name) {
            return Err(Error::invalid_argument(format!(
                "point data name {name:?} is given twice; every array needs its own name"
            )));
        }
        if data.values.len() != mesh.points().len() {
            return Err(Error::invalid_argument(format!(
                "point data {name:?} has {} values but the mesh has {} points; give exactly one \
                 value per point",
                data.values.len(),
                mesh.points().len()
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_shapes::cube;
    use glam::DVec3;

    #[test]
    fn lengths_names_and_duplicates_are_checked() {
        let mesh = cube(DVec3::ZERO, DVec3::ONE);
        let ok = [0u8; 8];
        let short = [0.0f64; 7];
        let data = |name, values| PointData { name, values };
        assert!(check(&mesh, &[data("state", PointValues::U8(&ok))], &[]).is_ok());
        for (bad, reserved) in [
            (vec![data("d", PointValues::F64(&short))], &[][..]),
            (vec![data("with space", PointValues::U8(&ok))], &[]),
            (vec![data("", PointValues::U8(&ok))], &[]),
            (vec![data("x", PointValues::U8(&ok))], &["x", "y", "z"]),
            (
                vec![
                    data("a", PointValues::U8(&ok)),
                    data("a", PointValues::U8(&ok)),
                ],
                &[],
            ),
        ] {
            let e = check(&mesh, &bad, reserved).unwrap_err();
            assert_eq!(e.kind(), crate::ErrorKind::InvalidArgument, "{e}");
        }
    }
}
