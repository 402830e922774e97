//! Several objects at once, the paper's proposal for structures that connect without a wall
//! between them (its conclusion): "start balloons from different seeds, look for intersections
//! with the other meshes, stop the nodes that meet". Every object is a balloon of its own, with
//! its own intensity model from its first seed, its own contacts with itself and its own
//! re-parametrisations; to each, the others are obstacles (`obstacle`): a vertex stops
//! [`CLEARANCE_VOXELS`] short of another object's surface as it stops at the border, and its
//! re-parametrisation keeps its new surface out of them. Contacts between two objects never
//! merge them.
//!
//! All objects grow together, one step each in turn, in the order they were given: the first
//! inflation, and each re-parametrisation of contacts with itself and the refinement after it,
//! until each is at equilibrium. Then their territories are settled by the thick parts of their
//! union (`partition`), each cuts off what it entered through a contact (`finishing::touching`),
//! and all grow together again into what was given to them or freed (`MAX_ROUNDS`). Then each
//! in order is let grow into what those before it gave up, is cut, faired and validated against
//! the others as they stand (the final surfaces of those before it). Competitors (stop seeds)
//! grow with the objects and keep them from growing into the structure they fill; they come
//! last in order and are not finished, as no object comes after them, nor returned.
//!
//! One object without competitors is exactly [`Segmenter::segment`].

pub(in crate::balloon) mod obstacle;
mod partition;
mod simplified;

pub use simplified::simplify_objects;
pub(in crate::balloon) use simplified::simplify_with_states;

use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;
use std::sync::Arc;

use glam::DVec3;

use crate::balloon::finishing::TOUCHING_EDGE_LENGTHS;
use crate::balloon::image_model::region::Region;
use crate::balloon::inflation::Inflation;
use crate::balloon::params::BalloonParams;
use crate::balloon::progress::{of_the_run, Phase, ProgressCallback};
use crate::balloon::reparametrization::AfterReparametrization;
use crate::balloon::segmenter::{SegmentationStats, Segmenter};
use crate::balloon::surface::{Surface, VertexState};
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::volume::Volume;
use obstacle::{crossings, Obstacle};
use partition::repartition;

/// The distance, in voxels of the smallest spacing, that a balloon keeps from another object:
/// where two objects meet, the gap between them is about this wide, and their surfaces never
/// touch.
pub const CLEARANCE_VOXELS: f64 = 0.25;

/// Labels go into a signed 32-bit `object` array.
pub const MAX_LABEL: u32 = i32::MAX as u32;

/// Objects and competitors at most: each is a balloon of its own, searched by all the others.
pub const MAX_OBJECTS: usize = 256;

/// Rounds of settling territories and inflating together again. More rounds went worse on the
/// touching pairs (`examples/objects_sweep`, 16 variants: the lowest Dice 0.90 with one round,
/// 0.86 with two, 0.88 with three) and each costs about as much as the first inflation.
const MAX_ROUNDS: usize = 1;

/// Seeds of one object (world mm), named by a positive label.
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectSeeds {
    pub label: u32,
    pub seeds: Vec<DVec3>,
}

/// An object's segmentation.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentedObject {
    pub label: u32,
    pub seeds: Vec<DVec3>,
    /// World mm; closed, 2-manifold, outward, free of self-intersections and of crossings with
    /// the other objects.
    pub mesh: TriMesh,
    pub states: Vec<VertexState>,
    pub stats: SegmentationStats,
}

/// What to segment: the objects, the competitors that only block them (`stops`, world mm,
/// each a balloon of its own) and the region of interest.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ObjectsRequest {
    pub objects: Vec<ObjectSeeds>,
    pub stops: Vec<DVec3>,
    pub region: Option<Region>,
}

