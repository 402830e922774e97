//! A shaded 3D view of one or several whole meshes: orthographic projection from an
//! anterior-oblique direction, fitted to the meshes' joint bounds, z-buffered triangle
//! rasterisation at pixel centres (one depth buffer for all meshes, so that each hides what is
//! behind it whichever mesh that belongs to), flat Lambert shading of each mesh in its own
//! colour with a little ambient light and a depth cue, and a small triad of the world axes.
//!
//! Triangles seen from their inside are drawn in another colour: on a consistently oriented
//! closed surface the z-buffer hides every inside, so what shows of that colour is a hole, a
//! wrongly oriented patch or an inside-out part. Which side is the outside is the caller's
//! choice: the right-hand normal's side, or the other side for a mesh whose normals point
//! inwards (as marching cubes gives them for a bright structure).
//! Triangles are drawn one after another in their order, mesh after mesh, so the picture does not
//! depend on the thread count; a tie in depth keeps the earlier triangle.

use glam::{DMat3, DVec2, DVec3};

use super::raster::{self, Rgb, RgbImage};

/// Background of the 3D panel.
pub(crate) const BACKGROUND: Rgb = [18, 18, 24];
/// The inside of a surface, where it shows: red, for something wrong (whatever the surface's
/// own colour).
const BACK: [f64; 3] = [225.0, 60.0, 50.0];
const AMBIENT: f64 = 0.22;
/// How much darker the far side of the mesh is than the near side.
const DEPTH_CUE: f64 = 0.35;
/// The share of the panel the mesh's larger projected extent fills.
const FILL: f64 = 0.86;

/// An orthographic camera: the picture's right and up and the viewing direction (into the
/// picture), orthonormal and right-handed (right × up = −forward).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Camera {
    pub right: DVec3,
    pub up: DVec3,
    pub forward: DVec3,
}

impl Camera {
    /// From the front (looking along LPS +y, the patient's left to the right, superior up),
    /// turned 30° about z towards the patient's left and 20° about x towards the head: the left
    /// anterior oblique, cranial view of angiography, where vessels running straight back or
    /// straight up do not hide behind themselves.
    pub fn anterior_oblique() -> Camera {
        let turn = DMat3::from_rotation_z(30f64.to_radians())
            * DMat3::from_rotation_x(-20f64.to_radians());
        Camera {
            right: turn * DVec3::X,
            up: turn * DVec3::Z,
            forward: turn * DVec3::Y,
        }
    }

    /// Light from above, left and in front of the viewer.
    fn light(&self) -> DVec3 {
        (0.45 * self.up - 0.35 * self.right - 0.8 * self.forward).normalize()
    }
}

/// One mesh of a 3D view and how to draw it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Surface<'a> {
    pub mesh: &'a crate::TriMesh,
    /// The colour of its outside in full light.
    pub colour: [f64; 3],
    /// Whether the triangles' right-hand normals point to the inside.
    pub inward: bool,
}

