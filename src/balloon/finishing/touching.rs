//! Structures that touch (the leak the paper's introduction warns of: "avoiding leakages in
//! neighbouring contrasted structures"). Where two structures lie side by side, the
//! partial-volume voxels along their contact are as bright as either, so the balloon passes the
//! contact and fills the second structure too; no local force can tell that contact from the
//! opening of a branch.
//!
//! The balloon's inside is split into the basins of its thick parts by the watershed of its
//! distance map (the distance of each inside voxel to the outside), the classic way to split
//! touching objects: flooded from its deepest voxels down, a basin grows from each maximum,
//! and where two meet at a saddle they stay apart if the saddle is markedly shallower than the
//! thinner of the two (a waist below [`SPLIT`] of its depth); otherwise they are one part
//! whose surface merely wobbles. Lobes thinner than a few target edge lengths are not parts of
//! their own (the paper ties the triangle size to the smallest structure). Two basins that
//! meet along an elongated contact, or that both meet their contact on their walls (two tubes
//! crossing: each runs on past it both ways), are two structures side by side; a basin entered through a
//! contact much narrower than itself is a structure reached through a neck (a kidney through
//! its artery, the liver through a portal branch); two that meet across a round contact about
//! as wide as the thinner of them are one structure narrowing or branching (a stenosis, the
//! root of a branch). The basins joined to a seed's basin through such contacts are kept, the
//! rest is cut off.

use std::collections::{HashMap, HashSet};

use glam::{DMat3, DVec3};

use crate::allocation;
use crate::balloon::fast_hash::FastHash;
use crate::balloon::reparametrization::isosurface::{
    covering_grid, isosurface, keep_inside_free_space, keep_seeded_components, without_cavities,
    FreeDepth,
};
use crate::disjoint_sets::DisjointSets;
use crate::distance_transform;
use crate::error::Result;
use crate::geometry::Geometry;
use crate::kernels::mask_voxels::MaskVoxels;
use crate::mesh::TriMesh;
use crate::morphology::{self, Grid};
use crate::signed_distance::{signed_distance_values, SignedDistanceOptions};
use crate::winding_number::inside_mask;

/// A contact between two basins is elongated — two structures side by side — when its length
/// is more than this many times its width (square root of the ratio of the two largest
/// variances of its face centres), measured on its largest connected patch (`largest_patch`).
/// A round cross-section has about 1; the 36 mm contact of two touching tubes 3.6 mm wide
/// about 10.
const ELONGATED: f64 = 3.0;
/// Contacts of fewer voxel faces than this are too small to have a shape (only their area
/// counts).
const MIN_CONTACT_FACES: usize = 12;
/// Two basins meeting at a saddle shallower than this share of the thinner one's thickness
/// stay apart: a waist. Two touching tubes meet at a waist however much the balloon fills
/// the crevice between them; one tube's surface wobbles by far less.
const SPLIT: f64 = 0.85;
/// A basin more than this many times as thick as the radius of its contact with the kept
/// ones was entered through a neck (see `joined_through_round_contacts`). A branch leaving at
/// 30° or more meets its root across an ellipse whose disc of equal area is at most 1.4 times
/// its radius; the portal-venous CT's IVC and left renal vein (7.6 and 4.9 mm thick) met the
/// aorta through pinholes of 3.7 and 2.0 mm, at 2.05 and 2.45. The price: a vessel past a
/// stenosis that narrows it to less than half its radius is cut off too, unless it is seeded.
const NECK_RATIO: f64 = 2.0;
/// How far around a contact (in each basin's own thicknesses, or in the thicker one's) its two
/// basins' shapes are looked at to tell two tubes side by side (each touched on its wall) from a
/// branch or a narrowing. The contact's centre may lie deep inside the thicker basin, more than
/// the thinner one's radius off its axis: then three of its own thicknesses take in only a short
/// piece of the thinner tube (a 3.2 mm tube crossing a 7.1 mm one at 34° spread along it only
/// 1.9 times as far as across), three of the thicker one's take in enough of it.
const SIDE_REACH: f64 = 3.0;
/// A basin meets a contact on its side when it spreads along it at least this many times as
/// far as across it (standard deviations): a tube touched on its wall, seen within three of its
/// radii of the contact, about 3; a branch leaving the contact, under 1.
const SIDE_ELONGATION: f64 = 2.0;

/// The depth (voxels) of each level over which the cores grow (`grow_cores`): on the grid, the
/// depths along a tube's ridge vary by up to a voxel with where its axis crosses the voxels, so
/// a saddle less than two voxels below a ridge is no saddle to tell apart. One voxel left the
/// seeded tube of touching-pair variant 7 (1.9 mm slices) 0.002 of Dice short of its 0.95.
const LEVEL_VOXELS: f64 = 2.0;

/// The radius (voxels) of the closing that fills the seam between the voxels earlier cuts took
/// and the balloon stopped against them (see [`cut_touching`]).
const SEAM_VOXELS: f64 = 2.0;

