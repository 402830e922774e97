//! One slice panel: the plane resampled from the volume in the display window, the meshes'
//! cross-sections over it, each in its object's colour (the first bright yellow), a cross at
//! the centre (the seed), the plane's name and position, the patient-orientation letters at its
//! edges and a scale bar.

use glam::{DVec2, DVec3};

use super::raster::{Rgb, RgbImage};
use super::slices::SlicePlane;
use super::window::Window;
use super::{font, label_scale, margin, INK};
use crate::Geometry;

/// The cross at the centre: cyan, distinct from the sections' colours and from grey tissue.
const CROSS: Rgb = [0, 215, 255];
/// Width of the section's and the cross's lines in pixels: thick enough to see at a glance.
const LINE_WIDTH: f64 = 2.0;
/// Width of the dark outline under them, which keeps them visible on bright tissue.
const OUTLINE_WIDTH: f64 = 3.5;
/// Scale bar lengths to choose from: 10 mm unless that is too short to see.
const BAR_MM: [f64; 6] = [10.0, 20.0, 50.0, 100.0, 200.0, 500.0];
/// The shortest scale bar, in font pixels.
const MIN_BAR: f64 = 12.0;

/// Draws the panel of `plane` from its `samples` (rows top to bottom, as
/// [`super::slices::resample`] gives them), with the meshes' `sections` (each mesh's segments
/// and their colour, drawn in this order over all the meshes' dark outlines) and, in the lower
/// left corner, `footnote`.
pub(crate) fn slice_panel(
    plane: &SlicePlane,
    samples: &[Option<f64>],
    window: &Window,
    sections: &[(Vec<[DVec3; 2]>, Rgb)],
    geometry: &Geometry,
    footnote: &str,
) -> RgbImage {
    let size = plane.size;
    let mut image = RgbImage::new(size, size, window.colour(None));
    for (n, &sample) in samples.iter().enumerate() {
        let (x, y) = (n as u32 % size, n as u32 / size);
        image.set(x, y, window.colour(sample));
    }
    let sections: Vec<(Vec<[DVec2; 2]>, Rgb)> = sections
        .iter()
        .map(|(segments, colour)| {
            let lines = segments.iter().map(|s| s.map(|p| plane.pixel(p))).collect();
            (lines, *colour)
        })
        .collect();
    draw_all_outlined(&mut image, &sections);
    let scale = label_scale(size);
    draw_outlined(
        &mut image,
        &cross(plane.pixel(plane.centre), scale as f64),
        CROSS,
    );
    let pad = margin(scale);
    image.text(pad, pad, &title(plane, geometry), scale, INK);
    draw_orientation_letters(&mut image, plane, scale);
    draw_scale_bar(&mut image, plane.pixel_mm, scale);
    if !footnote.is_empty() {
        let bottom = size as i64 - pad - (font::GLYPH_HEIGHT * scale) as i64;
        image.text(pad, bottom, footnote, scale, INK);
    }
    image
}

/// "axial k=103, z=22.5": the plane, the index of the voxel axis closest to its normal at the
/// centre, and its world coordinate in mm.
fn title(plane: &SlicePlane, geometry: &Geometry) -> String {
    let axis = plane.orientation.normal_axis();
    let direction = geometry.direction();
    let column = |a: usize| DVec3::new(direction[a], direction[3 + a], direction[6 + a]);
    let along = |a: usize| (column(a)[axis] / column(a).length()).abs();
    let index_axis = (0..3)
        .max_by(|&a, &b| along(a).total_cmp(&along(b)))
        .unwrap_or(axis);
    let index = geometry.world_to_index(plane.centre)[index_axis].round() as i64;
    format!(
        "{} {}={index}, {}={:.1}",
        plane.orientation.name(),
        ["i", "j", "k"][index_axis],
        ["x", "y", "z"][axis],
        plane.centre[axis]
    )
}

/// Lines in `colour` over a dark outline; all outlines first, so that none covers a line.
fn draw_outlined(image: &mut RgbImage, lines: &[[DVec2; 2]], colour: Rgb) {
    draw_all_outlined(image, &[(lines.to_vec(), colour)]);
}

/// Groups of lines, each in its colour, over a dark outline: all groups' outlines first, so
/// that none covers a line of another group where two objects touch; then the lines, group
/// after group.
fn draw_all_outlined(image: &mut RgbImage, groups: &[(Vec<[DVec2; 2]>, Rgb)]) {
    for &[a, b] in groups.iter().flat_map(|(lines, _)| lines) {
        image.line(a, b, OUTLINE_WIDTH, [0, 0, 0]);
    }
    for (lines, colour) in groups {
        for &[a, b] in lines {
            image.line(a, b, LINE_WIDTH, *colour);
        }
    }
}

