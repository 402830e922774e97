//! Wavefront OBJ meshes: `v` and `f` statements only. Faces may use the `v/vt/vn` forms and
//! negative (relative) indices; polygons are fan-triangulated. Texture coordinates, normals,
//! groups and materials are ignored. Written coordinates use Rust's shortest round-trip
//! formatting, so an f64 mesh reads back bit for bit.

use std::io::Write;
use std::path::Path;

use glam::DVec3;

use super::files;
use super::point_data::{self, PointData};
use super::polygons;
use super::scan::{self, Cursor};
use crate::error::{Error, Result};
use crate::mesh::TriMesh;

/// Reads the vertices and faces of an OBJ file.
pub fn read(path: &Path) -> Result<TriMesh> {
    files::parse_file(path, parse)
}

/// Writes `v` and `f` lines. OBJ stores no point data: `point_data` is only checked.
pub fn write(path: &Path, mesh: &TriMesh, point_data: &[PointData]) -> Result<()> {
    point_data::check(mesh, point_data, &[])?;
    files::write(path, |w| write_to(w, mesh))
}

pub(crate) fn parse(bytes: &[u8]) -> Result<TriMesh> {
    let mut points = Vec::new();
    let mut triangles = Vec::new();
    let mut corners = Vec::new();
    let mut lines = Cursor::new(bytes);
    let mut number = 0;
    while let Some(line) = lines.line() {
        number += 1;
        let line = match line.iter().position(|&b| b == b'#') {
            Some(comment) => &line[..comment],
            None => line,
        };
        let mut words = Cursor::new(line);
        let context = |e: Error| e.context(format!("line {number}"));
        match words.word() {
            Some(b"v") => {
                let p: [f64; 3] = [
                    words.number("vertex x").map_err(context)?,
                    words.number("vertex y").map_err(context)?,
                    words.number("vertex z").map_err(context)?,
                ];
                points.push(DVec3::from(p));
            }
            Some(b"f") => {
                corners.clear();
                while let Some(word) = words.word() {
                    corners.push(corner(word, points.len()).map_err(context)?);
                }
                polygons::push_polygon(&mut triangles, &corners);
            }
            _ => {}
        }
    }
    polygons::mesh(points, triangles)
}

/// The 0-based vertex of a face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`; negative `v` counts
/// back from the last vertex defined so far.
fn corner(word: &[u8], defined: usize) -> Result<u32> {
    let vertex = word.split(|&b| b == b'/').next().unwrap_or(word);
    let v: i64 = scan::parse(vertex, "face vertex index")?;
    let zero_based = match v {
        0 => None,
        v if v > 0 => Some(v - 1),
        v => (defined as i64).checked_add(v).filter(|&i| i >= 0),
    };
    zero_based
        .and_then(|i| u32::try_from(i).ok())
        .ok_or_else(|| {
            Error::format(format!(
                "face vertex index {v} does not name a vertex ({defined} defined so far; OBJ \
                 indices start at 1, negative ones count back from the last)"
            ))
        })
}

fn write_to(w: &mut impl Write, mesh: &TriMesh) -> std::io::Result<()> {
    writeln!(
        w,
        "# written by balloonseg: {} vertices, {} triangles",
        mesh.points().len(),
        mesh.triangles().len()
    )?;
    for p in mesh.points() {
        writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for [a, b, c] in mesh.triangles() {
        writeln!(w, "f {} {} {}", *a as u64 + 1, *b as u64 + 1, *c as u64 + 1)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::test_support::assert_never_panics;
    use super::*;
    use crate::mesh::test_shapes::{cube, icosphere};

    fn to_bytes(mesh: &TriMesh) -> Vec<u8> {
        let mut bytes = Vec::new();
        write_to(&mut bytes, mesh).unwrap();
        bytes
    }

    #[test]
    fn empty_mesh_round_trips() {
        assert_eq!(
            parse(&to_bytes(&TriMesh::default())).unwrap(),
            TriMesh::default()
        );
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let mesh = icosphere(DVec3::new(0.1, -1e-7, 3e5), 1.0 / 3.0, 2)
            .map_points(|p| p * std::f64::consts::PI)
            .unwrap();
        assert_eq!(parse(&to_bytes(&mesh)).unwrap(), mesh);
    }

    #[test]
    fn face_forms_relative_indices_and_polygons() {
        let text = b"# a quad and a triangle\nmtllib x.mtl\no thing\n\
                     v 0 0 0\nv 1 0 0\nv 1 1 0 # comment\nv 0 1 0 1.0\n\
                     vt 0 0\nvn 0 0 1\ng g1\nusemtl m\ns off\n\
                     f 1/1/1 2/1/1 3//1 4/1\r\n\
                     v 0 0 1\nf -1 -5 -4\nl 1 2\n";
        let mesh = parse(text).unwrap();
        assert_eq!(mesh.points().len(), 5);
        assert_eq!(mesh.triangles(), &[[0, 1, 2], [0, 2, 3], [4, 0, 1]]);
    }

    #[test]
    fn bad_indices_name_the_line() {
        for (text, needle) in [
            (&b"v 0 0 0\nf 0 1 1\n"[..], "line 2"),
            (b"v 0 0 0\nf -2 1 1\n", "-2"),
            (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "triangle 0"),
            (b"v 0 0\n", "line 1: vertex z"),
            (b"v 0 0 x\n", "\"x\""),
        ] {
            let e = parse(text).unwrap_err();
            assert!(e.message().contains(needle), "{needle}: {e}");
        }
    }

    #[test]
    fn corrupt_files_never_panic() {
        let bytes = to_bytes(&cube(DVec3::ZERO, DVec3::ONE));
        assert!(assert_never_panics(&bytes, 300, parse) > 0);
    }
}