/// What [`cut_touching`] cut off.
pub(crate) struct Cut {
    /// The balloon without it.
    pub mesh: TriMesh,
    /// The voxels (indices of the volume's grid, possibly beyond its faces) it took.
    pub removed: Vec<[i64; 3]>,
}

/// The closed balloon `mesh` without the structures it entered through an elongated contact
/// or a neck from the seeds' structure (see the module's comment), on the grid of
/// `geometry`, with basins at least `radius` mm thick to be parts of their own. `None` when
/// nothing is cut.
///
/// A structure cut off while the balloon was half-way along its contact is entered again
/// further along, and what is then entered is only the rest of it: a stub that meets the
/// seeds' structure across a short, round contact, as a branch does. So the basins are also
/// found with the voxels `earlier` cuts took (indices of `geometry`'s grid) as part of the
/// balloon, the seam between them closed: a basin without a seed that lies mostly in one of
/// these that holds some of them and that the rules above cut off is that structure again, and
/// is cut off too — unless all that is cut is a sliver smaller than a ball of `radius`.
pub(crate) fn cut_touching(
    mesh: &TriMesh,
    geometry: &Geometry,
    seeds: &[DVec3],
    radius: f64,
    earlier: &HashSet<[i64; 3], FastHash>,
    free_depth: Option<&FreeDepth<'_>>,
) -> Result<Option<Cut>> {
    // An isotropic grid of the smallest spacing: on a grid of 1.5 mm slices the depths would
    // be off by up to 0.75 mm, as much as the waist between two touching tubes.
    let voxel = geometry.min_spacing();
    let isotropic = Geometry::new([voxel; 3], geometry.origin(), geometry.direction())?;
    let (grid, dims) = covering_grid(mesh, &isotropic, 2.0)?;
    let spacing = grid.spacing();
    let inside = inside_mask(mesh, dims, &grid)?;
    let seed_voxels: Vec<usize> = seeds
        .iter()
        .filter_map(|&s| voxel_of(grid.world_to_index(s), dims))
        .collect();
    let (basins, thickness) = find_basins(&inside, dims, spacing, radius)?;
    // Whether each voxel of the inside is cut, in the order of `basins`' voxels.
    let mut cut = allocation::filled(basins.len(), false, "the touching cut's mask")?;
    let seed_basins = basins_of(&basins, &seed_voxels);
    // With one basin, or the seeds in parts too thin for a core of their own, there is nothing
    // to compare.
    if thickness.len() >= 2 && !seed_basins.is_empty() {
        let kept = joined_through_round_contacts(&basins, &thickness, &seed_basins, dims, &grid);
        for (c, (_, b)) in cut.iter_mut().zip(basins.iter()) {
            *c = b != u32::MAX && !kept[b as usize];
        }
    }
    let voxel_volume: f64 = spacing.iter().product();
    let volume = |cut: &[bool]| cut.iter().filter(|&&c| c).count() as f64 * voxel_volume;
    if !earlier.is_empty() {
        let (whole, again) = structures_cut_before(
            &inside,
            earlier,
            &seed_voxels,
            radius,
            dims,
            &grid,
            geometry,
        )?;
        // Each basin of the balloon's own without a seed goes with the structure seen whole
        // that most of it lies in.
        let mut share = vec![(0usize, 0usize); thickness.len()];
        for (n, b) in basins.iter().filter(|&(_, b)| b != u32::MAX) {
            let w = whole.at(n);
            share[b as usize].0 += usize::from(w != u32::MAX && again[w as usize]);
            share[b as usize].1 += 1;
        }
        let mut with_them = cut.clone();
        for (c, (_, b)) in with_them
            .iter_mut()
            .zip(basins.iter())
            .filter(|(_, (_, b))| *b != u32::MAX)
        {
            let (in_cut, all) = share[b as usize];
            *c |= !seed_basins.contains(&b) && 2 * in_cut > all;
        }
        let ball = 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3);
        if volume(&cut) > 0.0 || volume(&with_them) >= ball {
            cut = with_them;
        }
    }
    let cut: Vec<usize> = (0..cut.len())
        .filter(|&c| cut[c])
        .map(|c| basins.voxel(c))
        .collect();
    if cut.is_empty() {
        return Ok(None);
    }
    // The field below is a value per voxel of the box: the masks go first.
    drop((inside, basins));
    // The cut voxels become as far outside as the band reaches, so that the new surface
    // crosses half-way between them and the kept voxels, on the boundary of the basins.
    let options = SignedDistanceOptions { band_voxels: 1.0 };
    let mut field = signed_distance_values(mesh, mesh, dims, &grid, &options)?;
    let outside = options.band_mm(&grid);
    let voxels = Grid(dims);
    let mut removed: Vec<[i64; 3]> = cut
        .iter()
        .map(|&n| {
            let (i, j, k) = voxels.coordinates(n);
            let p = DVec3::new(i as f64, j as f64, k as f64);
            let v = geometry.world_to_index(grid.index_to_world(p)).round();
            [v.x as i64, v.y as i64, v.z as i64]
        })
        .collect();
    removed.sort_unstable();
    removed.dedup();
    for n in cut {
        field[n] = outside;
    }
    if let Some(free_depth) = free_depth {
        keep_inside_free_space(&mut field, dims, &grid, free_depth);
    }
    keep_seeded_components(&mut field, dims, &grid, seeds)?;
    Ok(Some(Cut {
        mesh: without_cavities(isosurface(field, dims, &grid, 0.0)?, voxel_volume),
        removed,
    }))
}