/// Segments every object of `request` in `volume`, in the order given.
pub fn segment_objects<'v, 'p>(
    volume: Volume<'v>,
    params: BalloonParams,
    request: &ObjectsRequest,
    progress: Option<ProgressCallback<'p>>,
) -> Result<Vec<SegmentedObject>> {
    params.validate()?;
    check_request(volume, request)?;
    let mut members = Vec::with_capacity(request.objects.len() + request.stops.len());
    let starts = request
        .objects
        .iter()
        .map(|o| (Some(o.label), o.seeds.as_slice()))
        .chain(
            request
                .stops
                .iter()
                .map(|s| (None, std::slice::from_ref(s))),
        );
    for (label, seeds) in starts {
        let name = describe(label);
        let start = || -> Result<Segmenter<'v, 'p>> {
            let mut segmenter = Segmenter::new(volume, params.clone(), seeds[0])?;
            for &seed in &seeds[1..] {
                segmenter.add_seed(seed)?;
            }
            if let Some(region) = request.region {
                segmenter.restrict_to(region)?;
            }
            Ok(segmenter)
        };
        members.push(Member {
            label,
            segmenter: start().map_err(|e| e.context(&name))?,
        });
    }
    let shared = share_progress(&mut members, progress);
    // One balloon's `segment` simplifies its own result; the objects are simplified together,
    // below, so that their simplified surfaces do not cross.
    let (results, together) = if members.len() == 1 {
        let (mesh, states) = members[0].segmenter.segment()?;
        (vec![(mesh, states)], None)
    } else {
        (compete(&mut members)?, params.simplification())
    };
    let mut objects: Vec<SegmentedObject> = members
        .into_iter()
        .zip(results)
        .filter_map(|(member, (mesh, states))| {
            Some(SegmentedObject {
                label: member.label?,
                seeds: member.segmenter.seeds().to_vec(),
                mesh,
                states,
                stats: member.segmenter.stats().clone(),
            })
        })
        .collect();
    if let Some(max_error) = together {
        let progress = |fraction: f64| match &shared {
            Some(shared) => {
                let fraction = of_the_run(fraction, Phase::Simplification, true);
                (shared.borrow_mut().0)(fraction, Phase::Simplification)
            }
            None => true,
        };
        simplify_objects(&mut objects, max_error, progress)
            .map_err(|e| e.context("cannot simplify the segmentation"))?;
    }
    Ok(objects)
}

struct Member<'v, 'p> {
    /// `None` for a competitor.
    label: Option<u32>,
    segmenter: Segmenter<'v, 'p>,
}

fn describe(label: Option<u32>) -> String {
    match label {
        Some(label) => format!("object {label}"),
        None => "a stop seed".to_string(),
    }
}

