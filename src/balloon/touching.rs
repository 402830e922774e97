//! Structures that touch (the leak the paper's introduction warns of: "avoiding leakages in
//! neighbouring contrasted structures"). Where two structures lie side by side, the
//! partial-volume voxels along their contact are as bright as either, so the balloon passes the
//! contact and fills the second structure too; no local force can tell that contact from the
//! opening of a branch.
//!
//! After the balloon stops, its inside is split into the basins of its thick parts: the
//! components of the inside eroded by a ball (the cores), each grown back over the inside along
//! shortest paths — a geodesic Voronoi partition, i.e. the watershed of the distance map with
//! the cores as markers, the classic way to split touching objects. Two basins that meet along
//! an elongated contact are two structures side by side; two that meet across a round one are
//! one structure narrowing (a stenosis, the root of a branch, a thin vessel between thick ones).
//! The basins joined to a seed's basin through round contacts are kept, the rest is cut off.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};

use glam::{DMat3, DVec3};

use super::fast_hash::FastHash;
use super::reparametrize::{covering_grid, isosurface, keep_seeded_components, without_cavities};
use crate::error::Result;
use crate::geometry::Geometry;
use crate::mesh::TriMesh;
use crate::morphology::{self, Grid};
use crate::signed_distance::{signed_distance_values, SignedDistanceOptions};
use crate::winding_number::inside_mask;

/// A contact between two basins is elongated — two structures side by side — when its length
/// is more than this many times its width (square root of the ratio of the two largest
/// variances of its face centres). A round cross-section has about 1; the 36 mm contact of two
/// touching tubes 3.6 mm wide about 10.
const ELONGATED: f64 = 3.0;
/// Contacts of fewer voxel faces than this are too small to have a shape: kept.
const MIN_CONTACT_FACES: usize = 12;

/// The closed balloon `mesh` without the structures it entered through an elongated contact
/// with the seeds' structure (see the module's comment), on the grid of `geometry`, with cores
/// eroded by a ball of `radius` mm. `None` when nothing is cut.
pub(crate) fn cut_touching(
    mesh: &TriMesh,
    geometry: &Geometry,
    seeds: &[DVec3],
    radius: f64,
) -> Result<Option<TriMesh>> {
    let spacing = geometry.spacing();
    let (grid, dims) = covering_grid(mesh, geometry, 2.0)?;
    let inside = inside_mask(mesh, dims, &grid)?;
    let (cores, count) =
        morphology::components(&morphology::erode(&inside, dims, spacing, radius), dims);
    if count < 2 {
        return Ok(None);
    }
    let basins = basins(&inside, &cores, dims, spacing);
    let seed_basins: Vec<u32> = seeds
        .iter()
        .filter_map(|&s| voxel_of(grid.world_to_index(s), dims))
        .map(|n| basins[n])
        .filter(|&b| b != u32::MAX)
        .collect();
    if seed_basins.is_empty() {
        // The seeds lie in parts too thin for a core of their own: nothing to compare with.
        return Ok(None);
    }
    let kept = joined_through_round_contacts(&basins, count, &seed_basins, dims, &grid);
    let cut: Vec<usize> = (0..basins.len())
        .filter(|&n| basins[n] != u32::MAX && !kept[basins[n] as usize])
        .collect();
    if cut.is_empty() {
        return Ok(None);
    }
    // The cut voxels become as far outside as the band reaches, so that the new surface
    // crosses half-way between them and the kept voxels, on the boundary of the basins.
    let options = SignedDistanceOptions { band_voxels: 1.0 };
    let mut field = signed_distance_values(mesh, mesh, dims, &grid, &options)?;
    let outside = options.band_mm(&grid);
    for n in cut {
        field[n] = outside;
    }
    keep_seeded_components(&mut field, dims, &grid, seeds);
    let voxel: f64 = spacing.iter().product();
    Ok(Some(without_cavities(
        isosurface(field, dims, &grid, 0.0)?,
        voxel,
    )))
}

/// The voxel nearest the continuous index `p`, if it is on the grid.
fn voxel_of(p: DVec3, dims: [usize; 3]) -> Option<usize> {
    let r = p.round();
    let on_grid = (0..3).all(|a| r[a] >= 0.0 && r[a] < dims[a] as f64);
    on_grid.then(|| r.x as usize + dims[0] * (r.y as usize + dims[1] * r.z as usize))
}