/// The basins of `mask`'s thick parts (see the module's comment): a label per voxel
/// (`u32::MAX` outside and in parts too thin for a core) and each basin's thickness, with basins
/// at least `radius` mm thick to be parts of their own.
pub(in crate::balloon) fn find_basins(
    mask: &[bool],
    dims: [usize; 3],
    spacing: [f64; 3],
    radius: f64,
) -> Result<(BasinMap, Vec<f64>)> {
    let voxels = MaskVoxels::new(mask, dims)?;
    let depth = distance_transform::depth_in_mask(&voxels, spacing)?;
    let (mut cores, thickness) = watershed(&voxels, &depth, radius, spacing[0])?;
    // Each basin's core, the part deeper than its waists could be, grown back over the inside
    // (`grow_cores`).
    for (l, &d) in cores.iter_mut().zip(&depth) {
        if *l != u32::MAX && d < SPLIT * thickness[*l as usize] {
            *l = u32::MAX;
        }
    }
    let labels = grow_cores(&voxels, &depth, cores, LEVEL_VOXELS * spacing[0])?;
    Ok((BasinMap { voxels, labels }, thickness))
}

/// The basin of each voxel of a mask, kept at the mask's voxels only: the mask is a vessel tree
/// in the box around it, a few per cent of the box.
pub(in crate::balloon) struct BasinMap {
    voxels: MaskVoxels,
    labels: Vec<u32>,
}

impl BasinMap {
    /// The basin of the grid's voxel `n`: `u32::MAX` outside the mask and in parts too thin for
    /// a core.
    pub fn at(&self, n: usize) -> u32 {
        self.voxels.position(n).map_or(u32::MAX, |c| self.labels[c])
    }

    /// The mask's voxels, ascending, each with its basin.
    pub fn iter(&self) -> impl Iterator<Item = (usize, u32)> + '_ {
        (0..self.labels.len()).map(|c| (self.voxels.voxel(c), self.labels[c]))
    }

    /// The number of the mask's voxels.
    pub fn len(&self) -> usize {
        self.labels.len()
    }

    /// The grid index of the mask's `c`-th voxel.
    pub fn voxel(&self, c: usize) -> usize {
        self.voxels.voxel(c)
    }
}

/// The basins of the balloon's inside `inside` with the voxels `earlier` cuts took (indices of
/// `geometry`'s grid) as part of it, their seam closed (see [`cut_touching`]), and for each
/// whether it holds some of those voxels and is cut off by the module's rules from the basins
/// of `seed_voxels`: the structures cut off before, seen whole.
fn structures_cut_before(
    inside: &[bool],
    earlier: &HashSet<[i64; 3], FastHash>,
    seed_voxels: &[usize],
    radius: f64,
    dims: [usize; 3],
    grid: &Geometry,
    geometry: &Geometry,
) -> Result<(BasinMap, Vec<bool>)> {
    let spacing = grid.spacing();
    let mut taken = allocation::filled(inside.len(), false, "the earlier cuts' mask")?;
    mark_voxels(&mut taken, dims, grid, geometry, earlier);
    // The balloon's front stopped at the cut rounded, and the groove it leaves along the seam
    // would read as a waist between the cut part and the part entered again.
    let mut seen = allocation::collect(
        inside.iter().zip(&taken).map(|(&a, &b)| a || b),
        "the balloon's inside with the earlier cuts",
    )?;
    morphology::close(&mut seen, dims, spacing, SEAM_VOXELS * spacing[0])?;
    let (whole, thickness) = find_basins(&seen, dims, spacing, radius)?;
    let seeded = basins_of(&whole, seed_voxels);
    let kept = joined_through_round_contacts(&whole, &thickness, &seeded, dims, grid);
    let mut again = vec![false; thickness.len()];
    for (_, w) in whole.iter().filter(|&(n, w)| taken[n] && w != u32::MAX) {
        again[w as usize] = !kept[w as usize];
    }
    Ok((whole, again))
}

/// The basins of `voxels`, those in one.
pub(in crate::balloon) fn basins_of(basins: &BasinMap, voxels: &[usize]) -> Vec<u32> {
    voxels
        .iter()
        .map(|&n| basins.at(n))
        .filter(|&b| b != u32::MAX)
        .collect()
}

