//! Validation of the finished surface: closed, 2-manifold, outward, free of self-intersections
//! and of crossings with other objects, or the finishing steps undone around the contacts, or one more
//! re-parametrisation; and handles narrower than a voxel closed when the image cannot show them.

use glam::DVec3;

use crate::balloon::objects::obstacle::crossings;
use crate::balloon::progress::Phase;
use crate::balloon::reparametrization::isosurface::voxel_genus;
use crate::balloon::reparametrization::AfterReparametrization;
use crate::balloon::segmenter::Segmenter;
use crate::balloon::surface::VertexState;
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::mesh_checks;
use crate::self_intersection::self_intersections;

use super::UNFAIR_ROUNDS;

/// A final surface re-parametrised to close handles narrower than a voxel must keep the
/// balloon's volume to this share: marching cubes on the scan's grid moves the surface of a
/// lumen 20 mm across by well under half a percent of its volume (stents: 0.25–0.46%), but a
/// vessel a voxel or two thick by several percent (thin-vessels 48: 5.5%), and there a
/// handle narrower than a voxel may be the vessel's own loop, which the grid breaks.
const KEPT_VOLUME: f64 = 0.01;

/// Rounds of moving the corners of triangles that cross another object's final surface out of
/// it (`pushed_out_of_finished`), before the finishing steps are undone around them.
const PUSH_ROUNDS: usize = 4;

impl Segmenter<'_, '_> {
    /// The current mesh if it meets the guarantees, without the handles narrower than a voxel
    /// ([`Self::with_fewer_handles`]). Where the curvature offset, settling or fairing
    /// (`earlier`: the positions before each, latest first) made the surface meet itself, each
    /// in turn is undone around the contacts, [`UNFAIR_ROUNDS`] times each, then the latest
    /// everywhere, and so on. Otherwise (or straight away if it stopped with contacts) one more
    /// re-parametrisation, without refinement or remeshing — a marching-cubes surface has no
    /// contacts — checked again. A marching-cubes surface that still crosses another object's
    /// (the grid cannot follow that surface closer than its cells) is made again with the
    /// clearance widened, up to a voxel.
    pub(in crate::balloon) fn validated(
        &mut self,
        mut earlier: Vec<Vec<DVec3>>,
    ) -> Result<(TriMesh, Vec<VertexState>)> {
        self.timed(Phase::Validation, |s| {
            s.report(0.95, Phase::Validation)?;
            // A balloon that stopped with contacts cannot pass: repair it without measuring it.
            let mut repaired = s.has_self_intersections();
            if repaired {
                s.replace_by_isosurface(AfterReparametrization::Nothing)?;
            }
            let (mut unfair_rounds, mut push_rounds) = (0, 0);
            loop {
                let (mesh, states) = s.mesh();
                let report = mesh_checks::check(&mesh);
                let pairs = s.contacts(&mesh)?;
                let only_crossings = pairs.iter().all(|&(a, b)| a == b);
                // Crossings alone are met where they are, before anything is undone for them.
                if !pairs.is_empty() && only_crossings && push_rounds < PUSH_ROUNDS {
                    push_rounds += 1;
                    let crossing: Vec<u32> = pairs.iter().map(|&(t, _)| t).collect();
                    let distance = push_rounds as f64 * s.image.clearance();
                    if s.pushed_out_of_finished(&mesh, &crossing, distance)? {
                        continue;
                    }
                    push_rounds = PUSH_ROUNDS;
                }
                if report.is_valid_closed_surface() && pairs.is_empty() {
                    let result = match report.genus() {
                        Some(genus) if genus > 0 && !repaired && report.components == 1 => s
                            .with_fewer_handles(&mesh, genus, report.signed_volume)?
                            .unwrap_or((mesh, states)),
                        _ => (mesh, states),
                    };
                    s.report(1.0, Phase::Validation)?;
                    return Ok(result);
                }
                if !earlier.is_empty() {
                    // Around the contacts, each step undone in turn, latest first, before the
                    // latest is undone everywhere: a contact settling made stays when only the
                    // curvature offset is undone around it.
                    let stage = (unfair_rounds / UNFAIR_ROUNDS) as usize;
                    if stage < earlier.len() && report.is_valid_closed_surface() {
                        s.unfair(&earlier[stage], &mesh, &pairs);
                        unfair_rounds += 1;
                    } else {
                        let before = earlier.remove(0);
                        s.unfair(&before, &mesh, &[]);
                        unfair_rounds = 0;
                    }
                    continue;
                }
                if repaired && only_crossings && s.image.widen_clearance() {
                    s.replace_by_isosurface(AfterReparametrization::Nothing)?;
                    continue;
                }
                if repaired {
                    return Err(Error::internal(format!(
                        "the segmentation failed its own checks (closed {}, manifold {}, outward {}, \
                         {} intersecting pairs) even after re-parametrisation",
                        report.closed(),
                        report.manifold(),
                        report.outward(),
                        pairs.len()
                    )));
                }
                s.freeze_self_intersections()?;
                s.replace_by_isosurface(AfterReparametrization::Nothing)?;
                repaired = true;
            }
        })
    }

