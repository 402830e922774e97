//! PLY meshes (Stanford polygon format), ASCII and binary of either byte order.
//!
//! Reading takes the `vertex` element's x, y, z (any numeric type) and the `face` element's
//! `vertex_indices` (or `vertex_index`) list, with any count and index types; every other
//! element and property, lists included, is skipped. Writing stores binary little endian with
//! double coordinates, point data as extra vertex properties, `uchar`/`uint` face lists and
//! cell data as `int` face properties after the list.
//!
//! Ours rather than `ply-rs-bw` (4.0), measured in BENCHMARKS.md ("io: our readers against the
//! crates"): it covers the same encodings and list types but stores every element as a hash map
//! of properties, which takes 5.6 (ASCII) to 11.6 (binary) times our time, and it needs Rust
//! 1.87 (ours 1.80); on 2000 mutations each of three files neither reader panicked, aborted or
//! hung.

use std::io::Write;
use std::path::Path;

use glam::DVec3;

use super::files;
use super::point_data::{self, CellData, PointData, PointValues};
use super::polygons;
use super::scan::{self, Cursor, Encoding, NumType};
use crate::error::{Error, Result};
use crate::mesh::TriMesh;

/// Reads the vertices and faces of a PLY file.
pub fn read(path: &Path) -> Result<TriMesh> {
    files::parse_file(path, parse)
}

/// Writes binary little-endian PLY; each point data array becomes a vertex property.
pub fn write(path: &Path, mesh: &TriMesh, point_data: &[PointData]) -> Result<()> {
    write_with_cells(path, mesh, point_data, &[])
}

/// [`write`] with each cell data array as an `int` face property.
pub fn write_with_cells(
    path: &Path,
    mesh: &TriMesh,
    point_data: &[PointData],
    cell_data: &[CellData],
) -> Result<()> {
    point_data::check(mesh, point_data, &["x", "y", "z"])?;
    // Readers, ours included, look for the face list under either name.
    point_data::check_cells(mesh, cell_data, &["vertex_indices", "vertex_index"])?;
    files::write(path, |w| write_to(w, mesh, point_data, cell_data))
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Scalar(NumType),
    List { count: NumType, item: NumType },
}

#[derive(Debug)]
struct Property<'a> {
    name: &'a [u8],
    kind: Kind,
}

#[derive(Debug)]
struct Element<'a> {
    name: &'a [u8],
    count: usize,
    properties: Vec<Property<'a>>,
}

fn num_type(word: &[u8]) -> Result<NumType> {
    Ok(match word {
        b"char" | b"int8" => NumType::I8,
        b"uchar" | b"uint8" => NumType::U8,
        b"short" | b"int16" => NumType::I16,
        b"ushort" | b"uint16" => NumType::U16,
        b"int" | b"int32" => NumType::I32,
        b"uint" | b"uint32" => NumType::U32,
        b"float" | b"float32" => NumType::F32,
        b"double" | b"float64" => NumType::F64,
        _ => {
            return Err(Error::format(format!(
                "unknown PLY property type {}",
                scan::show(word)
            )))
        }
    })
}

/// Parses the header up to `end_header`, leaving `cursor` at the first byte of the body.
fn header<'a>(cursor: &mut Cursor<'a>) -> Result<(Encoding, Vec<Element<'a>>)> {
    if cursor.line().map(<[u8]>::trim_ascii) != Some(b"ply") {
        return Err(Error::format(
            "not a PLY file: the first line must be \"ply\"",
        ));
    }
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let line = cursor
            .line()
            .ok_or_else(|| Error::format("the PLY header has no end_header line"))?;
        let mut words = Cursor::new(line);
        let Some(keyword) = words.word() else {
            continue;
        };
        match keyword {
            b"end_header" => break,
            b"comment" | b"obj_info" => {}
            b"format" => {
                encoding = Some(match words.expect_word()? {
                    b"ascii" => Encoding::Text,
                    b"binary_little_endian" => Encoding::Binary { big_endian: false },
                    b"binary_big_endian" => Encoding::Binary { big_endian: true },
                    other => {
                        return Err(Error::format(format!(
                            "unknown PLY format {}",
                            scan::show(other)
                        )))
                    }
                })
            }
            b"element" => {
                let name = words.expect_word()?;
                let count = words.number("element count")?;
                elements.push(Element {
                    name,
                    count,
                    properties: Vec::new(),
                });
            }
            b"property" => {
                let element = elements
                    .last_mut()
                    .ok_or_else(|| Error::format("a PLY property comes before any element"))?;
                let first = words.expect_word()?;
                let kind = if first == b"list" {
                    Kind::List {
                        count: num_type(words.expect_word()?)?,
                        item: num_type(words.expect_word()?)?,
                    }
                } else {
                    Kind::Scalar(num_type(first)?)
                };
                let name = words.expect_word()?;
                element.properties.push(Property { name, kind });
            }
            other => {
                return Err(Error::format(format!(
                    "unknown PLY header keyword {}",
                    scan::show(other)
                )))
            }
        }
    }
    let encoding = encoding.ok_or_else(|| Error::format("the PLY header has no format line"))?;
    Ok((encoding, elements))
}

