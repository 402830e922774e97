//! The geometry of a stack of DICOM slices, as ITK's ImageSeriesReader (with GDCM's IPP sorter)
//! gives it: slices sorted by ImagePositionPatient projected on the slice normal (the cross
//! product of ImageOrientationPatient's row and column cosines), the origin at the first slice,
//! the slice spacing the distance from the first position to the last over the slice count
//! minus one, and the direction's columns the row cosine, the column cosine and the normal.
//!
//! What ITK only warns about is an error here, since a segmentation on a wrongly spaced grid is
//! silently wrong: unequal gaps (a missing slice, or varying thickness) and positions that leave
//! the normal (a tilted gantry). Pure arithmetic on positions, so it is tested without files.

use glam::DVec3;

use crate::error::{Error, Result};

/// How far a gap may differ from the median gap, as a fraction of it. A missing slice doubles a
/// gap; DICOM's decimal strings round positions to about 1e-6 mm, far below this.
const GAP_TOLERANCE: f64 = 0.01;
/// How far (mm, plus a fraction of the stack's length) a slice may sit off the line through the
/// first slice along the normal before the stack counts as tilted.
const OFF_AXIS_MM: f64 = 1e-3;
const OFF_AXIS_FRACTION: f64 = 1e-4;
/// The shortest gap (mm) that counts as two slices rather than one slice twice.
const SAME_POSITION_MM: f64 = 1e-4;

/// A sorted stack: `order[n]` is the input index of the n-th slice along the normal.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Stack {
    pub order: Vec<usize>,
    pub origin: DVec3,
    /// The slice spacing (mm); `None` for a single slice, which has no positions to measure.
    pub slice_spacing: Option<f64>,
    /// Row-major, columns row cosine, column cosine, normal (ITK's convention).
    pub direction: [f64; 9],
}

/// The unit row and column cosines of ImageOrientationPatient (six numbers), checked to be
/// perpendicular; `name` is the file the error names.
pub(crate) fn orientation(values: &[f64], name: &str) -> Result<(DVec3, DVec3)> {
    let bad = |why: &str| {
        Error::format(format!(
            "{name}: ImageOrientationPatient {values:?} {why}; the slice orientation is unusable"
        ))
    };
    if values.len() != 6 || values.iter().any(|v| !v.is_finite()) {
        return Err(bad("is not six finite numbers"));
    }
    let row = DVec3::new(values[0], values[1], values[2]);
    let column = DVec3::new(values[3], values[4], values[5]);
    if row.length() < 0.5 || column.length() < 0.5 {
        return Err(bad("has a zero cosine"));
    }
    let (row, column) = (row.normalize(), column.normalize());
    if row.dot(column).abs() > 1e-3 {
        return Err(bad("has row and column cosines that are not perpendicular"));
    }
    Ok((row, column))
}

