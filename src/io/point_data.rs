//! Values written next to a mesh: per-point arrays (vertex state, distances, ...) and
//! per-triangle integer arrays (the `object` label of each triangle when several segmented
//! objects share one file). The types every mesh writer takes, and the checks they share.

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

/// A named integer array with one value per mesh triangle (VTK's cell data), e.g. `object`,
/// the label of the object each triangle bounds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CellData<'a> {
    pub name: &'a str,
    pub values: &'a [i32],
}

/// Checks that every array has one value per point and a name that every format can store:
/// non-empty, no whitespace or control characters (PLY headers and legacy VTK separate words
/// by spaces), unique, and not in `reserved` (names the format already uses).
pub(crate) fn check(mesh: &TriMesh, point_data: &[PointData], reserved: &[&str]) -> Result<()> {
    let mut seen = HashSet::new();
    for data in point_data {
        check_name("point data", data.name, reserved, &mut seen)?;
        check_count(
            "point data",
            data.name,
            data.values.len(),
            mesh.points().len(),
            "point",
        )?;
    }
    Ok(())
}

/// [`check`] for per-triangle arrays: one value per triangle, names as for point data. Point
/// and cell arrays may share a name; every format keeps them apart.
pub(crate) fn check_cells(mesh: &TriMesh, cell_data: &[CellData], reserved: &[&str]) -> Result<()> {
    let mut seen = HashSet::new();
    for data in cell_data {
        check_name("cell data", data.name, reserved, &mut seen)?;
        let triangles = mesh.triangles().len();
        check_count(
            "cell data",
            data.name,
            data.values.len(),
            triangles,
            "triangle",
        )?;
    }
    Ok(())
}

/// One value per `element` (point or triangle), of which the mesh has `count`.
fn check_count(what: &str, name: &str, values: usize, count: usize, element: &str) -> Result<()> {
    if values == count {
        return Ok(());
    }
    Err(Error::invalid_argument(format!(
        "{what} {name:?} has {values} values but the mesh has {count} {element}s; give exactly \
         one value per {element}"
    )))
}

/// Checks one array name and records it in `seen`; `what` is "point data" or "cell data".
fn check_name<'a>(
    what: &str,
    name: &'a str,
    reserved: &[&str],
    seen: &mut HashSet<&'a str>,
) -> Result<()> {
    if name.is_empty() || name.chars().any(|c| c.is_whitespace() || c.is_control()) {
        return Err(Error::invalid_argument(format!(
            "{what} name {name:?} must be non-empty and without spaces or control characters; \
             use e.g. underscores instead of spaces"
        )));
    }
    if reserved.contains(&name) {
        return Err(Error::invalid_argument(format!(
            "{what} name {name:?} is reserved by this file format; rename the array"
        )));
    }
    if !seen.insert(name) {
        return Err(Error::invalid_argument(format!(
            "{what} name {name:?} is given twice; every array needs its own name"
        )));
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

    #[test]
    fn cell_data_needs_one_value_per_triangle_and_distinct_names() {
        let mesh = cube(DVec3::ZERO, DVec3::ONE);
        let labels = [1i32; 12];
        let data = |name, values| CellData { name, values };
        assert!(check_cells(&mesh, &[data("object", &labels)], &[]).is_ok());
        // A point array and a cell array may share a name.
        let state = [0u8; 8];
        let point = [PointData {
            name: "object",
            values: PointValues::U8(&state),
        }];
        assert!(check(&mesh, &point, &[]).is_ok());
        for (bad, reserved, needle) in [
            (
                vec![data("object", &labels[..11])],
                &[][..],
                "11 values but the mesh has 12 triangles",
            ),
            (vec![data("", &labels)], &[], "non-empty"),
            (vec![data("my object", &labels)], &[], "without spaces"),
            (
                vec![data("vertex_indices", &labels)],
                &["vertex_indices"],
                "reserved",
            ),
            (
                vec![data("a", &labels), data("a", &labels)],
                &[],
                "given twice",
            ),
        ] {
            let e = check_cells(&mesh, &bad, reserved).unwrap_err();
            assert_eq!(e.kind(), crate::ErrorKind::InvalidArgument, "{e}");
            assert!(e.message().contains(needle), "{needle}: {e}");
            assert!(e.message().starts_with("cell data"), "{e}");
        }
    }
}