/// The members inflate together, then the objects finish one after the other (module docs);
/// the final mesh and vertex states of each object, in order.
fn compete(members: &mut [Member<'_, '_>]) -> Result<Vec<(TriMesh, Vec<VertexState>)>> {
    let geometry = *members[0].segmenter.volume_geometry();
    let clearance = CLEARANCE_VOXELS * geometry.min_spacing();
    // A vertex moves less than a voxel per step, so a reach of two voxels sees every obstacle
    // it could step into, with room for the clearance.
    let reach = 2.0 * geometry.max_spacing();
    let mut indexes: Vec<Arc<Obstacle>> = (0..members.len())
        .map(|i| index_near_others(members, i, reach))
        .collect();
    let mut runs: Vec<_> = members
        .iter()
        .map(|m| {
            let limit = m.segmenter.params().max_iterations;
            Some(m.segmenter.start_inflation(Phase::Inflation, limit))
        })
        .collect();
    let mut used = vec![0; members.len()];
    for round in 0..=MAX_ROUNDS {
        inflate_together(
            members,
            &mut runs,
            &mut used,
            &mut indexes,
            reach,
            clearance,
        )?;
        if round == MAX_ROUNDS {
            break;
        }
        let repartitioned = repartition_members(members, &mut indexes, reach, clearance)?;
        let cut = cut_touching_members(members, &mut indexes, reach, clearance)?;
        if !repartitioned && !cut {
            break;
        }
        if cut {
            for (i, member) in members.iter_mut().enumerate() {
                member
                    .segmenter
                    .set_obstacles(others(&indexes, i), clearance);
                member.segmenter.release_frozen();
            }
        }
        restart(members, &mut runs, &used, &indexes, clearance);
    }
    let mut results = Vec::with_capacity(members.len());
    // Each finishes alone, its surface free to grow where the others were not near.
    for (j, index) in indexes.iter_mut().enumerate() {
        *index = Arc::new(members[j].segmenter.as_obstacle(reach, None));
    }
    // Competitors come last: with every object final, their own finish would serve nobody.
    let objects = members.iter().take_while(|m| m.label.is_some()).count();
    for i in 0..objects {
        let Member { label, segmenter } = &mut members[i];
        segmenter.set_obstacles(others(&indexes, i), clearance);
        segmenter.keep_apart_from(indexes[..i].to_vec());
        let name = || describe(*label);
        let mut left = segmenter.params().max_iterations.saturating_sub(used[i]);
        // What those finished before it gave up (a part they cut off, a sliver their fairing
        // freed) is free to grow into.
        if i > 0 && segmenter.release_frozen() > 0 {
            let limit = left.max(segmenter.params().refinement_iterations);
            let mut run = segmenter.start_inflation(Phase::Refinement, limit);
            while !segmenter
                .continue_inflation(&mut run)
                .map_err(|e| e.context(name()))?
            {}
            left = left.saturating_sub(run.steps);
        }
        let (mesh, states) = segmenter.finish(left).map_err(|e| e.context(name()))?;
        indexes[i] = Arc::new(Obstacle::of_mesh(&mesh, reach));
        results.push((mesh, states));
    }
    check_apart(members, &results, &indexes)?;
    Ok(results)
}

/// All members with an inflation under way take a step each in turn, each against the others
/// as they stand, until every inflation and the re-parametrisations and refinements after it
/// are over; `used` counts each member's steps.
fn inflate_together(
    members: &mut [Member<'_, '_>],
    runs: &mut [Option<Inflation>],
    used: &mut [u32],
    indexes: &mut [Arc<Obstacle>],
    reach: f64,
    clearance: f64,
) -> Result<()> {
    while runs.iter().any(Option::is_some) {
        for i in 0..members.len() {
            let Some(run) = runs[i].as_mut() else {
                continue;
            };
            let Member { label, segmenter } = &mut members[i];
            segmenter.set_obstacles(others(indexes, i), clearance);
            let done = segmenter
                .continue_inflation(run)
                .map_err(|e| e.context(describe(*label)))?;
            if done {
                used[i] += run.steps;
                let left = segmenter.params().max_iterations.saturating_sub(used[i]);
                // Contacts are re-parametrised and refined here, beside the others, as a
                // balloon alone does after its first inflation: a large structure does most of
                // its growing in those refinements.
                match segmenter
                    .next_refinement(left)
                    .map_err(|e| e.context(describe(*label)))?
                {
                    Some(next) => *run = next,
                    None => {
                        // Whole: the others may grow anywhere around a surface that no longer
                        // moves.
                        indexes[i] = Arc::new(members[i].segmenter.as_obstacle(reach, None));
                        runs[i] = None;
                        continue;
                    }
                }
            }
            indexes[i] = index_near_others(members, i, reach);
        }
    }
    Ok(())
}

