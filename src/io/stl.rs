//! STL triangle soups, binary and ASCII. Reading welds bit-identical corners into shared
//! vertices ([`TriMesh::from_soup`]); writing stores binary STL with per-facet normals.
//!
//! A binary file may begin with the word "solid" like an ASCII one, so the size formula of
//! binary STL (84 + 50 bytes per triangle) decides first, and the word "solid" only after.
//!
//! Ours rather than `stl_io` (0.11), measured in BENCHMARKS.md ("io: our readers against the
//! crates"): it welds the same vertices, but reads binary STL in 1.2 to 1.3 times our time and
//! ASCII in 2.0, its errors are io errors that do not name the facet, and it needs Rust 1.85
//! (ours 1.80); on 2000 mutations each of an ASCII and a binary file neither reader panicked,
//! aborted or hung.

use std::io::Write;
use std::path::Path;

use glam::DVec3;

use super::files;
use super::point_data::{self, PointData};
use super::scan::{self, Cursor};
use crate::error::{Error, Result};
use crate::mesh::TriMesh;

const HEADER: usize = 80;
const FACET: usize = 50;

/// Reads a binary or ASCII STL file.
pub fn read(path: &Path) -> Result<TriMesh> {
    files::parse_file(path, parse)
}

/// Writes binary STL (float32 coordinates, normals from the corners). STL stores no point
/// data: `point_data` is only checked.
pub fn write(path: &Path, mesh: &TriMesh, point_data: &[PointData]) -> Result<()> {
    point_data::check(mesh, point_data, &[])?;
    check_fits(mesh)?;
    files::write(path, |w| write_to(w, mesh))
}

fn binary_triangle_count(bytes: &[u8]) -> Option<u64> {
    let count = bytes.get(HEADER..HEADER + 4)?;
    Some(u32::from_le_bytes([count[0], count[1], count[2], count[3]]) as u64)
}

fn starts_with_solid(bytes: &[u8]) -> bool {
    let text = bytes.trim_ascii_start();
    text.len() >= 5 && text[..5].eq_ignore_ascii_case(b"solid")
}

pub(crate) fn parse(bytes: &[u8]) -> Result<TriMesh> {
    let count = binary_triangle_count(bytes);
    let binary_size = count.map(|n| (HEADER + 4) as u64 + FACET as u64 * n);
    if binary_size == Some(bytes.len() as u64) || !starts_with_solid(bytes) {
        return parse_binary(bytes);
    }
    parse_ascii(bytes).map_err(|e| match (count, binary_size) {
        (Some(n), Some(size)) => Error::format(format!(
            "{} (read as ASCII STL because it starts with \"solid\"; as binary STL its {n} \
             triangles would need {size} bytes, not {})",
            e.message(),
            bytes.len()
        )),
        _ => e,
    })
}

fn parse_binary(bytes: &[u8]) -> Result<TriMesh> {
    let Some(count) = binary_triangle_count(bytes) else {
        return Err(Error::format(format!(
            "{} bytes are too short for a binary STL header (84 bytes) and the file does not \
             start with \"solid\" as ASCII STL does",
            bytes.len()
        )));
    };
    let mut cursor = Cursor::new(&bytes[HEADER + 4..]);
    cursor.check_room(count as usize, FACET, "binary STL triangles")?;
    let body = cursor.take(count as usize * FACET)?;
    let f32_at = |b: &[u8], at: usize| f32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]]);
    let soup: Vec<[DVec3; 3]> = body
        .chunks_exact(FACET)
        .map(|facet| {
            // The stored normal (first 12 bytes) is redundant with the winding and often wrong.
            let corner = |c: usize| {
                let at = 12 + 12 * c;
                DVec3::new(
                    f32_at(facet, at) as f64,
                    f32_at(facet, at + 4) as f64,
                    f32_at(facet, at + 8) as f64,
                )
            };
            [corner(0), corner(1), corner(2)]
        })
        .collect();
    TriMesh::from_soup(&soup).map_err(|e| Error::format(e.message()))
}