/// Marks in `mask` (on `grid`, `dims`) the voxels whose nearest voxel of `geometry`'s grid is
/// one of `voxels`; those beyond `grid` are left out.
fn mark_voxels(
    mask: &mut [bool],
    dims: [usize; 3],
    grid: &Geometry,
    geometry: &Geometry,
    voxels: &HashSet<[i64; 3], FastHash>,
) {
    for &v in voxels {
        let centre = DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
        // The grid's voxels within the box of `v`'s corners.
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for corner in 0..8 {
            let offset = DVec3::new(
                (corner & 1) as f64 - 0.5,
                ((corner >> 1) & 1) as f64 - 0.5,
                ((corner >> 2) & 1) as f64 - 0.5,
            );
            let p = grid.world_to_index(geometry.index_to_world(centre + offset));
            lo = lo.min(p);
            hi = hi.max(p);
        }
        if (0..3).any(|a| hi[a] < 0.0 || lo[a] > dims[a] as f64 - 1.0) {
            continue;
        }
        let range = |a: usize| {
            lo[a].floor().max(0.0) as usize..=hi[a].ceil().min(dims[a] as f64 - 1.0) as usize
        };
        for k in range(2) {
            for j in range(1) {
                for i in range(0) {
                    let p = DVec3::new(i as f64, j as f64, k as f64);
                    let nearest = geometry.world_to_index(grid.index_to_world(p)).round();
                    if [nearest.x as i64, nearest.y as i64, nearest.z as i64] == v {
                        mask[i + dims[0] * (j + dims[1] * k)] = true;
                    }
                }
            }
        }
    }
}

/// The voxel nearest the continuous index `p`, if it is on the grid.
pub(in crate::balloon) fn voxel_of(p: DVec3, dims: [usize; 3]) -> Option<usize> {
    let r = p.round();
    let on_grid = (0..3).all(|a| r[a] >= 0.0 && r[a] < dims[a] as f64);
    on_grid.then(|| r.x as usize + dims[0] * (r.y as usize + dims[1] * r.z as usize))
}

/// For each voxel of `inside` (`depth` and `cores` in its order), the label of the core that
/// reaches it first when the cores grow over the inside level by level down the distance map
/// `depth`, `level_depth` mm at a time, and within each level along shortest paths (steps
/// between 6-neighbours of the isotropic grid); `u32::MAX` where no core is reached. A thin structure lying
/// against a thick one (a renal vein on the aorta) has no core of its own where the two meet:
/// grown along shortest paths alone, the thick one's core took the thin one's stretch beyond a
/// pinhole between them and the thin one's basin began a cross-section further on, as if the
/// thick one branched there. Level by level, the thin one's ridge is taken along its own length
/// before the pinhole's shallower saddle is crossed. Within a level the flood's order does not
/// decide where two basins meet: shortest paths do. Ties go to the smaller label, so the
/// partition is deterministic.
fn grow_cores(
    inside: &MaskVoxels,
    depth: &[f64],
    cores: Vec<u32>,
    level_depth: f64,
) -> Result<Vec<u32>> {
    let mut label = cores;
    let mut order = allocation::collect_counted(
        (0..inside.len()).filter(|&n| label[n] == u32::MAX),
        "the flood's order",
    )?;
    order.sort_unstable_by(|&a, &b| depth[b].total_cmp(&depth[a]).then(a.cmp(&b)));
    let mut admitted = allocation::filled(inside.len(), false, "the flood's admitted voxels")?;
    let mut waiting: Vec<usize> = Vec::new();
    let mut next_admitted = 0;
    let mut level = order.first().map_or(0.0, |&n| depth[n]);
    while next_admitted < order.len() {
        while let Some(&n) = order.get(next_admitted).filter(|&&n| depth[n] >= level) {
            admitted[n] = true;
            waiting.push(n);
            next_admitted += 1;
        }
        // The first ring is the admitted voxels next to a labelled one; then shortest paths.
        let mut ring: Vec<usize> = waiting
            .iter()
            .copied()
            .filter(|&n| inside.neighbours(n).any(|m| label[m] != u32::MAX))
            .collect();
        let mut next = Vec::new();
        while !ring.is_empty() {
            // Each voxel of the ring takes the smallest label among its labelled neighbours
            // from before the ring.
            let labels: Vec<u32> = ring
                .iter()
                .map(|&n| {
                    inside
                        .neighbours(n)
                        .map(|m| label[m])
                        .min()
                        .expect("next to a labelled voxel")
                })
                .collect();
            for (&n, l) in ring.iter().zip(labels) {
                label[n] = l;
            }
            for &n in &ring {
                next.extend(
                    inside
                        .neighbours(n)
                        .filter(|&m| admitted[m] && label[m] == u32::MAX),
                );
            }
            next.sort_unstable();
            next.dedup();
            std::mem::swap(&mut ring, &mut next);
            next.clear();
        }
        waiting.retain(|&n| label[n] == u32::MAX);
        level -= level_depth;
    }
    Ok(label)
}