/// For each voxel of `inside`, the label of the core nearest to it along paths inside (steps
/// between 6-neighbours, as long as the spacing along their axis); `u32::MAX` outside and where
/// no core is reached. Ties go to the smaller label, so the partition is deterministic.
fn basins(inside: &[bool], cores: &[u32], dims: [usize; 3], spacing: [f64; 3]) -> Vec<u32> {
    let grid = Grid(dims);
    let mut label = cores.to_vec();
    let mut distance = vec![f64::INFINITY; inside.len()];
    let mut queue = BinaryHeap::new();
    for (n, &c) in cores.iter().enumerate() {
        if c != u32::MAX {
            distance[n] = 0.0;
            queue.push(Reverse((0u64, c, n)));
        }
    }
    let step = |a: usize, b: usize| {
        let axis = match a.abs_diff(b) {
            1 => 0,
            d if d == dims[0] => 1,
            _ => 2,
        };
        spacing[axis]
    };
    while let Some(Reverse((bits, c, n))) = queue.pop() {
        if f64::from_bits(bits) > distance[n] || label[n] != c {
            continue;
        }
        for m in grid.neighbours(n) {
            let d = distance[n] + step(n, m);
            if inside[m] && (d < distance[m] || (d == distance[m] && c < label[m])) {
                distance[m] = d;
                label[m] = c;
                queue.push(Reverse((d.to_bits(), c, m)));
            }
        }
    }
    label
}

/// Which basins are joined to one of `seeds` through contacts that are not elongated.
fn joined_through_round_contacts(
    basins: &[u32],
    count: u32,
    seeds: &[u32],
    dims: [usize; 3],
    grid: &Geometry,
) -> Vec<bool> {
    // The centres of the voxel faces between each pair of basins, as moments.
    let mut contacts: HashMap<(u32, u32), Moments, FastHash> = HashMap::default();
    let voxels = Grid(dims);
    for (n, &a) in basins.iter().enumerate() {
        if a == u32::MAX {
            continue;
        }
        for m in voxels.neighbours(n).filter(|&m| m > n) {
            let b = basins[m];
            if b != u32::MAX && b != a {
                let index = |v: usize| {
                    let (i, j, k) = voxels.coordinates(v);
                    DVec3::new(i as f64, j as f64, k as f64)
                };
                let centre = 0.5 * (index(n) + index(m));
                contacts
                    .entry((a.min(b), a.max(b)))
                    .or_default()
                    .add(grid.index_to_world(centre));
            }
        }
    }
    let mut joined = vec![Vec::new(); count as usize];
    let mut pairs: Vec<_> = contacts.into_iter().collect();
    pairs.sort_unstable_by_key(|(pair, _)| *pair);
    for ((a, b), moments) in pairs {
        if moments.count < MIN_CONTACT_FACES || moments.elongation() <= ELONGATED {
            joined[a as usize].push(b);
            joined[b as usize].push(a);
        }
    }
    let mut kept = vec![false; count as usize];
    let mut stack: Vec<u32> = seeds.to_vec();
    while let Some(b) = stack.pop() {
        if !std::mem::replace(&mut kept[b as usize], true) {
            stack.extend(&joined[b as usize]);
        }
    }
    kept
}

/// Count, sum and sum of outer products of points: their covariance.
#[derive(Default)]
struct Moments {
    count: usize,
    sum: DVec3,
    outer: DMat3,
}

impl Moments {
    fn add(&mut self, p: DVec3) {
        self.count += 1;
        self.sum += p;
        self.outer += DMat3::from_cols(p * p.x, p * p.y, p * p.z);
    }

    /// Length over width of the points' spread: the square root of the ratio of the largest
    /// to the second largest variance.
    fn elongation(&self) -> f64 {
        let n = self.count as f64;
        let mean = self.sum / n;
        let covariance =
            self.outer * (1.0 / n) - DMat3::from_cols(mean * mean.x, mean * mean.y, mean * mean.z);
        let [largest, second, _] = symmetric_eigenvalues(covariance);
        (largest / second.max(f64::MIN_POSITIVE)).sqrt()
    }
}

