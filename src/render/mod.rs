//! Pictures of a segmentation result (feature `io`), so that a leak shows at a glance: three
//! orthogonal slices of the volume through a centre with the mesh's cross-section drawn over
//! them, and a shaded 3D view of the whole mesh, laid out 2 × 2 (several objects each in their
//! own colour, [`render_objects`]):
//!
//! ```text
//! axial (x–y, anterior up)        coronal (x–z, superior up)
//! sagittal (y–z, anterior left)   3D (anterior oblique)
//! ```
//!
//! Slices are resampled in world millimetres (`slices`), so anisotropic voxels and oblique
//! grids keep their true proportions; the section is exact on the mesh's triangles
//! (`section`); the 3D view is a z-buffered orthographic rendering (`shading`). Everything is
//! drawn on our own small canvas (`raster`, `font`) and written by the `png` crate.

mod font;
mod panel;
mod png_file;
mod raster;
mod section;
mod shading;
mod slices;
mod window;

use glam::DVec3;

use crate::error::{Error, Result};
use crate::{TriMesh, Volume};
use raster::Rgb;
use shading::Camera;
use slices::{Orientation, SlicePlane};
use window::Window;

pub use png_file::write_png;
pub use raster::RgbImage;

/// The smallest and largest side of a panel, in pixels: below the labels no longer fit, above
/// a picture is hundreds of megabytes.
pub const MIN_PANEL_PX: u32 = 64;
pub const MAX_PANEL_PX: u32 = 4096;
/// Black lines between the panels, so that neighbouring panels' backgrounds do not merge.
const GAP: u32 = 2;
/// The colour of labels.
const INK: Rgb = [235, 235, 235];

/// The objects' colours, in order (repeating after the last): a bright colour for the section
/// lines in the slice panels and the legend, and a paler one of the same hue for the surface in
/// the 3D view. The first is the single mesh's yellow and gold; the others keep clear of the
/// cyan centre cross, the magenta of unknown voxels, the red of a surface's inside and of each
/// other, yellow against violet first as the pair most people tell apart, colour-blind or not.
const PALETTE: [(Rgb, [f64; 3]); 8] = [
    ([255, 232, 0], [240.0, 214.0, 128.0]),   // yellow
    ([150, 130, 255], [165.0, 155.0, 245.0]), // violet
    ([40, 220, 90], [135.0, 215.0, 145.0]),   // green
    ([255, 140, 0], [245.0, 170.0, 100.0]),   // orange
    ([255, 105, 190], [240.0, 160.0, 210.0]), // pink
    ([0, 200, 170], [120.0, 205.0, 190.0]),   // teal
    ([190, 130, 70], [200.0, 160.0, 120.0]),  // brown
    ([180, 255, 60], [200.0, 235.0, 140.0]),  // lime
];

/// The colour of object `n` (from 0) in [`render_objects`]'s picture: its section lines and its
/// legend swatch (its surface in the 3D view is a paler shade of it). Colours repeat after the
/// eighth object.
pub fn object_colour(n: usize) -> Rgb {
    PALETTE[n % PALETTE.len()].0
}

/// One object of [`render_objects`]'s picture: its mesh, in the volume's world space, and the
/// text that names it in the legend (such as its label, "1").
#[derive(Debug, Clone, Copy)]
pub struct RenderObject<'a> {
    pub mesh: &'a TriMesh,
    pub label: &'a str,
}

/// What to draw. Every `None` is chosen from the volume and the mesh (with several objects, the
/// union of their meshes: the box holding all of them).
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    /// The world point (mm, LPS) the three planes pass through, marked by a cross. Default:
    /// the centre of the mesh's bounding box, or the volume's centre.
    pub centre: Option<DVec3>,
    /// The display window (lo, hi): lo is black, hi white. Default: the 1st to 99th
    /// percentile of the volume in the three slice panels.
    pub window: Option<(f64, f64)>,
    /// The side of each panel in pixels ([`MIN_PANEL_PX`]–[`MAX_PANEL_PX`]); the picture is
    /// 2 × `panel_px` + 2 pixels square.
    pub panel_px: u32,
    /// The side of each slice panel's square field of view in mm. Default: the mesh's largest
    /// bounding-box extent × 1.4 + 20 mm (the extent taken as twice the box's largest reach
    /// from the centre, when that is not the box's middle), at most the volume's largest
    /// extent; without a mesh, the volume's largest extent.
    pub field_mm: Option<f64>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            centre: None,
            window: None,
            panel_px: 420,
            field_mm: None,
        }
    }
}