/// One number of type `ty`.
#[inline]
fn value(cursor: &mut Cursor, ty: NumType, encoding: Encoding) -> Result<f64> {
    match encoding {
        Encoding::Text => scan::text_number(cursor.expect_word()?, ty, "property value"),
        Encoding::Binary { big_endian } => Ok(ty.decode(cursor.take(ty.size())?, big_endian)),
    }
}

/// The length of a list property, checked against the bytes left.
fn list_length(cursor: &mut Cursor, count: NumType, item: NumType, e: Encoding) -> Result<usize> {
    let n = value(cursor, count, e)?;
    if !(n >= 0.0 && n.fract() == 0.0 && n <= u32::MAX as f64) {
        return Err(Error::format(format!("list length {n} is not a count")));
    }
    let n = n as usize;
    let min_bytes = match e {
        Encoding::Text => 1,
        Encoding::Binary { .. } => item.size(),
    };
    cursor.check_room(n, min_bytes, "list entries")?;
    Ok(n)
}

/// Reads one element instance; `keep` gets each scalar property's index and value, and
/// `list` each list property's index and items (skipped lists are consumed without a call).
fn instance(
    cursor: &mut Cursor,
    element: &Element,
    encoding: Encoding,
    wanted_list: Option<usize>,
    mut keep: impl FnMut(usize, f64),
    list: &mut Vec<u32>,
) -> Result<()> {
    for (p, property) in element.properties.iter().enumerate() {
        match property.kind {
            Kind::Scalar(ty) => keep(p, value(cursor, ty, encoding)?),
            Kind::List { count, item } => {
                let n = list_length(cursor, count, item, encoding)?;
                if wanted_list == Some(p) {
                    list.clear();
                    for _ in 0..n {
                        list.push(polygons::index(value(cursor, item, encoding)?)?);
                    }
                } else if let Encoding::Binary { .. } = encoding {
                    cursor.take(n * item.size())?;
                } else {
                    for _ in 0..n {
                        cursor.expect_word()?;
                    }
                }
            }
        }
    }
    Ok(())
}

fn min_instance_bytes(element: &Element, encoding: Encoding) -> usize {
    element
        .properties
        .iter()
        .map(|p| match (encoding, p.kind) {
            (Encoding::Text, _) => 1,
            (_, Kind::Scalar(ty)) => ty.size(),
            (_, Kind::List { count, .. }) => count.size(),
        })
        .sum()
}

pub(crate) fn parse(bytes: &[u8]) -> Result<TriMesh> {
    let mut cursor = Cursor::new(bytes);
    let (encoding, elements) = header(&mut cursor)?;
    let mut points = Vec::new();
    let mut triangles = Vec::new();
    let mut list = Vec::new();
    for element in &elements {
        if element.properties.is_empty() {
            continue;
        }
        let name = String::from_utf8_lossy(element.name);
        let instances = format!("{name} elements");
        cursor.check_room(
            element.count,
            min_instance_bytes(element, encoding),
            &instances,
        )?;
        let position = |axis: &[u8]| element.properties.iter().position(|p| p.name == axis);
        let at = |i: usize, e: Error| e.context(format!("{name} {i} of {}", element.count));
        match element.name {
            b"vertex" => {
                let missing = |axis| Error::format(format!("the vertex element has no {axis}"));
                let x = position(b"x").ok_or_else(|| missing("x"))?;
                let y = position(b"y").ok_or_else(|| missing("y"))?;
                let z = position(b"z").ok_or_else(|| missing("z"))?;
                points.reserve(element.count);
                for i in 0..element.count {
                    let mut p = DVec3::ZERO;
                    instance(
                        &mut cursor,
                        element,
                        encoding,
                        None,
                        |k, v| match k {
                            k if k == x => p.x = v,
                            k if k == y => p.y = v,
                            k if k == z => p.z = v,
                            _ => {}
                        },
                        &mut list,
                    )
                    .map_err(|e| at(i, e))?;
                    points.push(p);
                }
            }
            b"face" => {
                let indices = position(b"vertex_indices")
                    .or_else(|| position(b"vertex_index"))
                    .filter(|&p| matches!(element.properties[p].kind, Kind::List { .. }))
                    .ok_or_else(|| Error::format("the face element has no vertex_indices list"))?;
                triangles.reserve(element.count);
                for i in 0..element.count {
                    instance(
                        &mut cursor,
                        element,
                        encoding,
                        Some(indices),
                        |_, _| {},
                        &mut list,
                    )
                    .map_err(|e| at(i, e))?;
                    polygons::push_polygon(&mut triangles, &list);
                }
            }
            _ => {
                for i in 0..element.count {
                    instance(&mut cursor, element, encoding, None, |_, _| {}, &mut list)
                        .map_err(|e| at(i, e))?;
                }
            }
        }
    }
    polygons::mesh(points, triangles)
}