fn keyword(word: &[u8], expected: &str) -> bool {
    word.eq_ignore_ascii_case(expected.as_bytes())
}

fn expect(cursor: &mut Cursor, expected: &str) -> Result<()> {
    let word = cursor.expect_word()?;
    if keyword(word, expected) {
        Ok(())
    } else {
        Err(Error::format(format!(
            "expected \"{expected}\", found {}",
            scan::show(word)
        )))
    }
}

fn parse_ascii(bytes: &[u8]) -> Result<TriMesh> {
    let mut cursor = Cursor::new(bytes);
    let mut soup = Vec::new();
    while let Some(word) = cursor.word() {
        if keyword(word, "solid") || keyword(word, "endsolid") {
            // The rest of the line is the solid's name.
            cursor.line();
        } else if keyword(word, "facet") {
            let facet = soup.len();
            let corners = parse_facet(&mut cursor)
                .map_err(|e| e.context(format!("ASCII STL facet {facet}")))?;
            soup.push(corners);
        } else {
            return Err(Error::format(format!(
                "ASCII STL: expected \"facet\" or \"endsolid\", found {}",
                scan::show(word)
            )));
        }
    }
    TriMesh::from_soup(&soup).map_err(|e| Error::format(e.message()))
}

fn parse_facet(cursor: &mut Cursor) -> Result<[DVec3; 3]> {
    expect(cursor, "normal")?;
    for _ in 0..3 {
        cursor.number::<f64>("normal")?;
    }
    expect(cursor, "outer")?;
    expect(cursor, "loop")?;
    let mut corners = [DVec3::ZERO; 3];
    for (n, corner) in corners.iter_mut().enumerate() {
        expect(cursor, "vertex")?;
        let what = format!("vertex {n}");
        *corner = DVec3::new(
            cursor.number(&what)?,
            cursor.number(&what)?,
            cursor.number(&what)?,
        );
    }
    let word = cursor.expect_word()?;
    if keyword(word, "vertex") {
        return Err(Error::format(
            "more than three vertices; STL facets must be triangles",
        ));
    }
    if !keyword(word, "endloop") {
        return Err(Error::format(format!(
            "expected \"endloop\", found {}",
            scan::show(word)
        )));
    }
    expect(cursor, "endfacet")?;
    Ok(corners)
}

fn check_fits(mesh: &TriMesh) -> Result<()> {
    if mesh.triangles().len() > u32::MAX as usize {
        return Err(Error::invalid_argument(format!(
            "{} triangles exceed binary STL's 32-bit count; use .vtp or .ply",
            mesh.triangles().len()
        )));
    }
    let limit = f32::MAX as f64;
    if let Some(i) = mesh
        .points()
        .iter()
        .position(|p| p.abs().max_element() > limit)
    {
        return Err(Error::invalid_argument(format!(
            "point {i} ({}) is outside the float32 range STL stores; use .vtp or .ply",
            mesh.points()[i]
        )));
    }
    Ok(())
}