    /// Moves the corners of the triangles `crossing` of `mesh` (the current surface), which
    /// cross other objects' final surfaces, from the closest point of each such surface to the
    /// clearance outside it. The move stays only if the surface is still closed, 2-manifold,
    /// outward and free of self-intersections; returns whether it did.
    fn pushed_out_of_finished(
        &mut self,
        mesh: &TriMesh,
        crossing: &[u32],
        clearance: f64,
    ) -> Result<bool> {
        let mut corners = self.corner_slots(mesh, crossing.iter().copied());
        corners.sort_unstable();
        corners.dedup();
        let before = self.surface.positions().to_vec();
        for &v in &corners {
            let mut p = before[v as usize];
            for obstacle in &self.apart_from {
                let Some((distance, closest)) = obstacle.nearest(p) else {
                    continue;
                };
                let outward = if distance < 0.0 {
                    closest - p
                } else {
                    p - closest
                };
                if let Some(n) = outward.try_normalize().filter(|_| distance < clearance) {
                    p = closest + clearance * n;
                }
            }
            self.surface.positions_mut()[v as usize] = p;
        }
        self.index_surface();
        let (moved, _) = self.mesh();
        let pairs = self.pool.install(|| self_intersections(&moved));
        if mesh_checks::check(&moved).is_valid_closed_surface()
            && pairs.as_ref().is_ok_and(|p| p.is_empty())
        {
            return Ok(true);
        }
        self.surface.positions_mut().copy_from_slice(&before);
        self.index_surface();
        // Put back before an allocation failure is reported: the balloon stays as it was.
        pairs?;
        Ok(false)
    }

    /// The pairs of triangles of `mesh` (the current surface) that intersect, and each that
    /// crosses another object's final surface as a pair with itself.
    fn contacts(&self, mesh: &TriMesh) -> Result<Vec<(u32, u32)>> {
        let mut pairs = self.pool.install(|| self_intersections(mesh))?;
        let finished = &self.apart_from;
        let crossing = self.pool.install(|| crossings(mesh, finished))?;
        pairs.extend(crossing.into_iter().map(|t| (t, t)));
        Ok(pairs)
    }

    /// The final surface `mesh` (of genus `genus`, enclosing `volume`) re-parametrised (without
    /// refinement), if its voxels have fewer handles and the new surface is valid with fewer,
    /// not fewer than the voxels, and of the same volume within [`KEPT_VOLUME`]; otherwise the
    /// surface stays as it was. A handle narrower than a voxel is one the image cannot show,
    /// and the paper's re-parametrisation closes it: the stents' lumens wrapped around their
    /// struts (variants 8, 28, 41, 52: genus 1), the slab aorta around something on its wall
    /// (genus 2).
    pub(in crate::balloon) fn with_fewer_handles(
        &mut self,
        mesh: &TriMesh,
        genus: i64,
        volume: f64,
    ) -> Result<Option<(TriMesh, Vec<VertexState>)>> {
        let geometry = *self.volume.geometry();
        let Some(least) = self.pool.install(|| voxel_genus(mesh, &geometry))? else {
            return Ok(None);
        };
        if least >= genus {
            return Ok(None);
        }
        let before = self.surface.clone();
        self.replace_by_isosurface(AfterReparametrization::Nothing)?;
        let (without_handles, states) = self.mesh();
        let report = mesh_checks::check(&without_handles);
        if report.is_valid_closed_surface()
            && report.genus().is_some_and(|g| g < genus && g >= least)
            && (report.signed_volume - volume).abs() <= KEPT_VOLUME * volume
            && self.contacts(&without_handles)?.is_empty()
        {
            return Ok(Some((without_handles, states)));
        }
        self.replace_surface(before);
        Ok(None)
    }
}