/// The surfaces seen through `camera` on a `size` × `size` panel, fitted to their joint
/// projected bounds.
pub(crate) fn shaded_view(surfaces: &[Surface<'_>], camera: &Camera, size: u32) -> RgbImage {
    let views: Vec<Vec<DVec3>> = surfaces
        .iter()
        .map(|surface| {
            surface
                .mesh
                .points()
                .iter()
                .map(|&p| DVec3::new(p.dot(camera.right), p.dot(camera.up), p.dot(camera.forward)))
                .collect()
        })
        .collect();
    let mut image = RgbImage::new(size, size, BACKGROUND);
    let mut all = views.iter().flatten();
    let Some(&first) = all.next() else {
        return image;
    };
    let (lo, hi) = all.fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let extent = (hi - lo).truncate().max_element();
    let scale = if extent > 0.0 {
        FILL * size as f64 / extent
    } else {
        1.0
    };
    let middle = 0.5 * (lo + hi);
    let half = 0.5 * size as f64;
    let to_pixel = |p: DVec3| {
        DVec2::new(
            half + (p.x - middle.x) * scale,
            half - (p.y - middle.y) * scale,
        )
    };
    let depth_range = (hi.z - lo.z).max(f64::MIN_POSITIVE);
    let light = camera.light();
    let mut depth = vec![f64::INFINITY; size as usize * size as usize];
    for (surface, view) in surfaces.iter().zip(&views) {
        let (mesh, inward) = (surface.mesh, surface.inward);
        for (t, triangle) in mesh.triangles().iter().enumerate() {
            let normal = {
                let [a, b, c] = mesh.corners(t);
                (b - a).cross(c - a).normalize_or_zero()
            };
            if normal == DVec3::ZERO {
                continue;
            }
            let facing = (normal.dot(camera.forward) < 0.0) != inward;
            // Lit from the side the viewer sees.
            let lit = if normal.dot(camera.forward) < 0.0 {
                normal
            } else {
                -normal
            };
            let base = if facing { surface.colour } else { BACK };
            let brightness = AMBIENT + (1.0 - AMBIENT) * lit.dot(light).max(0.0);
            let v = triangle.map(|i| view[i as usize]);
            raster::triangle_pixels(size, size, v.map(to_pixel), |x, y, w| {
                let z = w[0] * v[0].z + w[1] * v[1].z + w[2] * v[2].z;
                let at = y as usize * size as usize + x as usize;
                if z < depth[at] {
                    depth[at] = z;
                    let cue = 1.0 - DEPTH_CUE * ((z - lo.z) / depth_range).clamp(0.0, 1.0);
                    image.set(x, y, base.map(|c| (c * brightness * cue).round() as u8));
                }
            });
        }
    }
    image
}

/// The world axes L (+x), P (+y) and S (+z) as seen by the camera, in the lower left corner.
pub(crate) fn draw_triad(image: &mut RgbImage, camera: &Camera) {
    let scale = super::label_scale(image.width());
    let reach = 14.0 * scale as f64;
    let origin = DVec2::new(2.2 * reach, image.height() as f64 - 2.2 * reach);
    let axes: [(DVec3, &str, Rgb); 3] = [
        (DVec3::X, "L", [235, 90, 90]),
        (DVec3::Y, "P", [90, 210, 90]),
        (DVec3::Z, "S", [110, 150, 255]),
    ];
    for (axis, letter, colour) in axes {
        let on_screen = DVec2::new(axis.dot(camera.right), -axis.dot(camera.up));
        let tip = origin + reach * on_screen;
        image.line(origin, tip, 1.5, colour);
        let label = origin + (reach + 6.0 * scale as f64) * on_screen;
        let glyph = DVec2::new(5.0, 7.0) * scale as f64 * 0.5;
        image.text(
            (label.x - glyph.x).round() as i64,
            (label.y - glyph.y).round() as i64,
            letter,
            scale,
            colour,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_shapes::icosphere;
    use crate::TriMesh;

    const GOLD: [f64; 3] = [240.0, 214.0, 128.0];
    const BLUE: [f64; 3] = [140.0, 150.0, 250.0];

    /// One mesh in gold.
    fn view(mesh: &TriMesh, camera: &Camera, size: u32, inward: bool) -> RgbImage {
        let surface = Surface {
            mesh,
            colour: GOLD,
            inward,
        };
        shaded_view(&[surface], camera, size)
    }

    fn drawn(image: &RgbImage, pick: impl Fn(Rgb) -> bool) -> usize {
        (0..image.height())
            .flat_map(|y| (0..image.width()).map(move |x| (x, y)))
            .filter(|&(x, y)| pick(image.pixel(x, y).unwrap()))
            .count()
    }

    #[test]
    fn the_camera_is_orthonormal_right_handed_and_in_front_left_and_above() {
        let c = Camera::anterior_oblique();
        assert!((c.right.cross(c.up) + c.forward).length() < 1e-12);
        assert!((c.right.length() - 1.0).abs() < 1e-12 && c.right.dot(c.up).abs() < 1e-12);
        // The camera sits at −forward: anterior (−y), the patient's left (+x), superior.
        let eye = -c.forward;
        assert!(eye.y < 0.0 && eye.x > 0.0 && eye.z > 0.0, "{eye}");
        assert!((eye.z - 20f64.to_radians().sin()).abs() < 1e-12);
    }

    #[test]
    fn a_sphere_is_a_disc_of_the_fitted_size_in_front_colours() {
        let size = 200;
        let image = view(
            &icosphere(DVec3::new(5.0, -3.0, 40.0), 10.0, 4),
            &Camera::anterior_oblique(),
            size,
            false,
        );
        // The sphere's outline is fitted to FILL of the panel.
        let radius = 0.5 * FILL * size as f64;
        let disc = std::f64::consts::PI * radius * radius;
        let mesh_pixels = drawn(&image, |p| p != BACKGROUND);
        assert!(
            (mesh_pixels as f64 - disc).abs() < 0.03 * disc,
            "{mesh_pixels} pixels, a disc of radius {radius} has {disc}"
        );
        // Its middle is covered, its corners are not, and nothing red (inside) shows.
        assert_ne!(image.pixel(size / 2, size / 2), Some(BACKGROUND));
        assert_eq!(image.pixel(size - 3, 2), Some(BACKGROUND));
        assert_eq!(drawn(&image, |p| p[0] > 100 && p[1] < p[0] / 2), 0);
    }

    #[test]
    fn an_inside_out_sphere_shows_its_inside_colour_unless_told_its_normals_point_in() {
        let flipped = icosphere(DVec3::ZERO, 10.0, 3).flipped();
        let camera = Camera::anterior_oblique();
        let centre = view(&flipped, &camera, 120, false).pixel(60, 60).unwrap();
        assert!(
            centre[0] > 2 * centre[1],
            "{centre:?} is not the inside's red"
        );
        let inward = view(&flipped, &camera, 120, true);
        assert_eq!(inward, view(&flipped.flipped(), &camera, 120, false));
    }

    #[test]
    fn one_triangle_or_no_triangle_never_fails() {
        let point = TriMesh::new(vec![DVec3::ONE; 3], vec![[0, 1, 2]]).unwrap();
        let image = view(&point, &Camera::anterior_oblique(), 64, false);
        assert_eq!(image.pixel(32, 32), Some(BACKGROUND));
        let empty = TriMesh::default();
        let image = view(&empty, &Camera::anterior_oblique(), 64, false);
        assert_eq!(image.pixel(32, 32), Some(BACKGROUND));
        let none = shaded_view(&[], &Camera::anterior_oblique(), 64);
        assert_eq!(none.pixel(32, 32), Some(BACKGROUND));
    }

    #[test]
    fn the_nearer_of_two_meshes_hides_the_other_whichever_comes_first() {
        let camera = Camera::anterior_oblique();
        // A blue sphere 30 mm in front of a gold one, on one line of sight, and a small gold
        // one beside them: the view is fitted to all three.
        let far = icosphere(DVec3::ZERO, 10.0, 4);
        let near = icosphere(-30.0 * camera.forward, 6.0, 4);
        let aside = icosphere(25.0 * camera.right, 3.0, 4);
        let surface = |mesh, colour| Surface {
            mesh,
            colour,
            inward: false,
        };
        let size = 200;
        let in_order = shaded_view(
            &[
                surface(&far, GOLD),
                surface(&near, BLUE),
                surface(&aside, GOLD),
            ],
            &camera,
            size,
        );
        let reversed = shaded_view(
            &[
                surface(&aside, GOLD),
                surface(&near, BLUE),
                surface(&far, GOLD),
            ],
            &camera,
            size,
        );
        assert_eq!(in_order, reversed, "the order of the meshes shows");
        // Fitted to 38 mm across (the far sphere's left to the small one's right).
        let mm = FILL * size as f64 / 38.0;
        let disc = |r: f64| std::f64::consts::PI * (r * mm).powi(2);
        let blue = drawn(&in_order, |p| p != BACKGROUND && p[2] > p[0]) as f64;
        let gold = drawn(&in_order, |p| p != BACKGROUND && p[0] > p[2]) as f64;
        let (blue_expected, gold_expected) = (disc(6.0), disc(10.0) - disc(6.0) + disc(3.0));
        assert!(
            (blue - blue_expected).abs() < 0.05 * blue_expected,
            "{blue} blue pixels, expected {blue_expected}"
        );
        assert!(
            (gold - gold_expected).abs() < 0.05 * gold_expected,
            "{gold} gold pixels, expected {gold_expected}"
        );
    }
}