/// The watershed of the distance map `depth` (mm) of the voxels of `inside`: a basin label
/// per voxel of `inside` and each basin's thickness (its deepest voxel's depth). Voxels are
/// flooded from the deepest down, in a fixed order; a voxel next to one basin joins it, one
/// next to several merges those whose saddle here is not a waist — shallower than [`SPLIT`]
/// of the thinner one's thickness and by at least a `voxel` (a smaller dip is the grid's) —
/// or where either is thinner than `min_thickness`, and joins the deepest.
fn watershed(
    inside: &MaskVoxels,
    depth: &[f64],
    min_thickness: f64,
    voxel: f64,
) -> Result<(Vec<u32>, Vec<f64>)> {
    let mut order = allocation::collect(0..depth.len(), "the watershed's order")?;
    order.sort_unstable_by(|&a, &b| depth[b].total_cmp(&depth[a]).then(a.cmp(&b)));
    let mut label = allocation::filled(depth.len(), u32::MAX, "the watershed's labels")?;
    let mut sets = Basins::default();
    for n in order {
        let saddle = depth[n];
        let mut around: Vec<u32> = inside
            .neighbours(n)
            .filter(|&m| label[m] != u32::MAX)
            .map(|m| sets.find(label[m]))
            .collect();
        around.sort_unstable();
        around.dedup();
        let Some(&first) = around.first() else {
            label[n] = sets.add(saddle);
            continue;
        };
        let mut joined = first;
        for &other in &around[1..] {
            let a = sets.find(joined);
            let b = sets.find(other);
            let thinner = sets.thickness[a as usize].min(sets.thickness[b as usize]);
            let waist = saddle < SPLIT * thinner && thinner - saddle >= voxel;
            if thinner < min_thickness || !waist {
                joined = sets.union(a, b);
            } else if sets.thickness[b as usize] > sets.thickness[a as usize] {
                joined = b;
            }
        }
        label[n] = sets.find(joined);
    }
    // Number the basins that remain densely, in the order of their roots.
    let mut dense = vec![u32::MAX; sets.parent.len()];
    let mut thickness = Vec::new();
    for l in label.iter_mut().filter(|l| **l != u32::MAX) {
        let root = sets.find(*l) as usize;
        if dense[root] == u32::MAX {
            dense[root] = thickness.len() as u32;
            thickness.push(sets.thickness[root]);
        }
        *l = dense[root];
    }
    Ok((label, thickness))
}

/// Union–find over the basins of the flood, each with its thickness.
#[derive(Default)]
struct Basins {
    parent: Vec<u32>,
    thickness: Vec<f64>,
}

impl Basins {
    fn add(&mut self, thickness: f64) -> u32 {
        self.parent.push(self.parent.len() as u32);
        self.thickness.push(thickness);
        self.parent.len() as u32 - 1
    }

    fn find(&mut self, mut a: u32) -> u32 {
        while self.parent[a as usize] != a {
            let up = self.parent[self.parent[a as usize] as usize];
            self.parent[a as usize] = up;
            a = up;
        }
        a
    }

    /// Merges two roots into the deeper one; returns it.
    fn union(&mut self, a: u32, b: u32) -> u32 {
        if a == b {
            return a;
        }
        let (keep, gone) = if self.thickness[a as usize] >= self.thickness[b as usize] {
            (a, b)
        } else {
            (b, a)
        };
        self.parent[gone as usize] = keep;
        keep
    }
}

/// Which basins are joined to one of `seeds` through contacts that are neither elongated nor
/// necks: a basin entered through a contact whose radius (of a disc of its area) is less than
/// `1 / NECK_RATIO` of the basin's own thickness (its deepest point's distance to the outside,
/// `thickness`) is a structure the balloon leaked into through a narrow passage — a kidney
/// through its artery, the liver through a portal branch, a neighbour through a pinhole —
/// while a branch is about as thick as its root.
fn joined_through_round_contacts(
    basins: &BasinMap,
    thickness: &[f64],
    seeds: &[u32],
    dims: [usize; 3],
    grid: &Geometry,
) -> Vec<bool> {
    // The voxel faces between each pair of basins.
    let mut contacts: HashMap<(u32, u32), Vec<Face>, FastHash> = HashMap::default();
    let voxels = Grid(dims);
    let spacing = grid.spacing();
    let face_area = [
        spacing[1] * spacing[2],
        spacing[0] * spacing[2],
        spacing[0] * spacing[1],
    ];
    for (n, a) in basins.iter().filter(|&(_, a)| a != u32::MAX) {
        for m in voxels.neighbours(n).filter(|&m| m > n) {
            let b = basins.at(m);
            if b != u32::MAX && b != a {
                let index = |v: usize| {
                    let (i, j, k) = voxels.coordinates(v);
                    DVec3::new(i as f64, j as f64, k as f64)
                };
                let axis = match m - n {
                    1 => 0,
                    d if d == dims[0] => 1,
                    _ => 2,
                };
                let centre = 0.5 * (index(n) + index(m));
                let mut step = DVec3::ZERO;
                step[axis] = if a < b { 0.5 } else { -0.5 };
                let from_first =
                    grid.index_to_world(centre + step) - grid.index_to_world(centre - step);
                contacts
                    .entry((a.min(b), a.max(b)))
                    .or_default()
                    .push(Face {
                        voxels: [n, m],
                        centre: grid.index_to_world(centre),
                        area: face_area[axis],
                        oriented: from_first.normalize() * face_area[axis],
                    });
            }
        }
    }
    let count = thickness.len();
    let mut joined = vec![Vec::new(); count];
    let mut pairs: Vec<_> = contacts.into_iter().collect();
    pairs.sort_unstable_by_key(|(pair, _)| *pair);
    for ((a, b), faces) in pairs {
        let moments = moments_of(faces.iter());
        // The side test reads the basins around the contact: only for contacts that the
        // contact's own shape leaves open.
        let thicker = thickness[a as usize].max(thickness[b as usize]);
        let on_its_side =
            |c: u32, t: f64| meets_on_its_side(basins, c, &moments, SIDE_REACH * t, dims, grid);
        let round = moments.count < MIN_CONTACT_FACES
            || (largest_patch(&faces, voxels).elongation() <= ELONGATED
                && ![a, b].iter().all(|&c| {
                    let own = thickness[c as usize];
                    on_its_side(c, own) || (own < thicker && on_its_side(c, thicker))
                }));
        if round {
            let radius = (moments.area / std::f64::consts::PI).sqrt();
            joined[a as usize].push((b, radius));
            joined[b as usize].push((a, radius));
        }
    }
    let mut kept = vec![false; count];
    let mut stack: Vec<u32> = seeds.to_vec();
    while let Some(b) = stack.pop() {
        if !std::mem::replace(&mut kept[b as usize], true) {
            stack.extend(
                joined[b as usize]
                    .iter()
                    .filter(|&&(c, radius)| thickness[c as usize] <= NECK_RATIO * radius)
                    .map(|&(c, _)| c),
            );
        }
    }
    kept
}