fn write_to(w: &mut impl Write, mesh: &TriMesh) -> std::io::Result<()> {
    let mut header = [b' '; HEADER];
    // Must not start with "solid", which would announce ASCII STL.
    let title = b"binary STL written by balloonseg";
    header[..title.len()].copy_from_slice(title);
    w.write_all(&header)?;
    w.write_all(&(mesh.triangles().len() as u32).to_le_bytes())?;
    for t in 0..mesh.triangles().len() {
        let [a, b, c] = mesh.corners(t);
        let normal = (b - a).cross(c - a).normalize_or_zero();
        let mut facet = [0u8; FACET];
        for (slot, v) in [normal, a, b, c].iter().enumerate() {
            for (axis, x) in v.to_array().iter().enumerate() {
                let at = 12 * slot + 4 * axis;
                facet[at..at + 4].copy_from_slice(&(*x as f32).to_le_bytes());
            }
        }
        w.write_all(&facet)?;
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

    fn as_f32(p: DVec3) -> DVec3 {
        p.as_vec3().as_dvec3()
    }

    #[test]
    fn empty_mesh_round_trips() {
        assert_eq!(
            parse(&to_bytes(&TriMesh::default())).unwrap(),
            TriMesh::default()
        );
    }

    #[test]
    fn binary_round_trip_keeps_corners_to_float32_and_welds_vertices() {
        let mesh = icosphere(DVec3::new(10.3, -4.1, 7.7), 12.5, 2);
        let bytes = to_bytes(&mesh);
        assert_eq!(bytes.len(), 84 + 50 * mesh.triangles().len());
        let back = parse(&bytes).unwrap();
        assert_eq!(back.points().len(), mesh.points().len());
        assert_eq!(back.triangles().len(), mesh.triangles().len());
        for t in 0..mesh.triangles().len() {
            assert_eq!(back.corners(t), mesh.corners(t).map(as_f32));
        }
    }

    #[test]
    fn written_normals_point_out_of_a_cube() {
        let mesh = cube(DVec3::ZERO, DVec3::ONE);
        let bytes = to_bytes(&mesh);
        for t in 0..12 {
            let at = 84 + 50 * t;
            let n: Vec<f32> = (0..3)
                .map(|k| f32::from_le_bytes(bytes[at + 4 * k..at + 4 * k + 4].try_into().unwrap()))
                .collect();
            let [a, b, c] = mesh.corners(t);
            let centre = (a + b + c) / 3.0 - DVec3::splat(0.5);
            let n = DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64);
            assert!((n.length() - 1.0).abs() < 1e-6 && n.dot(centre) > 0.0);
        }
    }

    #[test]
    fn binary_file_whose_header_starts_with_solid_is_read_as_binary() {
        let mut bytes = to_bytes(&cube(DVec3::ZERO, DVec3::ONE));
        bytes[..12].copy_from_slice(b"solid cube  ");
        let mesh = parse(&bytes).unwrap();
        assert_eq!((mesh.points().len(), mesh.triangles().len()), (8, 12));
    }

    #[test]
    fn ascii_facets_are_welded_and_keep_their_winding() {
        let text = b"solid two\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   \
                     vertex 1 0 0\n   vertex 0 1 0\n  endloop\n endfacet\n\
                     FACET NORMAL 0 0 1 OUTER LOOP VERTEX 1 0 0 VERTEX 1 1 0 VERTEX 0 1 0 \
                     ENDLOOP ENDFACET\nendsolid two\n";
        let mesh = parse(text).unwrap();
        assert_eq!(mesh.points().len(), 4);
        assert_eq!(mesh.triangles(), &[[0, 1, 2], [1, 3, 2]]);
        assert!((mesh.area() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn ascii_errors_name_the_facet() {
        let quad = b"solid q\nfacet normal 0 0 1 outer loop vertex 0 0 0 vertex 1 0 0 \
                     vertex 1 1 0 vertex 0 1 0 endloop endfacet endsolid";
        let e = parse(quad).unwrap_err();
        assert!(
            e.message().contains("facet 0") && e.message().contains("triangles"),
            "{e}"
        );
        let bad = b"solid q\nfacet normal 0 0 1 outer loop vertex 0 zero 0";
        let e = parse(bad).unwrap_err();
        assert!(e.message().contains("\"zero\""), "{e}");
    }

    #[test]
    fn truncated_binary_is_an_error_naming_the_count() {
        let bytes = to_bytes(&cube(DVec3::ZERO, DVec3::ONE));
        let e = parse(&bytes[..bytes.len() - 1]).unwrap_err();
        assert!(e.message().contains("12 binary STL triangles"), "{e}");
    }

    #[test]
    fn corrupt_files_never_panic() {
        let bytes = to_bytes(&cube(DVec3::ZERO, DVec3::ONE));
        assert!(assert_never_panics(&bytes, 300, parse) > 0);
        let text = b"solid c\nfacet normal 0 0 1 outer loop vertex 0 0 0 vertex 1 0 0 \
                     vertex 0 1 0 endloop endfacet\nendsolid c\n";
        assert!(assert_never_panics(text, 300, parse) > 0);
    }
}