/// Sorts `positions` (one per slice, named by `names` in errors) along the normal of `row` and
/// `column` and measures the stack.
pub(crate) fn stack(
    row: DVec3,
    column: DVec3,
    positions: &[DVec3],
    names: &[String],
) -> Result<Stack> {
    let normal = row.cross(column).normalize();
    let along: Vec<f64> = positions.iter().map(|p| p.dot(normal)).collect();
    let mut order: Vec<usize> = (0..positions.len()).collect();
    order.sort_by(|&a, &b| along[a].total_cmp(&along[b]));
    let direction = [
        row.x, column.x, normal.x, row.y, column.y, normal.y, row.z, column.z, normal.z,
    ];
    let origin = positions[order[0]];
    if positions.len() == 1 {
        return Ok(Stack {
            order,
            origin,
            slice_spacing: None,
            direction,
        });
    }
    let first = order[0];
    let last = order[order.len() - 1];
    let length = along[last] - along[first];
    let off_axis_limit = OFF_AXIS_MM + OFF_AXIS_FRACTION * length;
    for &n in &order {
        let offset = positions[n] - origin;
        let off_axis = (offset - offset.dot(normal) * normal).length();
        if off_axis > off_axis_limit {
            let degrees = off_axis.atan2(offset.dot(normal)).to_degrees();
            return Err(Error::format(format!(
                "{} lies {off_axis:.3} mm off the line along the slice normal through {} (a \
                 gantry tilt of about {degrees:.2}°): the slices are not a rectangular grid; \
                 resample the series to untilted slices (for example with Slicer's \
                 \"Acquisition tilt correction\" or dcm2niix) and segment the result",
                names[n], names[first]
            )));
        }
    }
    // The median gap is the series' own: a missing slice is then the odd gap out.
    let mut gaps: Vec<f64> = order
        .windows(2)
        .map(|p| along[p[1]] - along[p[0]])
        .collect();
    gaps.sort_by(f64::total_cmp);
    let typical = gaps[gaps.len() / 2];
    for pair in order.windows(2) {
        let gap = along[pair[1]] - along[pair[0]];
        if gap < SAME_POSITION_MM {
            return Err(Error::format(format!(
                "{} and {} are at the same position along the slice normal: the folder holds \
                 one slice twice or two acquisitions of one series; remove the duplicates",
                names[pair[0]], names[pair[1]]
            )));
        }
        if (gap - typical).abs() > GAP_TOLERANCE * typical {
            return Err(Error::format(format!(
                "the gap between {} and {} is {gap:.4} mm but the series' other gaps are \
                 {typical:.4} mm: a slice is missing or the thickness varies, and a volume needs \
                 equal gaps; add the missing file or resample the series",
                names[pair[0]], names[pair[1]]
            )));
        }
    }
    // ITK's spacing: the first-to-last distance over the gaps (exact on equal gaps).
    let slice_spacing = (positions[last] - origin).length() / (order.len() - 1) as f64;
    Ok(Stack {
        order,
        origin,
        slice_spacing: Some(slice_spacing),
        direction,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(n: usize) -> Vec<String> {
        (0..n).map(|i| format!("s{i}.dcm")).collect()
    }

    /// Positions `start + normal * gap * k` for the given ks, in the given order.
    fn along(row: DVec3, column: DVec3, start: DVec3, gap: f64, ks: &[f64]) -> Vec<DVec3> {
        let normal = row.cross(column).normalize();
        ks.iter().map(|&k| start + normal * gap * k).collect()
    }

    fn oblique() -> (DVec3, DVec3) {
        let row = DVec3::new(0.8, 0.6, 0.0);
        let column = DVec3::new(-0.36, 0.48, 0.8);
        (row, column)
    }

    #[test]
    fn shuffled_slices_are_sorted_along_the_normal_with_the_origin_at_the_first() {
        let (row, column) = oblique();
        let start = DVec3::new(-10.0, 20.5, 3.25);
        let positions = along(row, column, start, 1.25, &[3.0, 0.0, 4.0, 1.0, 2.0]);
        let s = stack(row, column, &positions, &names(5)).unwrap();
        assert_eq!(s.order, vec![1, 3, 4, 0, 2]);
        assert!((s.origin - start).length() < 1e-12);
        assert!((s.slice_spacing.unwrap() - 1.25).abs() < 1e-12);
        let normal = row.cross(column);
        for (axis, v) in [row, column, normal].iter().enumerate() {
            let col = DVec3::new(
                s.direction[axis],
                s.direction[3 + axis],
                s.direction[6 + axis],
            );
            assert!((col - *v).length() < 1e-12, "column {axis}");
        }
    }

    #[test]
    fn a_descending_acquisition_still_starts_at_the_lowest_position() {
        let (row, column) = (DVec3::X, DVec3::Y);
        let positions = along(row, column, DVec3::ZERO, 2.0, &[2.0, 1.0, 0.0]);
        let s = stack(row, column, &positions, &names(3)).unwrap();
        assert_eq!(s.order, vec![2, 1, 0]);
        assert_eq!(s.origin, DVec3::ZERO);
    }

    #[test]
    fn a_missing_slice_is_an_error_naming_the_slices_around_the_gap() {
        let (row, column) = oblique();
        let positions = along(row, column, DVec3::ONE, 0.7, &[0.0, 1.0, 3.0, 4.0, 5.0]);
        let e = stack(row, column, &positions, &names(5)).unwrap_err();
        assert!(e.message().contains("between s1.dcm and s2.dcm"), "{e}");
        assert!(e.message().contains("missing"), "{e}");
    }

    #[test]
    fn rounding_of_the_positions_is_not_a_gap() {
        let (row, column) = oblique();
        let mut positions = along(row, column, DVec3::ONE, 0.7, &[0.0, 1.0, 2.0, 3.0]);
        positions[2] += DVec3::splat(2e-6);
        assert!(stack(row, column, &positions, &names(4)).is_ok());
    }

    #[test]
    fn a_tilted_gantry_is_an_error_with_its_angle() {
        let (row, column) = (DVec3::X, DVec3::Y);
        let tilt = 10f64.to_radians();
        let positions: Vec<DVec3> = (0..4)
            .map(|k| DVec3::new(0.0, k as f64 * tilt.sin(), k as f64 * tilt.cos()))
            .collect();
        let e = stack(row, column, &positions, &names(4)).unwrap_err();
        assert!(e.message().contains("tilt of about 10.00°"), "{e}");
    }

    #[test]
    fn one_slice_twice_is_an_error() {
        let (row, column) = (DVec3::X, DVec3::Y);
        let positions = along(row, column, DVec3::ZERO, 1.0, &[0.0, 1.0, 1.0, 2.0]);
        let e = stack(row, column, &positions, &names(4)).unwrap_err();
        assert!(e.message().contains("same position"), "{e}");
    }

    #[test]
    fn a_single_slice_has_no_measured_spacing() {
        let s = stack(DVec3::X, DVec3::Y, &[DVec3::ONE], &names(1)).unwrap();
        assert_eq!(s.slice_spacing, None);
        assert_eq!(s.origin, DVec3::ONE);
    }

    #[test]
    fn orientations_that_are_not_two_perpendicular_cosines_are_refused() {
        assert!(orientation(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "a").is_ok());
        assert!(orientation(&[1.0, 0.0, 0.0, 0.0, 1.0], "a").is_err());
        assert!(orientation(&[1.0, 0.0, 0.0, 0.7, 0.7, 0.0], "a").is_err());
        assert!(orientation(&[0.0, 0.0, 0.0, 0.0, 1.0, 0.0], "a").is_err());
        assert!(orientation(&[f64::NAN, 0.0, 0.0, 0.0, 1.0, 0.0], "a").is_err());
    }
}