/// Settles the members' territories by the thick parts of their union (`partition`): the
/// members whose surfaces it remade start again from them, frozen where they may not move on.
/// Returns whether any voxel changed hands.
fn repartition_members(
    members: &mut [Member<'_, '_>],
    indexes: &mut [Arc<Obstacle>],
    reach: f64,
    clearance: f64,
) -> Result<bool> {
    let meshes: Vec<TriMesh> = members.iter().map(|m| m.segmenter.mesh().0).collect();
    let seeds: Vec<&[DVec3]> = members.iter().map(|m| m.segmenter.seeds()).collect();
    let geometry = *members[0].segmenter.volume_geometry();
    let edge_length = members
        .iter()
        .map(|m| m.segmenter.edge_length())
        .fold(f64::INFINITY, f64::min);
    let radius = TOUCHING_EDGE_LENGTHS * edge_length;
    let Some(remade) = repartition(&meshes, &seeds, &geometry, radius)? else {
        return Ok(false);
    };

    for (index, mesh) in indexes.iter_mut().zip(&remade) {
        *index = Arc::new(Obstacle::of_mesh(mesh, reach));
    }
    for (i, (member, mesh)) in members.iter_mut().zip(&remade).enumerate() {
        let segmenter = &mut member.segmenter;
        segmenter.set_obstacles(others(indexes, i), clearance);
        let mut surface = Surface::from_mesh(mesh)?;
        segmenter.freeze_outside_window(&mut surface);
        segmenter.replace_surface(surface);
    }
    Ok(true)
}

/// Each member cuts off what it entered through a contact (`finishing::touching`), against the
/// others as they stand; returns whether any did.
fn cut_touching_members(
    members: &mut [Member<'_, '_>],
    indexes: &mut [Arc<Obstacle>],
    reach: f64,
    clearance: f64,
) -> Result<bool> {
    let mut cut = false;
    for i in 0..members.len() {
        let Member { label, segmenter } = &mut members[i];
        segmenter.set_obstacles(others(indexes, i), clearance);
        if segmenter
            .cut_touching(AfterReparametrization::Refinement)
            .map_err(|e| e.context(describe(*label)))?
        {
            indexes[i] = Arc::new(segmenter.as_obstacle(reach, None));
            cut = true;
        }
    }
    Ok(cut)
}

/// A refinement for every member, with what is left of its steps.
fn restart(
    members: &mut [Member<'_, '_>],
    runs: &mut [Option<Inflation>],
    used: &[u32],
    indexes: &[Arc<Obstacle>],
    clearance: f64,
) {
    for (i, member) in members.iter_mut().enumerate() {
        let segmenter = &mut member.segmenter;
        segmenter.set_obstacles(others(indexes, i), clearance);
        let left = segmenter.params().max_iterations.saturating_sub(used[i]);
        runs[i] = Some(segmenter.start_inflation(Phase::Refinement, left));
    }
}

/// The `i`th member's surface as an obstacle, for the others as they stand: only its triangles
/// within two reaches of another member's bounding box, which no vertex of that member leaves
/// by more than a step, nor the grid of its re-parametrisation by more than a reach. Far
/// apart, objects cost each other nothing.
fn index_near_others(members: &[Member<'_, '_>], i: usize, reach: f64) -> Arc<Obstacle> {
    let grown = DVec3::splat(reach);
    let others: Vec<(DVec3, DVec3)> = (0..members.len())
        .filter(|&j| j != i)
        .map(|j| members[j].segmenter.bounds())
        .map(|(lo, hi)| (lo - grown, hi + grown))
        .collect();
    Arc::new(members[i].segmenter.as_obstacle(reach, Some(&others)))
}

/// The surfaces of all members but the `i`th.
fn others(indexes: &[Arc<Obstacle>], i: usize) -> Vec<Arc<Obstacle>> {
    (0..indexes.len())
        .filter(|&j| j != i)
        .map(|j| indexes[j].clone())
        .collect()
}

/// No object's final surface meets another's: each was validated against those finished
/// before it, and this checks every pair once more before anything is returned. `results`
/// are the objects', in order; the competitors after them are not finished.
fn check_apart(
    members: &[Member<'_, '_>],
    results: &[(TriMesh, Vec<VertexState>)],
    indexes: &[Arc<Obstacle>],
) -> Result<()> {
    for i in 0..results.len() {
        for j in i + 1..results.len() {
            let crossing = crossings(&results[i].0, std::slice::from_ref(&indexes[j]))?;
            if !crossing.is_empty() {
                return Err(Error::internal(format!(
                    "{} and {} cross ({} triangles of the first meet the second) after \
                     validation; please report this with the image and the seeds",
                    describe(members[i].label),
                    describe(members[j].label),
                    crossing.len()
                )));
            }
        }
    }
    Ok(())
}

