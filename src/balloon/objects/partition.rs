//! The objects' territories settled by the thick parts of their union. Balloons that grow
//! together race: where two tubes touch, the balloon that reaches the contact first passes it
//! and holds part of the other tube, which its neighbour can then never fill, and the lobe it
//! holds is too small to be cut off as a leak (`finishing::touching`). The union of the objects
//! does show the two tubes: split into the basins of its thick parts by the same watershed as
//! the touching cut, each basin goes to the object whose seeds' basins it joins through the
//! widest contacts (`claim_basins`). Voxels elsewhere stay with the object that holds them.
//!
//! Where two claims meet, the boundary is drawn again by the power diagram of the balls
//! inscribed in the union (`distance_transform::power_labels`): each voxel goes to the object
//! of the ball of least power, which puts the boundary between two round structures in the
//! plane through the rim of their contact — a vessel's end where it opens into a chamber,
//! wherever the race left it. For that depth the gap the objects keep between them counts as
//! inside (`between_objects`); seen as outside, it would make each side of a contact a surface
//! of the union.
//!
//! Every object's surface is then made again from its signed distance map with the voxels it
//! gained moved inside and those it lost moved outside, on one isotropic grid of the smallest
//! spacing; a voxel next to (26-connected) one of an object earlier in order goes to neither,
//! so no marching-cubes cell holds the inside of two objects and the new surfaces cannot meet.
//! Refinement then lets them grow back towards each other, up to the clearance.

use std::collections::HashMap;

use glam::DVec3;

use crate::allocation;
use crate::balloon::fast_hash::FastHash;

use crate::balloon::finishing::touching::{basins_of, find_basins, voxel_of, BasinMap};
use crate::balloon::reparametrization::isosurface::{
    covering_grid, isosurface, keep_seeded_components, without_cavities,
};
use crate::disjoint_sets::DisjointSets;
use crate::distance_transform::{distance_to_outside, power_labels};
use crate::error::Result;
use crate::geometry::Geometry;
use crate::mesh::TriMesh;
use crate::morphology::Grid;
use crate::signed_distance::{signed_distance_values, SignedDistanceOptions};
use crate::winding_number::inside_mask;

const NOBODY: u32 = u32::MAX;

/// How far (voxels of the largest spacing) from two objects a voxel outside both may lie and
/// still be the gap between them rather than the outside of their union.
const GAP_VOXELS: f64 = 1.5;

/// The objects' new surfaces (world mm), if any voxel changed hands; `meshes` and `seeds` are
/// by object, in order, `radius` (mm) the smallest thickness of a part of its own.
pub(super) fn repartition(
    meshes: &[TriMesh],
    seeds: &[&[DVec3]],
    geometry: &Geometry,
    radius: f64,
) -> Result<Option<Vec<TriMesh>>> {
    let voxel = geometry.min_spacing();
    let isotropic = Geometry::new([voxel; 3], geometry.origin(), geometry.direction())?;
    let mut all = meshes[0].clone();
    for mesh in &meshes[1..] {
        all.append(mesh)?;
    }
    let (grid, dims) = covering_grid(&all, &isotropic, 2.0)?;
    let mut owner = allocation::filled(dims.iter().product(), NOBODY, "the objects' owners")?;
    for (i, mesh) in meshes.iter().enumerate() {
        for (o, inside) in owner.iter_mut().zip(inside_mask(mesh, dims, &grid)?) {
            if inside && *o == NOBODY {
                *o = i as u32;
            }
        }
    }
    let union = allocation::collect(owner.iter().map(|&o| o != NOBODY), "the objects' union")?;
    // The basins of the union as the balloons left it, their gap outside: with the gap closed,
    // two tubes lying side by side read as one thick part, split along its length instead
    // (touching-pair variant 0: Dice 0.58 for the thinner tube).
    let (basins, thickness) = find_basins(&union, dims, grid.spacing(), radius)?;
    let claimed = claim_basins(&basins, thickness.len(), seeds, &grid, dims);
    let claims = allocation::collect(
        owner
            .iter()
            .enumerate()
            .map(|(n, &o)| match claimed.get(basins.at(n) as usize) {
                Some(&k) if k != NOBODY && o != NOBODY => k,
                _ => o,
            }),
        "the basins' claims",
    )?;
    let gap = GAP_VOXELS * geometry.max_spacing();
    let between = between_objects(meshes, &owner, dims, &grid, gap)?;
    let closed = allocation::collect(
        union.iter().zip(&between).map(|(&u, &b)| u || b),
        "the objects' union with the space between them",
    )?;
    let depth = distance_to_outside(&closed, dims, grid.spacing())?;
    let mut new_owner = power_labels(&depth, &claims, NOBODY, dims, grid.spacing())?;
    for (o, &inside) in new_owner.iter_mut().zip(&union) {
        if !inside {
            *o = NOBODY;
        }
    }
    if new_owner == owner {
        return Ok(None);
    }
    keep_apart(&mut new_owner, dims)?;
    let band = SignedDistanceOptions { band_voxels: 1.0 };
    let outside = band.band_mm(&grid);
    let voxel_volume = voxel.powi(3);
    let mut repartitioned = Vec::with_capacity(meshes.len());
    for (i, mesh) in meshes.iter().enumerate() {
        let mut field = signed_distance_values(mesh, mesh, dims, &grid, &band)?;
        for (value, &o) in field.iter_mut().zip(&new_owner) {
            let own = o == i as u32;
            if own && *value >= 0.0 {
                *value = -outside;
            } else if !own && *value < 0.0 {
                *value = outside;
            }
        }
        keep_seeded_components(&mut field, dims, &grid, seeds[i])?;
        repartitioned.push(without_cavities(
            isosurface(field, dims, &grid, 0.0)?,
            voxel_volume,
        ));
    }
    Ok(Some(repartitioned))
}