/// A voxel face between two basins: the voxels on either side, its centre (world mm), area
/// and oriented area (towards the second basin).
struct Face {
    voxels: [usize; 2],
    centre: DVec3,
    area: f64,
    oriented: DVec3,
}

/// The moments of the faces' centres, with their areas and oriented areas.
fn moments_of<'f>(faces: impl Iterator<Item = &'f Face>) -> Moments {
    let mut moments = Moments::default();
    for face in faces {
        moments.add(face.centre, face.area, face.oriented);
    }
    moments
}

/// The moments of the largest connected patch of `faces` (by face count; faces whose voxels
/// are 26-neighbours are connected). Where a thicker basin floods the crossing of a thinner
/// tube (a trunk ending on the wall of a ring of vessels), the tube's basin meets it in two
/// discs, one on either side of the junction, whose centres together spread like the strip
/// along which two tubes lie side by side; each disc is round, and so is the junction.
fn largest_patch(faces: &[Face], voxels: Grid) -> Moments {
    let mut slots: HashMap<usize, u32, FastHash> = HashMap::default();
    for &v in faces.iter().flat_map(|f| &f.voxels) {
        let next = slots.len() as u32;
        slots.entry(v).or_insert(next);
    }
    let mut patches = DisjointSets::new(slots.len());
    for (&v, &slot) in &slots {
        for w in neighbours_26(voxels, v) {
            if let Some(&other) = slots.get(&w) {
                patches.union(slot, other);
            }
        }
    }
    // Roots are the smallest slot of their patch and slots follow the faces' order, so the
    // first-found largest patch is the same on every run.
    let roots: Vec<u32> = faces
        .iter()
        .map(|f| patches.find(slots[&f.voxels[0]]))
        .collect();
    let mut sizes: HashMap<u32, usize, FastHash> = HashMap::default();
    for &r in &roots {
        *sizes.entry(r).or_default() += 1;
    }
    let largest = roots
        .iter()
        .copied()
        .max_by_key(|r| (sizes[r], std::cmp::Reverse(*r)))
        .unwrap_or(0);
    moments_of(
        faces
            .iter()
            .zip(&roots)
            .filter(|&(_, &r)| r == largest)
            .map(|(f, _)| f),
    )
}

/// The 26-neighbours of voxel `n` inside the grid.
fn neighbours_26(voxels: Grid, n: usize) -> impl Iterator<Item = usize> {
    let [ni, nj, nk] = voxels.0;
    let (i, j, k) = voxels.coordinates(n);
    let near = |c: usize, size: usize| c.saturating_sub(1)..=(c + 1).min(size - 1);
    near(k, nk)
        .flat_map(move |z| {
            near(j, nj).flat_map(move |y| near(i, ni).map(move |x| x + ni * (y + nj * z)))
        })
        .filter(move |&m| m != n)
}