/// The overview picture of `volume` and, if given, `mesh` (in the volume's world space): the
/// axial, coronal and sagittal planes through the centre with the mesh's cross-section in
/// yellow, and a shaded 3D view of the mesh. Places outside the volume are dark blue-grey,
/// unknown (NaN) voxels magenta. The same as [`render_objects`] with that one mesh (or none).
pub fn render_overview(
    volume: &Volume<'_>,
    mesh: Option<&TriMesh>,
    options: &RenderOptions,
) -> Result<RgbImage> {
    let objects: Vec<RenderObject<'_>> = mesh
        .map(|mesh| RenderObject { mesh, label: "" })
        .into_iter()
        .collect();
    render_objects(volume, &objects, options)
}

/// The overview picture of `volume` and several objects' meshes (in the volume's world space),
/// each in its own colour ([`object_colour`]: yellow, violet, green, orange, ...): the axial,
/// coronal and sagittal planes through the centre with every mesh's cross-section in its
/// colour, and a shaded 3D view of all of them together, each surface in a paler shade of its
/// colour, nearer surfaces hiding farther ones whichever object they belong to. With two or
/// more objects, a legend in the 3D panel's lower right corner shows each object's colour and
/// label (a label too long for half the panel is cut short, ending in ".."). One object gives exactly
/// [`render_overview`]'s picture, no objects the volume alone. Every mesh must have triangles
/// and reach into the volume.
pub fn render_objects(
    volume: &Volume<'_>,
    objects: &[RenderObject<'_>],
    options: &RenderOptions,
) -> Result<RgbImage> {
    let size = options.panel_px;
    if !(MIN_PANEL_PX..=MAX_PANEL_PX).contains(&size) {
        return Err(Error::invalid_argument(format!(
            "a panel of {size} pixels; give {MIN_PANEL_PX} to {MAX_PANEL_PX}"
        )));
    }
    let window = options.window.map(checked_window).transpose()?;
    let extent = VolumeBox::of(volume);
    let bounds = union_bounds(objects, &extent)?;
    let centre = match options.centre {
        Some(c) => checked_centre(c, volume)?,
        None => default_centre(volume, bounds),
    };
    let field_mm = match options.field_mm {
        Some(f) if f.is_finite() && f > 0.0 => f,
        Some(f) => {
            return Err(Error::invalid_argument(format!(
                "a field of view of {f} mm; give a positive number of mm"
            )))
        }
        None => default_field(bounds, centre, &extent),
    };
    let planes = Orientation::ALL.map(|orientation| SlicePlane {
        orientation,
        centre,
        pixel_mm: field_mm / size as f64,
        size,
    });
    let samples = planes.map(|plane| slices::resample(volume, &plane));
    let window = window.unwrap_or_else(|| Window::percentiles(samples.iter().flatten().copied()));
    let side = 2 * size + GAP;
    let mut picture = RgbImage::new(side, side, [0, 0, 0]);
    let corners = [(0, 0), (size + GAP, 0), (0, size + GAP)];
    for (n, (plane, samples)) in planes.iter().zip(&samples).enumerate() {
        let (normal, offset) = plane.normal_offset();
        let sections: Vec<(Vec<[DVec3; 2]>, Rgb)> = objects
            .iter()
            .enumerate()
            .map(|(n, object)| {
                let segments = section::section(object.mesh, normal, offset);
                (segments, object_colour(n))
            })
            .collect();
        let footnote = match plane.orientation {
            Orientation::Axial => format!("window {}..{}", short(window.lo), short(window.hi)),
            _ => String::new(),
        };
        let panel = panel::slice_panel(
            plane,
            samples,
            &window,
            &sections,
            volume.geometry(),
            &footnote,
        );
        picture.draw_image(&panel, corners[n].0, corners[n].1);
    }
    picture.draw_image(&view_panel(objects, size), size + GAP, size + GAP);
    Ok(picture)
}

/// The scale of the labels' font for a panel of `size` pixels: 2 on the default 420.
fn label_scale(size: u32) -> u32 {
    (size / 210).max(1)
}

/// The distance of labels from a panel's edge.
fn margin(scale: u32) -> i64 {
    4 * scale as i64
}

/// A number with three significant digits, or as a whole number when it is larger.
fn short(v: f64) -> String {
    let digits = if v == 0.0 {
        0
    } else {
        (2 - v.abs().log10().floor() as i64).clamp(0, 4) as usize
    };
    format!("{v:.digits$}")
}

fn checked_window((lo, hi): (f64, f64)) -> Result<Window> {
    if lo.is_finite() && hi.is_finite() && lo < hi {
        Ok(Window { lo, hi })
    } else {
        Err(Error::invalid_argument(format!(
            "the display window {lo}..{hi} is empty; give finite lo < hi"
        )))
    }
}

/// The world bounding box of a volume's voxels (each voxel reaching half a spacing around its
/// centre).
struct VolumeBox {
    lo: DVec3,
    hi: DVec3,
}

impl VolumeBox {
    fn of(volume: &Volume<'_>) -> VolumeBox {
        let dims = volume.dims().map(|d| d as f64);
        let corners = (0..8).map(|n| {
            let index = DVec3::from_array(std::array::from_fn(|a| {
                if n >> a & 1 == 0 {
                    -0.5
                } else {
                    dims[a] - 0.5
                }
            }));
            volume.geometry().index_to_world(index)
        });
        let (lo, hi) = corners.fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p), hi.max(p))
        });
        VolumeBox { lo, hi }
    }

    fn largest_extent(&self) -> f64 {
        (self.hi - self.lo).max_element()
    }
}

