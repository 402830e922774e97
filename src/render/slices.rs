//! The three world-axis planes through a point, as radiology viewers show them, and their
//! resampling from a volume by trilinear interpolation at every pixel centre.
//!
//! Planes are laid in world (LPS) millimetres, never along the volume's index axes, so that
//! an oblique or anisotropic grid comes out with true proportions and the usual orientation:
//! the patient's right on the viewer's left (+x, the patient's left, to the right) on the axial
//! and coronal planes, anterior (−y) at the top of the axial plane, superior (+z) at the top of
//! the coronal and sagittal planes, and the face on the left of the sagittal plane.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::Volume;

/// Which world-axis plane a panel shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Orientation {
    /// The x–y plane (constant z).
    Axial,
    /// The x–z plane (constant y).
    Coronal,
    /// The y–z plane (constant x).
    Sagittal,
}

impl Orientation {
    pub const ALL: [Orientation; 3] = [
        Orientation::Axial,
        Orientation::Coronal,
        Orientation::Sagittal,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Orientation::Axial => "axial",
            Orientation::Coronal => "coronal",
            Orientation::Sagittal => "sagittal",
        }
    }

    /// The world axis the plane is perpendicular to (0 = x, 1 = y, 2 = z).
    pub fn normal_axis(self) -> usize {
        match self {
            Orientation::Axial => 2,
            Orientation::Coronal => 1,
            Orientation::Sagittal => 0,
        }
    }

    /// The world directions of the picture's right and up.
    pub fn right_up(self) -> (DVec3, DVec3) {
        match self {
            Orientation::Axial => (DVec3::X, -DVec3::Y),
            Orientation::Coronal => (DVec3::X, DVec3::Z),
            Orientation::Sagittal => (DVec3::Y, DVec3::Z),
        }
    }
}

/// A square picture of `size` × `size` pixels of `pixel_mm` on a plane through `centre`, the
/// centre in the middle of the picture.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SlicePlane {
    pub orientation: Orientation,
    pub centre: DVec3,
    pub pixel_mm: f64,
    pub size: u32,
}

impl SlicePlane {
    fn half(&self) -> f64 {
        0.5 * self.size as f64
    }

    /// The world point at continuous pixel coordinates (x right, y down).
    pub fn world(&self, pixel: DVec2) -> DVec3 {
        let (right, up) = self.orientation.right_up();
        self.centre + (pixel.x - self.half()) * self.pixel_mm * right
            - (pixel.y - self.half()) * self.pixel_mm * up
    }

    /// The continuous pixel coordinates of a world point projected onto the plane.
    pub fn pixel(&self, world: DVec3) -> DVec2 {
        let (right, up) = self.orientation.right_up();
        let d = world - self.centre;
        DVec2::new(
            self.half() + d.dot(right) / self.pixel_mm,
            self.half() - d.dot(up) / self.pixel_mm,
        )
    }

    /// The plane as `normal · p = offset`.
    pub fn normal_offset(&self) -> (DVec3, f64) {
        let axis = self.orientation.normal_axis();
        let mut normal = DVec3::ZERO;
        normal[axis] = 1.0;
        (normal, self.centre[axis])
    }
}