fn write_to(
    w: &mut impl Write,
    mesh: &TriMesh,
    point_data: &[PointData],
    cell_data: &[CellData],
) -> std::io::Result<()> {
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by balloonseg\n\
         element vertex {}\nproperty double x\nproperty double y\nproperty double z\n",
        mesh.points().len()
    );
    for data in point_data {
        let ty = match data.values {
            PointValues::U8(_) => "uchar",
            PointValues::F64(_) => "double",
        };
        header += &format!("property {ty} {}\n", data.name);
    }
    header += &format!(
        "element face {}\nproperty list uchar uint vertex_indices\n",
        mesh.triangles().len()
    );
    for data in cell_data {
        header += &format!("property int {}\n", data.name);
    }
    header += "end_header\n";
    w.write_all(header.as_bytes())?;
    for (i, p) in mesh.points().iter().enumerate() {
        for x in p.to_array() {
            w.write_all(&x.to_le_bytes())?;
        }
        for data in point_data {
            match data.values {
                PointValues::U8(v) => w.write_all(&[v[i]])?,
                PointValues::F64(v) => w.write_all(&v[i].to_le_bytes())?,
            }
        }
    }
    for (t, triangle) in mesh.triangles().iter().enumerate() {
        let mut face = [3u8; 13];
        for (k, v) in triangle.iter().enumerate() {
            face[1 + 4 * k..5 + 4 * k].copy_from_slice(&v.to_le_bytes());
        }
        w.write_all(&face)?;
        for data in cell_data {
            w.write_all(&data.values[t].to_le_bytes())?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::test_support::assert_never_panics;
    use super::*;
    use crate::mesh::test_shapes::{cube, icosphere};

    fn to_bytes(mesh: &TriMesh, point_data: &[PointData]) -> Vec<u8> {
        let mut bytes = Vec::new();
        write_to(&mut bytes, mesh, point_data, &[]).unwrap();
        bytes
    }

    #[test]
    fn empty_mesh_round_trips() {
        assert_eq!(
            parse(&to_bytes(&TriMesh::default(), &[])).unwrap(),
            TriMesh::default()
        );
    }

    #[test]
    fn round_trip_with_point_data_is_bit_exact() {
        let mesh = icosphere(DVec3::new(1.0 / 3.0, -2.5, 1e4), 0.7, 2);
        let n = mesh.points().len();
        let state: Vec<u8> = (0..n).map(|i| (i % 3) as u8).collect();
        let dist: Vec<f64> = (0..n).map(|i| i as f64 / 7.0).collect();
        let data = [
            PointData {
                name: "state",
                values: PointValues::U8(&state),
            },
            PointData {
                name: "distance",
                values: PointValues::F64(&dist),
            },
        ];
        let bytes = to_bytes(&mesh, &data);
        assert_eq!(parse(&bytes).unwrap(), mesh);
    }

    #[test]
    fn cell_data_are_int_face_properties_after_the_list() {
        let mesh = icosphere(DVec3::new(0.5, 0.25, -1.0), 3.0, 1);
        let m = mesh.triangles().len();
        let object: Vec<i32> = (0..m as i32).map(|t| t / 10).collect();
        let extremes: Vec<i32> = (0..m).map(|t| [i32::MIN, -1, i32::MAX][t % 3]).collect();
        let state = vec![1u8; mesh.points().len()];
        let point_data = [PointData {
            name: "object",
            values: PointValues::U8(&state),
        }];
        let cell_data = [
            CellData {
                name: "object",
                values: &object,
            },
            CellData {
                name: "extremes",
                values: &extremes,
            },
        ];
        let mut bytes = Vec::new();
        write_to(&mut bytes, &mesh, &point_data, &cell_data).unwrap();
        assert_eq!(parse(&bytes).unwrap(), mesh);
        let mut cursor = Cursor::new(&bytes);
        let (encoding, elements) = header(&mut cursor).unwrap();
        let [vertex, face] = &elements[..] else {
            panic!("{elements:?}")
        };
        let properties: Vec<(&[u8], Kind)> =
            face.properties.iter().map(|p| (p.name, p.kind)).collect();
        let list = Kind::List {
            count: NumType::U8,
            item: NumType::U32,
        };
        let int = Kind::Scalar(NumType::I32);
        assert_eq!(
            properties,
            [
                (&b"vertex_indices"[..], list),
                (b"object", int),
                (b"extremes", int)
            ]
        );
        let mut corners = Vec::new();
        for _ in 0..vertex.count {
            instance(&mut cursor, vertex, encoding, None, |_, _| {}, &mut corners).unwrap();
        }
        let mut values = [Vec::new(), Vec::new()];
        for triangle in mesh.triangles() {
            let keep = |p: usize, v: f64| values[p - 1].push(v as i32);
            instance(&mut cursor, face, encoding, Some(0), keep, &mut corners).unwrap();
            assert_eq!(corners, triangle);
        }
        assert_eq!(cursor.remaining(), 0);
        assert_eq!(values, [object, extremes]);
    }

    #[test]
    fn ascii_with_other_elements_lists_and_types() {
        let text = b"ply\r\nformat ascii 1.0\r\ncomment made by hand\r\n\
            element camera 1\r\nproperty float view\r\nproperty list uchar int junk\r\n\
            element vertex 4\r\nproperty float y\r\nproperty uchar red\r\n\
            property list ushort float extra\r\nproperty double x\r\nproperty short z\r\n\
            element face 1\r\nproperty uchar flags\r\nproperty list uint short vertex_index\r\n\
            end_header\r\n\
            1.5 2 7 8\r\n\
            0 255 0 0.5 0\r\n0 1 2 1 2 1 0\r\n1 3 1 1 1 0\r\n1.25 0 0 0 0\r\n\
            9 4 0 1 2 3\r\n";
        let mesh = parse(text).unwrap();
        assert_eq!(
            mesh.points(),
            &[
                DVec3::new(0.5, 0.0, 0.0),
                DVec3::new(1.0, 0.0, 0.0),
                DVec3::new(1.0, 1.0, 0.0),
                DVec3::new(0.0, 1.25, 0.0)
            ]
        );
        assert_eq!(mesh.triangles(), &[[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn big_endian_float_vertices_and_short_indices() {
        let mut bytes = b"ply\nformat binary_big_endian 1.0\nelement vertex 3\n\
            property float x\nproperty float y\nproperty float z\nelement face 1\n\
            property list uchar ushort vertex_indices\nend_header\n"
            .to_vec();
        for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
            bytes.extend(v.to_be_bytes());
        }
        bytes.push(3);
        for i in [0u16, 1, 2] {
            bytes.extend(i.to_be_bytes());
        }
        let mesh = parse(&bytes).unwrap();
        assert_eq!(mesh.triangles(), &[[0, 1, 2]]);
        assert_eq!(mesh.points()[1], DVec3::X);
    }

    #[test]
    fn errors_name_the_instance() {
        let bytes = to_bytes(&cube(DVec3::ZERO, DVec3::ONE), &[]);
        let e = parse(&bytes[..bytes.len() - 2]).unwrap_err();
        assert!(e.message().starts_with("face 11 of 12: "), "{e}");
        assert!(e.message().contains("truncated"), "{e}");
        let text = b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n\
                     property float y\nproperty float z\nend_header\n0 0 0\n1 1\n";
        let e = parse(text).unwrap_err();
        assert!(e.message().contains("vertex 1 of 2"), "{e}");
        let lying = b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n\
                      property float x\nproperty float y\nproperty float z\nend_header\n";
        let e = parse(lying).unwrap_err();
        assert!(e.message().contains("truncated"), "{e}");
    }

    #[test]
    fn corrupt_files_never_panic() {
        let mesh = cube(DVec3::ZERO, DVec3::ONE);
        let state = [1u8; 8];
        let data = [PointData {
            name: "s",
            values: PointValues::U8(&state),
        }];
        let bytes = to_bytes(&mesh, &data);
        assert!(assert_never_panics(&bytes, 500, parse) > 0);
        let text = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n\
            property float y\nproperty float z\nelement face 1\n\
            property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        assert!(assert_never_panics(text, 500, parse) > 0);
    }
}