/// The voxels outside every object but within `gap` (mm) of two of them: the space objects
/// keep between them where they meet. Their union's depth must not take it for its outside,
/// or each object's side of a contact would look like a surface of the union.
fn between_objects(
    meshes: &[TriMesh],
    owner: &[u32],
    dims: [usize; 3],
    grid: &Geometry,
    gap: f64,
) -> Result<Vec<bool>> {
    let band = SignedDistanceOptions {
        band_voxels: (gap / grid.max_spacing()).max(1.0),
    };
    let mut near: Vec<u8> = allocation::zeroed(owner.len(), "the objects' nearness counts")?;
    for mesh in meshes {
        let field = signed_distance_values(mesh, mesh, dims, grid, &band)?;
        for ((count, &d), &o) in near.iter_mut().zip(&field).zip(owner) {
            if o == NOBODY && d < gap {
                *count = count.saturating_add(1);
            }
        }
    }
    allocation::collect(
        near.iter().map(|&count| count >= 2),
        "the space between the objects",
    )
}

/// The object each basin goes to (`NOBODY`: it stays as it is). A basin holding the seeds of
/// one object goes to it; the others join their neighbours through the widest contacts first
/// (voxel faces between them), never joining two objects' basins: a tube's own parts meet across
/// its whole cross-section, two tubes across the patch where they touch.
fn claim_basins(
    basins: &BasinMap,
    count: usize,
    seeds: &[&[DVec3]],
    grid: &Geometry,
    dims: [usize; 3],
) -> Vec<u32> {
    let mut owner = vec![NOBODY; count];
    let mut contested = vec![false; count];
    for (i, object_seeds) in seeds.iter().enumerate() {
        let voxels: Vec<usize> = object_seeds
            .iter()
            .filter_map(|&s| voxel_of(grid.world_to_index(s), dims))
            .collect();
        for b in basins_of(basins, &voxels) {
            match owner[b as usize] {
                NOBODY => owner[b as usize] = i as u32,
                k if k != i as u32 => contested[b as usize] = true,
                _ => {}
            }
        }
    }
    for (o, &c) in owner.iter_mut().zip(&contested) {
        if c {
            *o = NOBODY;
        }
    }
    let mut faces: HashMap<(u32, u32), usize, FastHash> = HashMap::default();
    let voxels = Grid(dims);
    for (n, a) in basins.iter().filter(|&(_, a)| a != NOBODY) {
        for m in voxels.neighbours(n).filter(|&m| m > n) {
            let b = basins.at(m);
            if b != NOBODY && b != a {
                *faces.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
    }
    let mut contacts: Vec<((u32, u32), usize)> = faces.into_iter().collect();
    contacts.sort_unstable_by(|x, y| y.1.cmp(&x.1).then(x.0.cmp(&y.0)));
    let mut sets = DisjointSets::new(count);
    // The owner of each set, at its root; a contested basin's set is nobody's and stays so.
    let mut set_owner = owner.clone();
    let set_contested = contested;
    for ((a, b), _) in contacts {
        let (ra, rb) = (sets.find(a), sets.find(b));
        if ra == rb || set_contested[ra as usize] || set_contested[rb as usize] {
            continue;
        }
        let (oa, ob) = (set_owner[ra as usize], set_owner[rb as usize]);
        if oa != NOBODY && ob != NOBODY && oa != ob {
            continue;
        }
        sets.union(ra, rb);
        let root = sets.find(ra) as usize;
        set_owner[root] = if oa != NOBODY { oa } else { ob };
    }
    (0..count as u32)
        .map(|b| set_owner[sets.find(b) as usize])
        .collect()
}

/// Gives up to nobody every voxel with a 26-neighbour of an object earlier in order.
fn keep_apart(owner: &mut [u32], dims: [usize; 3]) -> Result<()> {
    let grid = Grid(dims);
    let before = allocation::collect(owner.iter().copied(), "the owners before")?;
    for (n, o) in owner.iter_mut().enumerate() {
        if *o == NOBODY {
            continue;
        }
        let (i, j, k) = grid.coordinates(n);
        let near_earlier = (0..27).any(|m| {
            let d = [m % 3, m / 3 % 3, m / 9].map(|c| c as i64 - 1);
            let at = [i as i64 + d[0], j as i64 + d[1], k as i64 + d[2]];
            if (0..3).any(|a| at[a] < 0 || at[a] >= dims[a] as i64) {
                return false;
            }
            let u = before[at[0] as usize + dims[0] * (at[1] as usize + dims[1] * at[2] as usize)];
            u != NOBODY && u < *o
        });
        if near_earlier {
            *o = NOBODY;
        }
    }
    Ok(())
}
