//! OFF (Geomview Object File Format) meshes, ASCII: read into a `TriMesh` and write one.
//!
//! Reading accepts the header `OFF` (or its variants `COFF`, `NOFF`, `CNOFF`, `STOFF`..., whose
//! extra per-vertex fields are ignored), a header line holding the counts too, or no header at
//! all; `#` comments and blank lines anywhere; and faces with any number of corners, which are
//! taken as convex and triangulated as fans around their first corner (trailing colour fields
//! are ignored). Face order is kept, so the i-th triangle of a triangle-only file is its i-th
//! face — the correspondence the comparison against CGAL relies on. Binary OFF and the `4OFF`
//! and `nOFF` variants are rejected. Every malformed or truncated file gives a `Format` error
//! naming the file and line; nothing in the file can cause a panic or an oversized allocation.
//!
//! Writing uses the shortest decimal form that reads back to the same f64, so a mesh survives a
//! write/read round trip bit for bit.

use std::io::{BufRead, Write};
use std::path::Path;

use glam::DVec3;

use super::files;
use crate::error::{Error, Result};
use crate::mesh::TriMesh;

/// Reads an ASCII OFF file. Its errors name the file and line themselves.
pub fn read(path: &Path) -> Result<TriMesh> {
    let bytes = files::read(path)?;
    parse(&bytes[..], &path.display().to_string())
}

/// Writes an ASCII OFF file with one triangle per face.
pub fn write(path: &Path, mesh: &TriMesh) -> Result<()> {
    files::write(path, |w| write_to(w, mesh))
}

fn write_to(mut out: impl Write, mesh: &TriMesh) -> std::io::Result<()> {
    writeln!(out, "OFF")?;
    writeln!(out, "{} {} 0", mesh.points().len(), mesh.triangles().len())?;
    for p in mesh.points() {
        // `Debug` prints the shortest round-tripping form, switching to exponent notation for
        // very large or small magnitudes (where `Display` would print hundreds of digits).
        writeln!(out, "{:?} {:?} {:?}", p.x, p.y, p.z)?;
    }
    for [a, b, c] in mesh.triangles() {
        writeln!(out, "3 {a} {b} {c}")?;
    }
    out.flush()
}

/// The significant lines of a file: comments stripped, blank lines skipped, numbered.
struct Lines<'n, R> {
    reader: R,
    /// The file name, for messages.
    name: &'n str,
    buffer: String,
    /// The number of the line last read.
    number: usize,
}

/// A line without its comment and surrounding white space.
fn content(line: &str) -> &str {
    line.split('#').next().unwrap_or("").trim()
}

impl<R: BufRead> Lines<'_, R> {
    /// The number of the next line with content and its content; `None` and the number of the
    /// line past the end at the end of the file.
    fn next(&mut self) -> Result<(usize, Option<&str>)> {
        loop {
            self.buffer.clear();
            self.number += 1;
            let read = self.reader.read_line(&mut self.buffer).map_err(|e| {
                let error = if e.kind() == std::io::ErrorKind::InvalidData {
                    Error::format
                } else {
                    Error::io
                };
                error(format!("{}: line {}: {e}", self.name, self.number))
            })?;
            if read == 0 {
                return Ok((self.number, None));
            }
            if !content(&self.buffer).is_empty() {
                return Ok((self.number, Some(content(&self.buffer))));
            }
        }
    }

    /// The next line with content, or an error saying what was expected instead of the end
    /// (described lazily: formatting it for every line would slow reading down).
    fn expect(&mut self, what: impl Fn() -> String) -> Result<(usize, &str)> {
        let name = self.name;
        match self.next()? {
            (number, Some(line)) => Ok((number, line)),
            (number, None) => Err(error_at(
                name,
                number,
                format!(
                    "the file ends where {} was expected; it is truncated",
                    what()
                ),
            )),
        }
    }
}

/// A format error at a line of the file.
fn error_at(name: &str, line: usize, message: impl std::fmt::Display) -> Error {
    Error::format(format!("{name}: line {line}: {message}"))
}