/// The caller's progress callback, shared by the members, with each member's last fraction.
type SharedProgress<'p> = Rc<RefCell<(ProgressCallback<'p>, Vec<f64>)>>;

/// One progress callback for all members: the mean of their fractions. Returned for what
/// follows the members' runs.
fn share_progress<'p>(
    members: &mut [Member<'_, 'p>],
    progress: Option<ProgressCallback<'p>>,
) -> Option<SharedProgress<'p>> {
    let callback = progress?;
    let n = members.len();
    let shared = Rc::new(RefCell::new((callback, vec![0.0; n])));
    for (i, member) in members.iter_mut().enumerate() {
        let shared = Rc::clone(&shared);
        member
            .segmenter
            .set_progress(Some(Box::new(move |fraction, phase| {
                let (callback, fractions) = &mut *shared.borrow_mut();
                fractions[i] = fraction;
                let mean = fractions.iter().sum::<f64>() / n as f64;
                callback(mean, phase)
            })));
    }
    Some(shared)
}

/// Labels positive and distinct, every object seeded, not too many objects, and no voxel
/// seeded by two of them.
fn check_request(volume: Volume<'_>, request: &ObjectsRequest) -> Result<()> {
    if request.objects.is_empty() {
        return Err(Error::invalid_argument(
            "no object to segment: give at least one seed",
        ));
    }
    let count = request.objects.len() + request.stops.len();
    if count > MAX_OBJECTS {
        return Err(Error::invalid_argument(format!(
            "{count} objects and stop seeds; at most {MAX_OBJECTS} can grow at once: give \
             fewer labels or stop seeds"
        )));
    }
    let geometry = volume.geometry();
    let voxel = |p: DVec3| {
        let i = geometry.world_to_index(p).round();
        [i.x as i64, i.y as i64, i.z as i64]
    };
    for object in &request.objects {
        let label = object.label;
        if label == 0 || label > MAX_LABEL {
            let seeds: Vec<String> = object.seeds.iter().map(|s| format!("{s} mm")).collect();
            return Err(Error::invalid_argument(format!(
                "object label {label} (seeds {}); labels are 1 to {MAX_LABEL}",
                seeds.join(", ")
            )));
        }
        if object.seeds.is_empty() {
            return Err(Error::invalid_argument(format!(
                "object {label} has no seed; give it at least one"
            )));
        }
        if request.objects.iter().filter(|o| o.label == label).count() > 1 {
            return Err(Error::invalid_argument(format!(
                "object label {label} is given twice; put all its seeds in one object"
            )));
        }
    }
    let seeds = request
        .objects
        .iter()
        .flat_map(|o| o.seeds.iter().map(|&s| (Some(o.label), s)));
    let stops = request.stops.iter().map(|&s| (None, s));
    let mut seeded: HashMap<[i64; 3], (Option<u32>, DVec3)> = HashMap::new();
    for (owner, seed) in seeds.chain(stops) {
        if !seed.is_finite() {
            return Err(Error::invalid_argument(format!(
                "the seed {seed} of {} is not finite; give world millimetres",
                describe(owner)
            )));
        }
        match seeded.insert(voxel(seed), (owner, seed)) {
            Some((other, at)) if other != owner || owner.is_none() => {
                return Err(Error::invalid_argument(format!(
                    "the seed {seed} mm of {} is in the voxel {:?} of the seed {at} mm of {}; \
                     give each object and each stop seed voxels of its own",
                    describe(owner),
                    voxel(seed),
                    describe(other)
                )));
            }
            _ => {}
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