/// The volume at every pixel centre of `plane`, rows top to bottom: `None` outside the volume,
/// NaN where a voxel is unknown.
pub(crate) fn resample(volume: &Volume<'_>, plane: &SlicePlane) -> Vec<Option<f64>> {
    let size = plane.size as usize;
    let mut samples = vec![None; size * size];
    samples
        .par_chunks_mut(size)
        .enumerate()
        .for_each(|(y, row)| {
            for (x, sample) in row.iter_mut().enumerate() {
                let centre = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
                *sample = volume.sample_world(plane.world(centre));
            }
        });
    samples
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::phantom::oblique_direction;
    use crate::{Geometry, TypedVolume};

    fn volume_of(dims: [usize; 3], geometry: Geometry, f: impl Fn(DVec3) -> f64) -> Vec<f64> {
        let mut voxels = Vec::with_capacity(dims.iter().product());
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let index = DVec3::new(i as f64, j as f64, k as f64);
                    voxels.push(f(geometry.index_to_world(index)));
                }
            }
        }
        voxels
    }

    fn at(samples: &[Option<f64>], plane: &SlicePlane, x: u32, y: u32) -> Option<f64> {
        samples[(y * plane.size + x) as usize]
    }

    #[test]
    fn a_bright_voxel_lands_on_its_pixel_with_the_radiological_orientation() {
        let dims = [20, 20, 20];
        let geometry = Geometry::identity();
        let bright = DVec3::new(13.0, 6.0, 9.0);
        let voxels = volume_of(dims, geometry, |w| if w == bright { 1000.0 } else { 0.0 });
        let volume = Volume::from(TypedVolume::contiguous(&voxels, dims, geometry).unwrap());
        // An odd size puts pixel centres on voxel centres: pixel (10, 10) is the centre.
        let centre = DVec3::new(10.0, 10.0, 9.0);
        let axial = SlicePlane {
            orientation: Orientation::Axial,
            centre,
            pixel_mm: 1.0,
            size: 21,
        };
        let samples = resample(&volume, &axial);
        // x = 13 is three pixels right of the centre; y = 6 is anterior of it, so above.
        assert_eq!(at(&samples, &axial, 13, 6), Some(1000.0));
        assert_eq!(at(&samples, &axial, 13, 14), Some(0.0));
        assert_eq!(axial.pixel(bright), DVec2::new(13.5, 6.5));
        // Beyond the last voxel (x > 19) is outside.
        assert_eq!(at(&samples, &axial, 20, 10), None);
        let sagittal = SlicePlane {
            orientation: Orientation::Sagittal,
            centre: DVec3::new(13.0, 10.0, 10.0),
            ..axial
        };
        let samples = resample(&volume, &sagittal);
        // Anterior (y = 6) to the left, superior (z = 9 < 10) is below the centre.
        assert_eq!(at(&samples, &sagittal, 6, 11), Some(1000.0));
    }

    #[test]
    fn oblique_anisotropic_grids_resample_in_true_world_millimetres() {
        let dims = [40, 36, 16];
        let geometry =
            Geometry::new([0.7, 0.9, 2.5], [-5.0, 3.0, 8.0], oblique_direction()).unwrap();
        // Trilinear interpolation reproduces a field linear in world space exactly.
        let gradient = DVec3::new(1.0, -2.0, 3.0);
        let voxels = volume_of(dims, geometry, |w| gradient.dot(w));
        let volume = Volume::from(TypedVolume::contiguous(&voxels, dims, geometry).unwrap());
        let centre = geometry.index_to_world(DVec3::new(20.0, 18.0, 8.0));
        for orientation in Orientation::ALL {
            let plane = SlicePlane {
                orientation,
                centre,
                pixel_mm: 0.5,
                size: 41,
            };
            let samples = resample(&volume, &plane);
            let value = |x, y| at(&samples, &plane, x, y).unwrap();
            let (right, up) = orientation.right_up();
            let middle = value(20, 20);
            assert!((middle - gradient.dot(centre)).abs() < 1e-9);
            // Four pixels right and up are 2 mm along the picture's axes.
            assert!((value(24, 20) - middle - 2.0 * gradient.dot(right)).abs() < 1e-9);
            assert!((value(20, 16) - middle - 2.0 * gradient.dot(up)).abs() < 1e-9);
            let p = plane.world(DVec2::new(3.25, 7.5));
            assert!((plane.pixel(p) - DVec2::new(3.25, 7.5)).length() < 1e-12);
        }
    }

    #[test]
    fn a_bright_voxel_of_an_oblique_grid_is_at_the_centre_of_planes_through_it() {
        let dims = [24, 20, 12];
        let geometry =
            Geometry::new([0.7, 0.7, 2.5], [1.0, -2.0, 0.5], oblique_direction()).unwrap();
        let index = DVec3::new(10.0, 12.0, 6.0);
        let bright = geometry.index_to_world(index);
        let voxels = volume_of(dims, geometry, |w| {
            if (w - bright).length() < 1e-9 {
                1000.0
            } else {
                0.0
            }
        });
        let volume = Volume::from(TypedVolume::contiguous(&voxels, dims, geometry).unwrap());
        for orientation in Orientation::ALL {
            let plane = SlicePlane {
                orientation,
                centre: bright,
                pixel_mm: 0.35,
                size: 31,
            };
            let samples = resample(&volume, &plane);
            let brightest = (0..samples.len())
                .max_by(|&a, &b| {
                    samples[a]
                        .unwrap_or(0.0)
                        .total_cmp(&samples[b].unwrap_or(0.0))
                })
                .unwrap();
            assert_eq!(brightest, 15 * 31 + 15, "{orientation:?}");
            assert!((samples[brightest].unwrap() - 1000.0).abs() < 1e-6);
        }
    }
}