/// Whether `basin` meets the contact `contact` on its side: around the contact (within `reach`
/// mm of its centre) the basin spreads along the contact more than [`SIDE_ELONGATION`] times
/// as far as across it. A tube touched on its wall runs on past the contact both ways; a
/// branch leaves the contact across it, and so does a trunk's own lumen from a stenosis.
fn meets_on_its_side(
    basins: &BasinMap,
    basin: u32,
    contact: &Moments,
    reach: f64,
    dims: [usize; 3],
    grid: &Geometry,
) -> bool {
    let normal = contact.normal.normalize_or_zero();
    if normal == DVec3::ZERO {
        return false;
    }
    let centre = contact.mean();
    let c = grid.world_to_index(centre);
    let r = reach / grid.min_spacing();
    let range = |a: usize| {
        let lo = (c[a] - r).floor().max(0.0) as usize;
        let hi = ((c[a] + r).ceil().max(0.0) as usize).min(dims[a] - 1);
        lo..=hi
    };
    let mut near = Moments::default();
    for k in range(2) {
        for j in range(1) {
            for i in range(0) {
                if basins.at(i + dims[0] * (j + dims[1] * k)) != basin {
                    continue;
                }
                let p = grid.index_to_world(DVec3::new(i as f64, j as f64, k as f64));
                if p.distance(centre) <= reach {
                    near.add(p, 0.0, DVec3::ZERO);
                }
            }
        }
    }
    if near.count < MIN_CONTACT_FACES {
        return false;
    }
    let covariance = near.covariance();
    let across = normal.dot(covariance * normal);
    let [along, _, _] = symmetric_eigenvalues(covariance);
    along > SIDE_ELONGATION.powi(2) * across
}

/// Count, sum and sum of outer products of points (their covariance), the area they stand for
/// and the sum of their oriented face areas (a patch's normal times its area).
#[derive(Default)]
struct Moments {
    count: usize,
    area: f64,
    normal: DVec3,
    sum: DVec3,
    outer: DMat3,
}

impl Moments {
    fn add(&mut self, p: DVec3, area: f64, normal: DVec3) {
        self.count += 1;
        self.area += area;
        self.normal += normal;
        self.sum += p;
        self.outer += DMat3::from_cols(p * p.x, p * p.y, p * p.z);
    }

    fn mean(&self) -> DVec3 {
        self.sum / self.count as f64
    }

    fn covariance(&self) -> DMat3 {
        let mean = self.mean();
        self.outer * (1.0 / self.count as f64)
            - DMat3::from_cols(mean * mean.x, mean * mean.y, mean * mean.z)
    }