/// A cross with a gap in its middle, so that the voxel under the centre stays visible.
fn cross(at: DVec2, scale: f64) -> [[DVec2; 2]; 4] {
    let (gap, arm) = (3.0 * scale, 9.0 * scale);
    [DVec2::X, DVec2::Y, -DVec2::X, -DVec2::Y].map(|d| [at + gap * d, at + arm * d])
}

/// The patient direction a world axis points to (LPS): Left, Posterior, Superior and their
/// opposites.
fn patient_direction(v: DVec3) -> &'static str {
    let axis = (0..3)
        .max_by(|&a, &b| v[a].abs().total_cmp(&v[b].abs()))
        .unwrap_or(0);
    let letters = [["R", "L"], ["A", "P"], ["I", "S"]];
    letters[axis][usize::from(v[axis] > 0.0)]
}

fn draw_orientation_letters(image: &mut RgbImage, plane: &SlicePlane, scale: u32) {
    let (right, up) = plane.orientation.right_up();
    let size = plane.size as i64;
    let pad = margin(scale);
    let (w, h) = (
        (font::GLYPH_WIDTH * scale) as i64,
        (font::GLYPH_HEIGHT * scale) as i64,
    );
    let middle = (size - w) / 2;
    let centre_row = (size - h) / 2;
    // A row in from the top and bottom edges, clear of the title and the footnote.
    let row = h + 3 * pad;
    image.text(middle, row - h, patient_direction(up), scale, INK);
    image.text(middle, size - row, patient_direction(-up), scale, INK);
    image.text(pad, centre_row, patient_direction(-right), scale, INK);
    image.text(
        size - pad - w,
        centre_row,
        patient_direction(right),
        scale,
        INK,
    );
}

/// A white bar of a round length in the lower right corner, its length written above it.
fn draw_scale_bar(image: &mut RgbImage, pixel_mm: f64, scale: u32) {
    let shortest = MIN_BAR * scale as f64;
    let mm = BAR_MM
        .into_iter()
        .find(|&mm| mm / pixel_mm >= shortest)
        .unwrap_or(BAR_MM[BAR_MM.len() - 1]);
    let length = (mm / pixel_mm).round() as i64;
    let pad = margin(scale);
    let size = image.width() as i64;
    let thickness = 2 * scale as i64;
    let (right, bottom) = (size - pad, size - pad);
    image.fill_rect(
        right - length,
        bottom - thickness,
        length,
        thickness,
        INK,
        1.0,
    );
    let label = format!("{mm:.0} mm");
    let width = font::text_width(&label, scale) as i64;
    let top = bottom - thickness - pad - (font::GLYPH_HEIGHT * scale) as i64;
    image.text(right - width, top, &label, scale, INK);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::slices::Orientation;

    #[test]
    fn titles_name_the_voxel_axis_along_the_normal() {
        // The vmtk aorta's direction: diag(-1, -1, 1).
        let g = Geometry::new(
            [0.5, 0.5, 2.0],
            [10.0, 20.0, -4.0],
            [-1., 0., 0., 0., -1., 0., 0., 0., 1.],
        )
        .unwrap();
        let centre = g.index_to_world(DVec3::new(7.0, 9.0, 3.0));
        let plane = |orientation| SlicePlane {
            orientation,
            centre,
            pixel_mm: 1.0,
            size: 100,
        };
        assert_eq!(title(&plane(Orientation::Axial), &g), "axial k=3, z=2.0");
        assert_eq!(
            title(&plane(Orientation::Coronal), &g),
            "coronal j=9, y=15.5"
        );
        assert_eq!(
            title(&plane(Orientation::Sagittal), &g),
            "sagittal i=7, x=6.5"
        );
    }

    #[test]
    fn letters_follow_the_radiological_convention() {
        let (right, up) = Orientation::Axial.right_up();
        assert_eq!(
            [patient_direction(-right), patient_direction(right)],
            ["R", "L"]
        );
        assert_eq!([patient_direction(up), patient_direction(-up)], ["A", "P"]);
        let (right, up) = Orientation::Sagittal.right_up();
        assert_eq!(
            [patient_direction(-right), patient_direction(up)],
            ["A", "S"]
        );
    }
}