/// The eigenvalues of a symmetric 3×3 matrix, largest first (the trigonometric solution of the
/// characteristic cubic, Smith 1961).
fn symmetric_eigenvalues(m: DMat3) -> [f64; 3] {
    let off = m.x_axis.y.powi(2) + m.x_axis.z.powi(2) + m.y_axis.z.powi(2);
    let diagonal = [m.x_axis.x, m.y_axis.y, m.z_axis.z];
    if off == 0.0 {
        let mut e = diagonal;
        e.sort_by(|a, b| b.total_cmp(a));
        return e;
    }
    let q = diagonal.iter().sum::<f64>() / 3.0;
    let p2 = diagonal.iter().map(|d| (d - q).powi(2)).sum::<f64>() + 2.0 * off;
    let p = (p2 / 6.0).sqrt();
    let b = (m - DMat3::from_diagonal(DVec3::splat(q))) * (1.0 / p);
    let phi = (b.determinant() / 2.0).clamp(-1.0, 1.0).acos() / 3.0;
    let largest = q + 2.0 * p * phi.cos();
    let smallest = q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos();
    [largest, 3.0 * q - largest - smallest, smallest]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_shapes::icosphere;

    #[test]
    fn eigenvalues_of_a_rotated_diagonal_matrix() {
        let r = DMat3::from_rotation_y(0.3) * DMat3::from_rotation_x(1.1);
        let m = r * DMat3::from_diagonal(DVec3::new(2.0, 9.0, 0.5)) * r.transpose();
        let e = symmetric_eigenvalues(m);
        for (found, expected) in e.iter().zip([9.0, 2.0, 0.5]) {
            assert!((found - expected).abs() < 1e-9, "{e:?}");
        }
    }

    #[test]
    fn a_strip_is_elongated_and_a_disk_is_not() {
        let mut strip = Moments::default();
        let mut disk = Moments::default();
        for i in 0..40 {
            for j in 0..4 {
                strip.add(DVec3::new(i as f64, j as f64, 0.1 * j as f64));
            }
        }
        for i in -6i32..=6 {
            for j in -6i32..=6 {
                if i * i + j * j <= 36 {
                    disk.add(DVec3::new(i as f64, 0.0, j as f64));
                }
            }
        }
        assert!(strip.elongation() > 8.0, "{}", strip.elongation());
        assert!(disk.elongation() < 1.1, "{}", disk.elongation());
    }

    /// Two capsules side by side along z, radius 4, whose walls touch along x = 0; or one
    /// capsule with a narrowing in its middle.
    fn capsules(touching: bool) -> TriMesh {
        let sdf = |p: DVec3| {
            let tube = |p: DVec3, x: f64| {
                let z = p.z.clamp(-14.0, 14.0);
                (p - DVec3::new(x, 0.0, z)).length() - 4.0
            };
            if touching {
                tube(p, -4.0).min(tube(p, 4.0))
            } else {
                // A waist of radius 2 at z = 0.
                let q = DVec3::new(p.x, p.y, p.z);
                let r = 4.0 - 2.0 * (-q.z * q.z / 8.0).exp();
                (DVec3::new(q.x, q.y, 0.0)).length() - r + (q.z.abs() - 18.0).max(0.0)
            }
        };
        let g = Geometry::with_spacing([0.8, 0.8, 1.5], [-14.0, -10.0, -24.0]).unwrap();
        let dims = [36, 26, 33];
        let mut values = Vec::new();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    values.push(sdf(
                        g.index_to_world(DVec3::new(i as f64, j as f64, k as f64))
                    ));
                }
            }
        }
        let image = crate::Image::new(crate::VoxelBuffer::F64(values), dims, g).unwrap();
        crate::marching_cubes::marching_cubes(&image.view(), 0.0).unwrap()
    }

    #[test]
    fn the_second_of_two_touching_tubes_is_cut_off_and_a_narrowing_is_kept() {
        let g = Geometry::with_spacing([0.8, 0.8, 1.5], [0.0; 3]).unwrap();
        let tubes = capsules(true);
        let seed = DVec3::new(-4.0, 0.0, 0.0);
        let cut = cut_touching(&tubes, &g, &[seed], 2.6)
            .unwrap()
            .expect("a cut");
        let report = crate::mesh_checks::check(&cut);
        assert!(report.is_valid_closed_surface(), "{report:?}");
        assert_eq!(report.components, 1);
        // One tube of radius 4 and length 28 with its caps: 1676 mm³; the two: 3351 mm³.
        let one = std::f64::consts::PI * 16.0 * 28.0 + 4.0 / 3.0 * std::f64::consts::PI * 64.0;
        assert!(
            (report.signed_volume - one).abs() < 0.08 * one,
            "{} vs {one}",
            report.signed_volume
        );
        assert!(
            cut.points().iter().all(|p| p.x < 1.0),
            "nothing of the second tube"
        );

        let narrowing = capsules(false);
        assert!(
            cut_touching(&narrowing, &g, &[DVec3::new(0.0, 0.0, -10.0)], 2.6)
                .unwrap()
                .is_none()
        );
        let sphere = icosphere(DVec3::ZERO, 6.0, 4);
        assert!(cut_touching(&sphere, &g, &[DVec3::ZERO], 2.6)
            .unwrap()
            .is_none());
    }

    #[test]
    fn a_seed_outside_every_basin_cuts_nothing() {
        let g = Geometry::with_spacing([0.8, 0.8, 1.5], [0.0; 3]).unwrap();
        let tubes = capsules(true);
        let far = DVec3::new(0.0, 30.0, 0.0);
        assert!(cut_touching(&tubes, &g, &[far], 2.6).unwrap().is_none());
    }
}