fn parse(reader: impl BufRead, name: &str) -> Result<TriMesh> {
    let mut lines = Lines {
        reader,
        name,
        buffer: String::new(),
        number: 0,
    };
    let (vertex_count, face_count) = header(&mut lines)?;
    // Counts come from the file: grow as lines arrive instead of trusting them for allocation.
    const RESERVE_LIMIT: usize = 1 << 20;
    let mut points = Vec::with_capacity(vertex_count.min(RESERVE_LIMIT));
    for v in 0..vertex_count {
        let (number, line) = lines.expect(|| format!("vertex {v} of {vertex_count}"))?;
        let mut fields = line.split_ascii_whitespace();
        let mut coordinate = |axis: &str| -> Result<f64> {
            let field = fields.next();
            match field.map(str::parse::<f64>) {
                Some(Ok(x)) if x.is_finite() => Ok(x),
                _ => Err(error_at(
                    name,
                    number,
                    format!(
                        "vertex {v} needs a finite {axis} coordinate, found {:?}",
                        field.unwrap_or("nothing")
                    ),
                )),
            }
        };
        let (x, y, z) = (coordinate("x")?, coordinate("y")?, coordinate("z")?);
        points.push(DVec3::new(x, y, z));
    }
    let mut triangles = Vec::with_capacity(face_count.min(RESERVE_LIMIT));
    for f in 0..face_count {
        let (number, line) = lines.expect(|| format!("face {f} of {face_count}"))?;
        let mut fields = line.split_ascii_whitespace();
        let corners = match fields.next().map(str::parse::<usize>) {
            Some(Ok(n)) if n >= 3 => n,
            _ => {
                return Err(error_at(
                    name,
                    number,
                    format!("face {f} must start with its number of corners (at least 3)"),
                ))
            }
        };
        let mut index = || -> Result<u32> {
            match fields.next().map(str::parse::<u32>) {
                Some(Ok(i)) if (i as usize) < vertex_count => Ok(i),
                Some(Ok(i)) => Err(error_at(
                    name,
                    number,
                    format!("face {f} uses vertex {i} but the file has {vertex_count} vertices"),
                )),
                _ => Err(error_at(
                    name,
                    number,
                    format!("face {f} needs {corners} vertex indices (non-negative integers)"),
                )),
            }
        };
        let first = index()?;
        let mut previous = index()?;
        for _ in 2..corners {
            let next = index()?;
            triangles.push([first, previous, next]);
            previous = next;
        }
    }
    TriMesh::new(points, triangles).map_err(|e| e.context(name))
}