/// The box holding all the objects' meshes, `None` without objects; an error for a mesh
/// without triangles or one beside the volume.
fn union_bounds(
    objects: &[RenderObject<'_>],
    volume: &VolumeBox,
) -> Result<Option<(DVec3, DVec3)>> {
    let mut union: Option<(DVec3, DVec3)> = None;
    for (n, object) in objects.iter().enumerate() {
        let name = match (objects.len(), object.label) {
            (1, _) => "the mesh".to_string(),
            (_, "") => format!("mesh {}", n + 1),
            (_, label) => format!("the mesh of object {label}"),
        };
        let (lo, hi) = mesh_bounds(object.mesh, volume, &name)?;
        union = Some(match union {
            Some((l, h)) => (l.min(lo), h.max(hi)),
            None => (lo, hi),
        });
    }
    Ok(union)
}

/// The mesh's bounds; an error for a mesh without triangles or one beside the volume, naming
/// the mesh as `name` ("the mesh").
fn mesh_bounds(mesh: &TriMesh, volume: &VolumeBox, name: &str) -> Result<(DVec3, DVec3)> {
    let bounds = mesh.bounds().filter(|_| !mesh.triangles().is_empty());
    let Some((lo, hi)) = bounds else {
        let instead = if name == "the mesh" {
            "render the volume without a mesh to see it alone"
        } else {
            "leave it out to see the others"
        };
        return Err(Error::invalid_mesh(format!(
            "{name} has no triangles, so there is nothing to draw; {instead}"
        )));
    };
    if lo.cmple(volume.hi).all() && hi.cmpge(volume.lo).all() {
        return Ok((lo, hi));
    }
    let span = |lo: DVec3, hi: DVec3| {
        format!(
            "x {:.1}..{:.1}, y {:.1}..{:.1}, z {:.1}..{:.1} mm",
            lo.x, hi.x, lo.y, hi.y, lo.z, hi.z
        )
    };
    Err(Error::invalid_argument(format!(
        "{name} ({}) lies outside the volume ({}); are both in the same world space? (LPS; a \
         mesh in RAS has x and y negated)",
        span(lo, hi),
        span(volume.lo, volume.hi)
    )))
}

/// A given centre, if it is a finite point within the volume.
fn checked_centre(centre: DVec3, volume: &Volume<'_>) -> Result<DVec3> {
    if !centre.is_finite() {
        return Err(Error::invalid_argument(format!(
            "the centre is {centre}; give three finite world coordinates in mm"
        )));
    }
    let index = volume.geometry().world_to_index(centre);
    let dims = volume.dims();
    if (0..3).all(|a| index[a] >= -0.5 && index[a] <= dims[a] as f64 - 0.5) {
        return Ok(centre);
    }
    Err(Error::invalid_argument(format!(
        "the centre ({:.1}, {:.1}, {:.1}) mm lies outside the volume: it is at voxel index \
         ({:.1}, {:.1}, {:.1}) of a {} × {} × {} grid",
        centre.x, centre.y, centre.z, index.x, index.y, index.z, dims[0], dims[1], dims[2]
    )))
}

/// The middle of the mesh's bounds, or of the volume, moved into the volume if it is outside
/// (a curved mesh's middle can be).
fn default_centre(volume: &Volume<'_>, bounds: Option<(DVec3, DVec3)>) -> DVec3 {
    let geometry = volume.geometry();
    let last = DVec3::from_array(volume.dims().map(|d| (d - 1) as f64));
    let index = match bounds {
        Some((lo, hi)) => geometry
            .world_to_index(0.5 * (lo + hi))
            .clamp(DVec3::ZERO, last),
        None => 0.5 * last,
    };
    geometry.index_to_world(index)
}

/// Room for the mesh around the centre and a margin, at most the volume's extent.
fn default_field(bounds: Option<(DVec3, DVec3)>, centre: DVec3, volume: &VolumeBox) -> f64 {
    let whole = volume.largest_extent();
    match bounds {
        Some((lo, hi)) => {
            let reach = (hi - centre).max(centre - lo).max_element();
            (2.0 * reach * 1.4 + 20.0).min(whole)
        }
        None => whole,
    }
}

/// The shaded 3D panel of the objects, with a legend when there are several, or a dark one
/// saying there is no mesh.
fn view_panel(objects: &[RenderObject<'_>], size: u32) -> RgbImage {
    let scale = label_scale(size);
    let pad = margin(scale);
    if objects.is_empty() {
        let mut image = RgbImage::new(size, size, shading::BACKGROUND);
        let text = "no mesh";
        let x = (size - font::text_width(text, scale)) as i64 / 2;
        let y = (size - font::GLYPH_HEIGHT * scale) as i64 / 2;
        image.text(x, y, text, scale, INK);
        return image;
    }
    let camera = Camera::anterior_oblique();
    // The side most of a surface faces is its outside, so that what shows in the inside's
    // colour is what is oriented against the rest.
    let surfaces: Vec<shading::Surface<'_>> = objects
        .iter()
        .enumerate()
        .map(|(n, object)| shading::Surface {
            mesh: object.mesh,
            colour: PALETTE[n % PALETTE.len()].1,
            inward: object.mesh.signed_volume() < 0.0,
        })
        .collect();
    let mut image = shading::shaded_view(&surfaces, &camera, size);
    shading::draw_triad(&mut image, &camera);
    let inward = surfaces.iter().filter(|s| s.inward).count();
    let title = if inward == 0 {
        "3D"
    } else if inward == surfaces.len() {
        "3D, normals inward"
    } else {
        "3D, some normals inward"
    };
    image.text(pad, pad, title, scale, INK);
    if objects.len() > 1 {
        draw_legend(&mut image, objects, scale);
    }
    image
}

/// Each object's colour swatch and label, one a row, in the lower right corner (the axes'
/// triad is in the lower left), the first object on top; labels cut to fit half the panel.
fn draw_legend(image: &mut RgbImage, objects: &[RenderObject<'_>], scale: u32) {
    let size = image.width() as i64;
    let pad = margin(scale);
    let s = scale as i64;
    let swatch = (font::GLYPH_HEIGHT * scale) as i64;
    let room = size / 2 - swatch - 3 * s;
    let labels: Vec<String> = objects
        .iter()
        .map(|o| fitted(o.label, scale, room as u32))
        .collect();
    let widest = labels
        .iter()
        .map(|l| font::text_width(l, scale) as i64)
        .max()
        .unwrap_or(0);
    let left = size - pad - widest - swatch - 3 * s;
    let row = swatch + 3 * s;
    let top = size - pad - swatch - (objects.len() as i64 - 1) * row;
    for (n, label) in labels.iter().enumerate() {
        let y = top + n as i64 * row;
        image.fill_rect(
            left - s,
            y - s,
            swatch + 2 * s,
            swatch + 2 * s,
            [0, 0, 0],
            1.0,
        );
        image.fill_rect(left, y, swatch, swatch, object_colour(n), 1.0);
        if !label.is_empty() {
            image.text(left + swatch + 3 * s, y, label, scale, INK);
        }
    }
}

/// `label`, or as much of it as fits in `width` pixels followed by "..".
fn fitted(label: &str, scale: u32, width: u32) -> String {
    if font::text_width(label, scale) <= width {
        return label.to_string();
    }
    let mut cut: String = label.chars().collect();
    while !cut.is_empty() && font::text_width(&format!("{cut}.."), scale) > width {
        cut.pop();
    }
    format!("{cut}..")
}

#[cfg(test)]
mod tests {
    use glam::DVec2;

    use super::*;
    use crate::marching_cubes::marching_cubes;
    use crate::phantom::{self, oblique_direction, PhantomOptions, Shape};

    fn torus_phantom(options: &PhantomOptions) -> (phantom::Phantom, TriMesh) {
        let phantom = phantom::render(Shape::Torus, options).unwrap();
        let mesh = marching_cubes(&phantom.image.view(), 600.0).unwrap();
        (phantom, mesh)
    }

    /// The overview of the default torus phantom and its isosurface.
    fn torus_overview(panel_px: u32) -> RgbImage {
        let (phantom, mesh) = torus_phantom(&PhantomOptions::default());
        let options = RenderOptions {
            panel_px,
            ..RenderOptions::default()
        };
        render_overview(&phantom.image.view(), Some(&mesh), &options).unwrap()
    }

    fn is_section(p: Rgb) -> bool {
        p[0] > 200 && p[1] > 180 && p[2] < 90
    }

    /// The panel at column `col`, row `row` of the layout.
    fn panel_pixels(picture: &RgbImage, size: u32, col: u32, row: u32) -> Vec<(u32, u32, Rgb)> {
        let (x0, y0) = (col * (size + GAP), row * (size + GAP));
        (0..size)
            .flat_map(|y| (0..size).map(move |x| (x, y)))
            .map(|(x, y)| (x, y, picture.pixel(x0 + x, y0 + y).unwrap()))
            .collect()
    }

    #[test]
    fn a_torus_phantom_shows_its_section_in_every_slice_and_its_surface_in_3d() {
        let picture = torus_overview(200);
        assert_eq!((picture.width(), picture.height()), (402, 402));
        for (col, row) in [(0, 0), (1, 0), (0, 1)] {
            let yellow = panel_pixels(&picture, 200, col, row)
                .into_iter()
                .filter(|&(_, _, p)| is_section(p))
                .count();
            assert!(yellow > 100, "panel {col},{row}: {yellow} yellow pixels");
        }
        let surface = panel_pixels(&picture, 200, 1, 1)
            .into_iter()
            .filter(|&(_, _, p)| p != shading::BACKGROUND)
            .count();
        assert!(surface > 5000, "{surface}");
    }

    #[test]
    fn sections_lie_on_the_surface_of_an_oblique_anisotropic_phantom() {
        let (phantom, mesh) = torus_phantom(&PhantomOptions {
            spacing: [0.7, 0.8, 1.6],
            direction: oblique_direction(),
            ..PhantomOptions::default()
        });
        let size = 240;
        let picture = render_overview(
            &phantom.image.view(),
            Some(&mesh),
            &RenderOptions {
                panel_px: size,
                ..RenderOptions::default()
            },
        )
        .unwrap();
        // The default field and centre, as render_overview chose them.
        let (lo, hi) = mesh.bounds().unwrap();
        let extent = VolumeBox::of(&phantom.image.view());
        let centre = default_centre(&phantom.image.view(), Some((lo, hi)));
        let field = default_field(Some((lo, hi)), centre, &extent);
        for (n, orientation) in Orientation::ALL.into_iter().enumerate() {
            let plane = SlicePlane {
                orientation,
                centre,
                pixel_mm: field / size as f64,
                size,
            };
            let (col, row) = [(0, 0), (1, 0), (0, 1)][n];
            let mut yellow = 0;
            for (x, y, p) in panel_pixels(&picture, size, col, row) {
                if is_section(p) {
                    let world = plane.world(DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
                    let d = Shape::Torus.signed_distance(world);
                    assert!(
                        d.abs() < 2.0 * plane.pixel_mm + 0.3,
                        "{orientation:?}: {d} mm off"
                    );
                    yellow += 1;
                }
            }
            assert!(yellow > 100, "{orientation:?}");
        }
    }

    #[test]
    fn the_same_input_gives_the_same_bytes_on_any_thread_count() {
        let (phantom, mesh) = torus_phantom(&PhantomOptions::default());
        let render = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    render_overview(
                        &phantom.image.view(),
                        Some(&mesh),
                        &RenderOptions::default(),
                    )
                    .unwrap()
                })
        };
        assert_eq!(render(1), render(3));
    }

    #[test]
    fn only_a_part_oriented_against_the_rest_shows_as_inside() {
        let (phantom, inward) = torus_phantom(&PhantomOptions::default());
        let volume = phantom.image.view();
        let options = RenderOptions {
            panel_px: 160,
            ..RenderOptions::default()
        };
        let red = |mesh: &TriMesh| {
            let picture = render_overview(&volume, Some(mesh), &options).unwrap();
            panel_pixels(&picture, 160, 1, 1)
                .into_iter()
                .filter(|&(_, _, p)| p[0] > 60 && p[1] < p[0] / 3 && p[2] < p[0] / 3)
                .count()
        };
        // Marching cubes' normals point to the bright inside: shown as the outside all the same.
        assert!(inward.signed_volume() < 0.0);
        assert_eq!(red(&inward), 0);
        assert_eq!(red(&inward.clone().flipped()), 0);
        // Turn the triangles of the part nearest the camera the other way.
        let eye = -Camera::anterior_oblique().forward;
        let (points, mut triangles) = inward.into_parts();
        for t in &mut triangles {
            let middle = t.iter().map(|&v| points[v as usize]).sum::<DVec3>() / 3.0;
            if middle.dot(eye) > 8.0 {
                t.swap(1, 2);
            }
        }
        let patched = TriMesh::new(points, triangles).unwrap();
        assert!(red(&patched) > 200, "{}", red(&patched));
    }

    #[test]
    fn without_a_mesh_the_volume_is_shown_whole_and_the_3d_panel_says_so() {
        let (phantom, _) = torus_phantom(&PhantomOptions::default());
        let options = RenderOptions {
            panel_px: 100,
            ..RenderOptions::default()
        };
        let picture = render_overview(&phantom.image.view(), None, &options).unwrap();
        assert!(!picture
            .as_bytes()
            .chunks(3)
            .any(|p| is_section([p[0], p[1], p[2]])));
        let ink = panel_pixels(&picture, 100, 1, 1)
            .into_iter()
            .filter(|&(_, _, p)| p == INK)
            .count();
        assert!(ink > 20, "no 'no mesh' label: {ink}");
    }

    #[test]
    fn unknown_voxels_are_magenta_and_the_outside_blue_grey() {
        let geometry = crate::Geometry::with_spacing([1.0, 1.0, 3.0], [0.0; 3]).unwrap();
        let mut voxels = vec![5.0f32; 10 * 10 * 10];
        voxels[5 * 100 + 5 * 10 + 5] = f32::NAN;
        let volume =
            Volume::from(crate::TypedVolume::contiguous(&voxels, [10, 10, 10], geometry).unwrap());
        let options = RenderOptions {
            centre: Some(DVec3::new(5.0, 5.0, 15.0)),
            panel_px: 100,
            field_mm: Some(50.0),
            ..RenderOptions::default()
        };
        let picture = render_overview(&volume, None, &options).unwrap();
        let axial = panel_pixels(&picture, 100, 0, 0);
        let colour_at = |x, y| axial.iter().find(|p| (p.0, p.1) == (x, y)).unwrap().2;
        // The centre of the axial plane is the unknown voxel (the cross leaves it free).
        assert_eq!(colour_at(50, 50), window::UNKNOWN);
        // 20 mm right of it is outside the 10 mm wide volume.
        assert_eq!(colour_at(90, 70), window::OUTSIDE);
    }

    #[test]
    fn bad_input_is_an_error_that_says_what_to_change() {
        let (phantom, mesh) = torus_phantom(&PhantomOptions::default());
        let far = mesh
            .clone()
            .map_points(|p| p + DVec3::new(500.0, 0.0, 0.0))
            .unwrap();
        let empty = TriMesh::default();
        let with = |change: fn(&mut RenderOptions)| {
            let mut options = RenderOptions::default();
            change(&mut options);
            options
        };
        let cases: [(Option<&TriMesh>, RenderOptions, &str); 13] = [
            (Some(&empty), with(|_| {}), "no triangles"),
            (Some(&far), with(|_| {}), "outside the volume"),
            (None, with(|o| o.window = Some((10.0, 10.0))), "window"),
            (None, with(|o| o.window = Some((20.0, 10.0))), "window"),
            (None, with(|o| o.window = Some((f64::NAN, 1.0))), "window"),
            (None, with(|o| o.centre = Some(DVec3::NAN)), "centre"),
            (None, with(|o| o.centre = Some(DVec3::Z * 900.0)), "centre"),
            (None, with(|o| o.panel_px = 0), "pixels"),
            (None, with(|o| o.panel_px = 4097), "pixels"),
            (None, with(|o| o.panel_px = u32::MAX), "pixels"),
            (None, with(|o| o.field_mm = Some(0.0)), "field of view"),
            (None, with(|o| o.field_mm = Some(-3.0)), "field of view"),
            (
                None,
                with(|o| o.field_mm = Some(f64::INFINITY)),
                "field of view",
            ),
        ];
        for (mesh, options, expected) in cases {
            let e = render_overview(&phantom.image.view(), mesh, &options).unwrap_err();
            assert!(e.message().contains(expected), "{options:?}: {e}");
        }
    }

    /// A uniform 40 mm cube of 1 mm voxels from the origin.
    fn plain_volume(voxels: &[f32]) -> Volume<'_> {
        let geometry = crate::Geometry::with_spacing([1.0; 3], [0.0; 3]).unwrap();
        Volume::from(crate::TypedVolume::contiguous(voxels, [40, 40, 40], geometry).unwrap())
    }

    fn count(pixels: &[(u32, u32, Rgb)], colour: Rgb) -> usize {
        pixels.iter().filter(|p| p.2 == colour).count()
    }

    #[test]
    fn two_objects_show_in_their_own_colours_in_every_panel_with_a_legend() {
        let voxels = vec![100.0f32; 40 * 40 * 40];
        let volume = plain_volume(&voxels);
        // Apart along the diagonal, each crossing all three planes through the middle of both.
        let first = TriMesh::icosphere(DVec3::splat(13.0), 9.0, 4);
        let second = TriMesh::icosphere(DVec3::splat(27.0), 9.0, 4);
        let objects = [
            RenderObject {
                mesh: &first,
                label: "1",
            },
            RenderObject {
                mesh: &second,
                label: "2",
            },
        ];
        let size = 200;
        let options = RenderOptions {
            panel_px: size,
            ..RenderOptions::default()
        };
        let picture = render_objects(&volume, &objects, &options).unwrap();
        let (yellow, violet) = (object_colour(0), object_colour(1));
        assert_eq!(yellow, [255, 232, 0]);
        for (col, row) in [(0, 0), (1, 0), (0, 1)] {
            let panel = panel_pixels(&picture, size, col, row);
            let (a, b) = (count(&panel, yellow), count(&panel, violet));
            assert!(
                a > 100 && b > 100,
                "panel {col},{row}: {a} yellow, {b} violet"
            );
            // Each circle in its own corner: the yellow one about the first sphere.
            let mean_x = |colour| {
                let xs: Vec<f64> = panel
                    .iter()
                    .filter(|p| p.2 == colour)
                    .map(|p| p.0 as f64)
                    .collect();
                xs.iter().sum::<f64>() / xs.len() as f64
            };
            assert!((mean_x(yellow) - mean_x(violet)).abs() > 40.0);
        }
        // The 3D view: both surfaces, in gold and in violet, and the legend's two swatches.
        let view = panel_pixels(&picture, size, 1, 1);
        let hue = |p: Rgb, n: usize| {
            let c = PALETTE[n].1;
            let k = (p[0] as f64 + p[1] as f64 + p[2] as f64) / (c[0] + c[1] + c[2]);
            k > 0.1 && (0..3).all(|a| (p[a] as f64 - k * c[a]).abs() < 6.0)
        };
        let gold = view.iter().filter(|p| hue(p.2, 0)).count();
        let lilac = view.iter().filter(|p| hue(p.2, 1)).count();
        assert!(
            gold > 2000 && lilac > 2000,
            "{gold} gold, {lilac} lilac pixels"
        );
        let swatch = (font::GLYPH_HEIGHT * label_scale(size)).pow(2) as usize;
        assert!(count(&view, yellow) >= swatch && count(&view, violet) >= swatch);
        // One object is render_overview's picture, without a legend.
        let one = render_objects(&volume, &objects[..1], &options).unwrap();
        assert_eq!(
            one,
            render_overview(&volume, Some(&first), &options).unwrap()
        );
        assert_eq!(count(&panel_pixels(&one, size, 1, 1), yellow), 0);
        assert_eq!(count(&panel_pixels(&one, size, 0, 0), violet), 0);
    }

    #[test]
    fn the_default_view_holds_every_object_and_a_bad_one_is_named() {
        let voxels = vec![100.0f32; 40 * 40 * 40];
        let volume = plain_volume(&voxels);
        let small = TriMesh::icosphere(DVec3::splat(8.0), 3.0, 2);
        let far = TriMesh::icosphere(DVec3::splat(32.0), 3.0, 2);
        let objects = |a, b| {
            [
                RenderObject {
                    mesh: a,
                    label: "aorta",
                },
                RenderObject {
                    mesh: b,
                    label: "heart",
                },
            ]
        };
        let extent = VolumeBox::of(&volume);
        let bounds = union_bounds(&objects(&small, &far), &extent).unwrap();
        assert_eq!(bounds, Some((DVec3::splat(5.0), DVec3::splat(35.0))));
        assert_eq!(default_centre(&volume, bounds), DVec3::splat(20.0));
        let empty = TriMesh::default();
        let outside = far.clone().map_points(|p| p + DVec3::X * 200.0).unwrap();
        let e = render_objects(&volume, &objects(&small, &empty), &RenderOptions::default())
            .unwrap_err();
        assert!(e.message().contains("object heart has no triangles"), "{e}");
        let e = render_objects(
            &volume,
            &objects(&outside, &small),
            &RenderOptions::default(),
        )
        .unwrap_err();
        assert!(e.message().contains("object aorta ("), "{e}");
        assert!(e.message().contains("outside the volume"), "{e}");
    }

    #[test]
    fn long_legend_labels_are_cut_to_fit() {
        assert_eq!(fitted("12", 2, 100), "12");
        // 6 pixels a letter at scale 1, less the last space: 8 letters are 47 pixels.
        assert_eq!(fitted("abdominal_aorta", 1, 47), "abdomi..");
        assert_eq!(fitted("abdominal_aorta", 1, 5), "..");
    }

    #[test]
    fn labels_are_short_numbers() {
        assert_eq!(short(1946.4), "1946");
        assert_eq!(short(-135.0), "-135");
        assert_eq!(short(12.34), "12.3");
        assert_eq!(short(0.5), "0.500");
        assert_eq!(short(0.0), "0");
    }

    #[test]
    fn a_written_overview_decodes_to_the_same_picture() {
        let picture = torus_overview(96);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("overview.png");
        write_png(&path, &picture).unwrap();
        let (width, height, bytes) = png_file::tests::read_png(&path);
        assert_eq!((width, height), (194, 194));
        assert_eq!(bytes, picture.as_bytes());
    }
}