    /// Length over width of the points' spread: the square root of the ratio of the largest
    /// to the second largest variance.
    fn elongation(&self) -> f64 {
        let [largest, second, _] = symmetric_eigenvalues(self.covariance());
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
                strip.add(
                    DVec3::new(i as f64, j as f64, 0.1 * j as f64),
                    1.0,
                    DVec3::ZERO,
                );
            }
        }
        for i in -6i32..=6 {
            for j in -6i32..=6 {
                if i * i + j * j <= 36 {
                    disk.add(DVec3::new(i as f64, 0.0, j as f64), 1.0, DVec3::ZERO);
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
        zero_level(sdf, [-14.0, -10.0, -24.0], [36, 26, 33])
    }

    /// The zero level of `sdf` (world mm) on a grid of 0.8 × 0.8 × 1.5 mm voxels from `origin`.
    fn zero_level(sdf: impl Fn(DVec3) -> f64, origin: [f64; 3], dims: [usize; 3]) -> TriMesh {
        let g = Geometry::with_spacing([0.8, 0.8, 1.5], origin).unwrap();
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
        let cut = cut_touching(&tubes, &g, &[seed], 2.6, &HashSet::default(), None)
            .unwrap()
            .expect("a cut")
            .mesh;
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
        assert!(cut_touching(
            &narrowing,
            &g,
            &[DVec3::new(0.0, 0.0, -10.0)],
            2.6,
            &HashSet::default(),
            None,
        )
        .unwrap()
        .is_none());
        let sphere = icosphere(DVec3::ZERO, 6.0, 4);
        assert!(
            cut_touching(&sphere, &g, &[DVec3::ZERO], 2.6, &HashSet::default(), None)
                .unwrap()
                .is_none()
        );
    }

    /// Regression: a tube cut off as touching while the balloon was half-way along it was
    /// entered again beyond the cut, and that stub, meeting the seeded tube across a short
    /// round contact, was kept as a branch (touching-pair variants 25, 35 and 45).
    #[test]
    fn a_structure_cut_off_earlier_and_entered_again_is_cut_off_again() {
        let g = Geometry::with_spacing([0.8, 0.8, 1.5], [0.0; 3]).unwrap();
        let capsule = |p: DVec3, x: f64, z0: f64, z1: f64| {
            (p - DVec3::new(x, 0.0, p.z.clamp(z0, z1))).length() - 4.0
        };
        // The seeded tube, and what the balloon took again of the second one: its end beyond
        // z = 10, against the seeded tube (axes 8 mm apart, radii 4 mm). Half a millimetre
        // apart, the stub met the seeded tube across a contact narrow enough to be a neck on
        // its own.
        let balloon = zero_level(
            |p| capsule(p, -4.0, -14.0, 14.0).min(capsule(p, 4.0, -14.0, 14.0).max(10.0 - p.z)),
            [-10.0, -6.0, -20.0],
            [26, 16, 28],
        );
        let seed = DVec3::new(-4.0, 0.0, 0.0);
        let nothing_earlier = HashSet::default();
        assert!(
            cut_touching(&balloon, &g, &[seed], 2.6, &nothing_earlier, None)
                .unwrap()
                .is_none(),
            "on its own, the stub is a branch"
        );
        // The earlier cut took the second tube below z = 10.
        let mut earlier: HashSet<[i64; 3], FastHash> = HashSet::default();
        for k in -14..=7 {
            for j in -6..=6 {
                for i in 0..=11 {
                    let p = g.index_to_world(DVec3::new(i as f64, j as f64, k as f64));
                    if capsule(p, 4.0, -14.0, 14.0) <= 0.0 && p.z < 10.0 {
                        earlier.insert([i, j, k]);
                    }
                }
            }
        }
        let cut = cut_touching(&balloon, &g, &[seed], 2.6, &earlier, None)
            .unwrap()
            .expect("the stub cut off")
            .mesh;
        let report = crate::mesh_checks::check(&cut);
        assert!(report.is_valid_closed_surface(), "{report:?}");
        assert!(
            cut.points().iter().all(|p| p.x < 1.5),
            "nothing of the second tube"
        );
    }

    /// Faces between voxels `(i, 0, k)` and `(i, 1, k)` of a 40 × 2 × 5 grid, for each `i` in
    /// `columns` and every `k`.
    fn faces_at(columns: impl Iterator<Item = usize>) -> Vec<Face> {
        columns
            .flat_map(|i| (0..5).map(move |k| (i, k)))
            .map(|(i, k)| {
                let n = i + 40 * 2 * k;
                Face {
                    voxels: [n, n + 40],
                    centre: DVec3::new(i as f64, 0.5, k as f64),
                    area: 1.0,
                    oriented: DVec3::Y,
                }
            })
            .collect()
    }

    #[test]
    fn two_discs_apart_are_round_patches_and_a_strip_is_one_elongated_patch() {
        let voxels = Grid([40, 2, 5]);
        // Two 5 × 5 patches 25 voxels apart: together as spread as a strip.
        let discs = faces_at((0..5).chain(30..35));
        assert!(moments_of(discs.iter()).elongation() > ELONGATED);
        assert!(largest_patch(&discs, voxels).elongation() <= ELONGATED);
        assert_eq!(largest_patch(&discs, voxels).count, 25);
        let strip = faces_at(0..35);
        assert!(largest_patch(&strip, voxels).elongation() > ELONGATED);
        assert_eq!(largest_patch(&strip, voxels).count, strip.len());
    }

    /// A ball of radius 9 voxels, a tube of radius 2.5 lying over it along x and joined to it by
    /// a pinhole one voxel across, and a ball of radius 6 at the tube's far end: a renal vein
    /// on the aorta, running to the kidney.
    fn tube_over_a_ball_through_a_pinhole() -> (Vec<bool>, [usize; 3]) {
        let dims = [60, 44, 30];
        let (ball, tube_y, end) = (DVec3::new(14.0, 16.0, 15.0), 28.0, 48.0);
        let mut mask = vec![false; dims[0] * dims[1] * dims[2]];
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let p = DVec3::new(i as f64, j as f64, k as f64);
                    let axis = DVec3::new(p.x.clamp(4.0, end), tube_y, 15.0);
                    let pinhole = i == 14 && k == 15 && (24..=26).contains(&j);
                    mask[i + dims[0] * (j + dims[1] * k)] = p.distance(ball) <= 9.0
                        || p.distance(axis) <= 2.5
                        || p.distance(DVec3::new(end, tube_y, 15.0)) <= 6.0
                        || pinhole;
                }
            }
        }
        (mask, dims)
    }

    #[test]
    fn a_thin_structure_over_a_pinhole_goes_with_the_basin_along_its_own_ridge() {
        let (mask, dims) = tube_over_a_ball_through_a_pinhole();
        assert!(
            mask[14 + dims[0] * (26 + dims[1] * 15)],
            "the pinhole joins them"
        );
        let (basins, thickness) = find_basins(&mask, dims, [1.0; 3], 2.0).unwrap();
        let at = |i: usize, j: usize| basins.at(i + dims[0] * (j + dims[1] * 15));
        let (ball, end) = (at(14, 16), at(48, 28));
        assert_eq!(thickness.len(), 2, "{thickness:?}");
        assert_ne!(ball, end);
        // Right over the pinhole, nine voxels from the ball's core and 28 from the end's.
        assert_eq!(
            at(14, 28),
            end,
            "the tube over the pinhole went with the ball"
        );
        assert_eq!(at(14, 25), ball, "the pinhole's near half");
    }

    #[test]
    fn a_seed_outside_every_basin_cuts_nothing() {
        let g = Geometry::with_spacing([0.8, 0.8, 1.5], [0.0; 3]).unwrap();
        let tubes = capsules(true);
        let far = DVec3::new(0.0, 30.0, 0.0);
        assert!(
            cut_touching(&tubes, &g, &[far], 2.6, &HashSet::default(), None)
                .unwrap()
                .is_none()
        );
    }
}