/// Reads the header keyword (if any) and the counts line; returns the vertex and face counts.
fn header(lines: &mut Lines<impl BufRead>) -> Result<(usize, usize)> {
    let name = lines.name;
    let (number, first) = lines.expect(|| "the OFF header".into())?;
    let mut fields = first.split_ascii_whitespace();
    let keyword = fields.next().unwrap_or("");
    let (number, counts): (usize, Vec<String>) =
        if keyword.bytes().next().is_some_and(|b| b.is_ascii_digit()) {
            (
                number,
                first.split_ascii_whitespace().map(str::to_string).collect(),
            )
        } else {
            let plain = keyword
                .strip_suffix("OFF")
                .is_some_and(|prefix| prefix.chars().all(|c| "STCN".contains(c)));
            if !plain {
                return Err(error_at(
                    name,
                    number,
                    format!(
                        "expected the header OFF (or COFF, NOFF, STOFF...), found {keyword:?}; \
                         4OFF and nOFF are not supported"
                    ),
                ));
            }
            let rest: Vec<String> = fields.map(str::to_string).collect();
            if rest
                .first()
                .is_some_and(|r| r.eq_ignore_ascii_case("binary"))
            {
                return Err(error_at(
                    name,
                    number,
                    "binary OFF is not supported; convert it to ASCII",
                ));
            }
            if rest.is_empty() {
                let (number, line) = lines.expect(|| "the vertex, face and edge counts".into())?;
                (
                    number,
                    line.split_ascii_whitespace().map(str::to_string).collect(),
                )
            } else {
                (number, rest)
            }
        };
    let count = |i: usize, what: &str| -> Result<usize> {
        counts
            .get(i)
            .and_then(|c| c.parse::<usize>().ok())
            .ok_or_else(|| {
                error_at(
                    name,
                    number,
                    format!("the {what} count must be a non-negative integer"),
                )
            })
    };
    let (vertices, faces) = (count(0, "vertex")?, count(1, "face")?);
    if vertices > u32::MAX as usize {
        return Err(error_at(
            name,
            number,
            format!("{vertices} vertices exceed the 32-bit index range"),
        ));
    }
    Ok((vertices, faces))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ErrorKind;

    fn parse_str(text: &str) -> Result<TriMesh> {
        parse(text.as_bytes(), "test.off")
    }

    fn written(mesh: &TriMesh) -> String {
        let mut bytes = Vec::new();
        write_to(&mut bytes, mesh).unwrap();
        String::from_utf8(bytes).unwrap()
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let points = vec![
            DVec3::new(0.1, -0.0, 1e-300),
            DVec3::new(1e300, -2.5e-7, 123_456_789.123_456_79),
            DVec3::new(f64::MIN_POSITIVE, f64::MAX, -f64::EPSILON),
            DVec3::new(1.0 / 3.0, 2.0f64.sqrt(), -7.0),
        ];
        let mesh = TriMesh::new(points, vec![[0, 1, 2], [2, 1, 3]]).unwrap();
        let back = parse_str(&written(&mesh)).unwrap();
        assert_eq!(back.triangles(), mesh.triangles());
        for (a, b) in back.points().iter().zip(mesh.points()) {
            assert_eq!(
                a.to_array().map(f64::to_bits),
                b.to_array().map(f64::to_bits)
            );
        }
    }

    #[test]
    fn round_trip_through_a_file() {
        let mesh = crate::mesh::test_shapes::icosphere(DVec3::new(1.0, 2.0, 3.0), 4.5, 2);
        let path = std::env::temp_dir().join(format!("balloonseg-off-{}.off", std::process::id()));
        write(&path, &mesh).unwrap();
        let back = read(&path);
        std::fs::remove_file(&path).unwrap();
        assert_eq!(back.unwrap(), mesh);
    }

    #[test]
    fn comments_blank_lines_colours_and_polygons() {
        let text = "# a comment before the header\n\nCOFF\n# counts next\n5 3 0\n\
                    0 0 0 255 0 0 255\n1 0 0  0 255 0 255 # trailing comment\n\n\
                    1 1 0 0 0 255 255\n0 1 0 1 1 1 1\n0.5 0.5 1 0 0 0 0\n\
                    4 0 1 2 3 0.5 0.5 0.5\n3 0 1 4\n5 0 1 2 3 4\n";
        let mesh = parse_str(text).unwrap();
        assert_eq!(mesh.points().len(), 5);
        assert_eq!(
            mesh.triangles(),
            &[
                [0, 1, 2],
                [0, 2, 3],
                [0, 1, 4],
                [0, 1, 2],
                [0, 2, 3],
                [0, 3, 4]
            ]
        );
        assert_eq!(mesh.points()[4], DVec3::new(0.5, 0.5, 1.0));
    }

    #[test]
    fn counts_on_the_header_line_or_no_header() {
        let body = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        for head in ["OFF 3 1 0\n", "3 1 0\n", "OFF\n3 1\n"] {
            let mesh = parse_str(&format!("{head}{body}")).unwrap();
            assert_eq!(mesh.triangles(), &[[0, 1, 2]], "{head}");
        }
    }

    fn format_error(text: &str) -> String {
        let e = parse_str(text).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Format, "{e}");
        assert!(e.message().starts_with("test.off"), "{e}");
        e.message().to_string()
    }

    #[test]
    fn corrupt_files_name_the_line() {
        let e = format_error("PLY\n3 1 0\n");
        assert!(e.contains("line 1") && e.contains("header"), "{e}");
        let e = format_error("OFF BINARY\n");
        assert!(e.contains("binary"), "{e}");
        let e = format_error("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n");
        assert!(e.contains("line 6") && e.contains("vertex 3"), "{e}");
        let e = format_error("OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n");
        assert!(e.contains("line 4") && e.contains("y coordinate"), "{e}");
        let e = format_error("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 inf\n3 0 1 2\n");
        assert!(e.contains("line 5") && e.contains("finite"), "{e}");
        let e = format_error("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n");
        assert!(e.contains("line 6") && e.contains("at least 3"), "{e}");
        let e = format_error("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n");
        assert!(e.contains("needs 4 vertex indices"), "{e}");
        let e = format_error("OFF\n-3 1 0\n");
        assert!(e.contains("vertex count"), "{e}");
        let e = format_error("OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
        assert!(e.contains("line 7: ") && e.contains("face 1 of 2"), "{e}");
        assert!(e.contains("truncated"), "{e}");
        let e = format_error("OFF\n99999999999999 1 0\n0 0 0\n");
        assert!(e.contains("32-bit"), "{e}");
    }

    #[test]
    fn a_huge_count_in_a_short_file_is_an_error_not_an_allocation() {
        let e = format_error("OFF\n4000000000 4000000000000000000 0\n0 0 0\n");
        assert!(e.contains("truncated"), "{e}");
    }

    #[test]
    fn every_truncation_parses_or_fails_cleanly() {
        let text = "OFF\n# cube corner\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n4 0 2 3 1\n";
        let full = parse_str(text).unwrap();
        assert_eq!(full.triangles().len(), 3);
        for cut in 0..text.len() {
            match parse_str(&text[..cut]) {
                Ok(m) => assert_eq!(m, full, "cut at {cut}"),
                Err(e) => assert_eq!(e.kind(), ErrorKind::Format, "cut at {cut}: {e}"),
            }
        }
        // Invalid UTF-8 in the middle of a number.
        let mut bytes = text.as_bytes().to_vec();
        bytes[20] = 0xff;
        let e = parse(bytes.as_slice(), "test.off").unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Format, "{e}");
    }

    #[test]
    fn a_missing_file_is_an_io_error() {
        let e = read(Path::new("/nonexistent/balloonseg/mesh.off")).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::Io);
        assert!(
            e.message().contains("/nonexistent/balloonseg/mesh.off"),
            "{e}"
        );
    }
}
