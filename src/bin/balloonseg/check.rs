//! `balloonseg check MESH`: the mesh's topology and geometry as JSON on standard output.

use std::path::PathBuf;
use std::process::ExitCode;

use balloonseg::self_intersection::{count_self_intersections, pair_limit};
use balloonseg::{io, mesh_checks, Result};
use serde_json::json;

#[derive(clap::Args)]
pub struct Args {
    /// Mesh file (.vtp, .vtk, .ply, .stl, .obj, .off).
    mesh: PathBuf,
    /// Exit with status 1 unless the mesh is closed, manifold, outward and free of
    /// self-intersections.
    #[arg(long)]
    strict: bool,
}

pub fn run(args: &Args) -> Result<ExitCode> {
    let mesh = io::read_mesh(&args.mesh)?;
    let report = mesh_checks::check(&mesh);
    let pairs = count_self_intersections(&mesh)?.saturated();
    let summary = json!({
        "file": crate::shown(&args.mesh),
        "vertices": report.vertices,
        "triangles": report.triangles,
        "closed": report.closed(),
        "manifold": report.manifold(),
        "oriented": report.consistently_oriented(),
        "outward": report.outward(),
        "self_intersecting_pairs": pairs,
        "self_intersections_counted_up_to": pair_limit(report.triangles),
        "euler_characteristic": report.euler_characteristic,
        "genus": report.genus(),
        "components": report.components,
        "area_mm2": report.area,
        "volume_mm3": report.signed_volume,
        "boundary_edges": report.boundary_edges,
        "non_manifold_edges": report.non_manifold_edges,
        "non_manifold_vertices": report.non_manifold_vertices,
        "degenerate_triangles": report.degenerate_triangles,
        "unreferenced_vertices": report.unreferenced_vertices,
    });
    let json = serde_json::to_string_pretty(&summary).expect("plain JSON values");
    crate::print_out(&format!("{json}\n"))?;
    let valid = report.is_valid_closed_surface() && pairs == 0;
    Ok(if args.strict && !valid {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}
