//! Legacy VTK files (`# vtk DataFile Version x.y`), ASCII or BINARY (big endian):
//! STRUCTURED_POINTS images and POLYDATA surfaces.
//!
//! Images: DIMENSIONS, SPACING (or ASPECT_RATIO), ORIGIN and an optional DIRECTION (nine
//! numbers, row-major; VTK's own writer stores none, which means identity), then the first
//! single-component SCALARS of POINT_DATA. Other attributes, CELL_DATA, FIELD data and METADATA
//! blocks are skipped. A negative spacing, which VTK allows, becomes a flipped direction axis.
//!
//! Surfaces: POINTS of any numeric type; POLYGONS (fan-triangulated) and TRIANGLE_STRIPS in
//! both the classic cell-array layout and the OFFSETS/CONNECTIVITY layout of version 5.1;
//! VERTICES and LINES are read past and ignored. The writer stores version 4.2 BINARY with
//! double points, the layout every VTK release reads, and point data as a FIELD of point
//! arrays (VTK's reader loads only the first SCALARS unless told otherwise, but every FIELD
//! array). Of the cell data, the first array is the CELL_DATA SCALARS (`int`), so that it is
//! the active cell scalars as in the .vtp writer, and the others a FIELD of cell arrays.
//!
//! Ours rather than `vtkio` (0.7.0-rc2, a release candidate), measured in
//! BENCHMARKS.md ("io: our readers against the crates"): its model keeps an image's origin and
//! spacing as float32 and has no DIRECTION; it parses a binary POLYDATA into its own model in
//! a quarter of our time (ours also builds and checks the TriMesh), an ASCII one in the same
//! time, a binary image in 1.8 times ours and an ASCII image in 0.4 of it. On 2000 mutations
//! each of five files neither reader panicked, aborted or hung. Its XML side fails outright
//! (see vtk_xml.rs), so it would cover only half of what these two modules read.

use std::io::Write;
use std::path::Path;

use glam::DVec3;

use super::files;
use super::point_data::{self, CellData, PointData, PointValues};
use super::polygons;
use super::scan::{self, Cursor, Encoding, NumType};
use crate::error::{Error, Result};
use crate::geometry::Geometry;
use crate::mesh::TriMesh;
use crate::volume::Image;

/// Reads the POLYDATA surface of a legacy VTK file.
pub fn read_mesh(path: &Path) -> Result<TriMesh> {
    files::parse_file(path, parse_mesh)
}

/// Writes a legacy VTK 4.2 BINARY POLYDATA file; the point data become FIELD point arrays.
pub fn write_mesh(path: &Path, mesh: &TriMesh, point_data: &[PointData]) -> Result<()> {
    write_mesh_with_cells(path, mesh, point_data, &[])
}

/// [`write_mesh`] with cell data: the first array becomes the CELL_DATA SCALARS, the others
/// FIELD cell arrays.
pub fn write_mesh_with_cells(
    path: &Path,
    mesh: &TriMesh,
    point_data: &[PointData],
    cell_data: &[CellData],
) -> Result<()> {
    point_data::check(mesh, point_data, &[])?;
    point_data::check_cells(mesh, cell_data, &[])?;
    check_fits(mesh)?;
    files::write(path, |w| write_mesh_to(w, mesh, point_data, cell_data))
}

/// Reads the first point scalars of a legacy VTK STRUCTURED_POINTS file as an image.
pub fn read_image(path: &Path) -> Result<Image> {
    files::parse_file(path, parse_image)
}

fn is(word: &[u8], keyword: &str) -> bool {
    word.eq_ignore_ascii_case(keyword.as_bytes())
}

fn num_type(word: &[u8]) -> Result<NumType> {
    let lower = word.to_ascii_lowercase();
    Ok(match lower.as_slice() {
        b"unsigned_char" => NumType::U8,
        b"char" | b"signed_char" => NumType::I8,
        b"unsigned_short" => NumType::U16,
        b"short" => NumType::I16,
        b"unsigned_int" => NumType::U32,
        // VTK writes vtkIdType arrays as 32-bit ints in legacy files.
        b"int" | b"vtkidtype" => NumType::I32,
        // `long` is written with the writer's sizeof(long): 8 bytes where VTK files come from
        // (Linux, macOS).
        b"unsigned_long" | b"vtktypeuint64" => NumType::U64,
        b"long" | b"vtktypeint64" => NumType::I64,
        b"float" => NumType::F32,
        b"double" => NumType::F64,
        _ => {
            return Err(Error::format(format!(
                "unsupported data type {}",
                scan::show(word)
            )))
        }
    })
}

/// Reads the four header lines and checks the dataset type; the cursor is left after it.
fn header<'a>(bytes: &'a [u8], dataset: &str) -> Result<(Cursor<'a>, Encoding)> {
    let mut c = Cursor::new(bytes);
    let first = c.line().unwrap_or_default();
    if !first.to_ascii_lowercase().starts_with(b"# vtk datafile") {
        return Err(Error::format(
            "not a legacy VTK file: the first line must be \"# vtk DataFile Version x.y\"",
        ));
    }
    c.line().ok_or_else(scan::eof)?;
    let format = c.expect_word()?;
    let encoding = if is(format, "ascii") {
        Encoding::Text
    } else if is(format, "binary") {
        Encoding::Binary { big_endian: true }
    } else {
        return Err(Error::format(format!(
            "the third line must be ASCII or BINARY, not {}",
            scan::show(format)
        )));
    };
    let keyword = c.expect_word()?;
    let kind = c.expect_word()?;
    if !is(keyword, "dataset") || !is(kind, dataset) {
        return Err(Error::format(format!(
            "expected \"DATASET {dataset}\", found {} {}; this reader handles {dataset} files",
            scan::show(keyword),
            scan::show(kind)
        )));
    }
    Ok((c, encoding))
}

/// Binary data starts after the line that announces it.
fn end_line(c: &mut Cursor, encoding: Encoding) {
    if let Encoding::Binary { .. } = encoding {
        c.line();
    }
}

fn count(value: f64, what: &str) -> Result<usize> {
    if value >= 0.0 && value.fract() == 0.0 && value <= u32::MAX as f64 {
        Ok(value as usize)
    } else {
        Err(Error::format(format!(
            "{what} {value} is not a valid count"
        )))
    }
}

/// A METADATA block: text lines up to an empty line.
fn skip_metadata(c: &mut Cursor) {
    c.line();
    while let Some(line) = c.line() {
        if line.trim_ascii().is_empty() {
            break;
        }
    }
}

/// FIELD data: `FIELD name n` then n arrays `name components tuples type` with their values.
fn skip_field(c: &mut Cursor, encoding: Encoding) -> Result<()> {
    c.expect_word()?;
    let arrays: usize = c.number("field array count")?;
    for a in 0..arrays {
        let name = c.expect_word()?;
        if is(name, "metadata") {
            skip_metadata(c);
            continue;
        }
        let context = |e: Error| e.context(format!("field array {a} of {arrays}"));
        let components: usize = c.number("field array components").map_err(context)?;
        let tuples: usize = c.number("field array tuples").map_err(context)?;
        let ty = num_type(c.expect_word()?).map_err(context)?;
        end_line(c, encoding);
        let values = components.saturating_mul(tuples);
        scan::numbers(c, values, ty, encoding, "field values").map_err(context)?;
    }
    Ok(())
}

/// `SCALARS name type [components]` followed by `LOOKUP_TABLE name`: type and components.
fn scalars_header(c: &mut Cursor) -> Result<(NumType, usize)> {
    c.expect_word()?;
    let ty = num_type(c.expect_word()?)?;
    let mut word = c.expect_word()?;
    let mut components = 1;
    if !is(word, "lookup_table") {
        components = scan::parse(word, "SCALARS components")?;
        word = c.expect_word()?;
    }
    if !is(word, "lookup_table") {
        return Err(Error::format(format!(
            "expected LOOKUP_TABLE after SCALARS, found {}",
            scan::show(word)
        )));
    }
    c.expect_word()?;
    Ok((ty, components))
}

/// Skips the attribute whose keyword was just read, stored for `tuples` points or cells.
fn skip_attribute(c: &mut Cursor, encoding: Encoding, keyword: &[u8], tuples: usize) -> Result<()> {
    // Colours and lookup tables are bytes in binary files and floats in ASCII ones.
    let colour = match encoding {
        Encoding::Text => NumType::F32,
        Encoding::Binary { .. } => NumType::U8,
    };
    let lower = keyword.to_ascii_lowercase();
    let (values, ty) = match lower.as_slice() {
        b"scalars" => {
            let (ty, components) = scalars_header(c)?;
            (tuples.checked_mul(components), ty)
        }
        b"color_scalars" => {
            c.expect_word()?;
            let components: usize = c.number("COLOR_SCALARS components")?;
            (tuples.checked_mul(components), colour)
        }
        b"lookup_table" => {
            c.expect_word()?;
            let size: usize = c.number("LOOKUP_TABLE size")?;
            (size.checked_mul(4), colour)
        }
        b"vectors" | b"normals" | b"tensors" | b"tensors6" | b"global_ids" | b"pedigree_ids" => {
            c.expect_word()?;
            let components = match lower.as_slice() {
                b"vectors" | b"normals" => 3,
                b"tensors" => 9,
                b"tensors6" => 6,
                _ => 1,
            };
            (tuples.checked_mul(components), num_type(c.expect_word()?)?)
        }
        b"texture_coordinates" => {
            c.expect_word()?;
            let dim: usize = c.number("TEXTURE_COORDINATES dimension")?;
            (tuples.checked_mul(dim), num_type(c.expect_word()?)?)
        }
        b"field" => return skip_field(c, encoding),
        b"metadata" => {
            skip_metadata(c);
            return Ok(());
        }
        _ => {
            return Err(Error::format(format!(
                "unknown attribute keyword {}",
                scan::show(keyword)
            )))
        }
    };
    end_line(c, encoding);
    let what = format!("{} values", String::from_utf8_lossy(keyword));
    scan::numbers(c, values.unwrap_or(usize::MAX), ty, encoding, &what)?;
    Ok(())
}

/// The geometry of a VTK image. VTK allows negative spacing; it becomes a flipped axis of the
/// direction matrix. Unusable values are corrupt input, hence format errors.
pub(super) fn image_geometry(
    mut spacing: [f64; 3],
    origin: [f64; 3],
    mut direction: [f64; 9],
) -> Result<Geometry> {
    for (axis, s) in spacing.iter_mut().enumerate() {
        if *s < 0.0 {
            *s = -*s;
            for row in 0..3 {
                direction[3 * row + axis] = -direction[3 * row + axis];
            }
        }
    }
    Geometry::new(spacing, origin, direction).map_err(|e| Error::format(e.message()))
}

fn three(c: &mut Cursor, what: &str) -> Result<[f64; 3]> {
    Ok([c.number(what)?, c.number(what)?, c.number(what)?])
}

pub(crate) fn parse_image(bytes: &[u8]) -> Result<Image> {
    let (mut c, encoding) = header(bytes, "STRUCTURED_POINTS")?;
    let mut dims: Option<[usize; 3]> = None;
    let mut spacing = [1.0; 3];
    let mut origin = [0.0; 3];
    let mut direction = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    // Tuples of the current POINT_DATA / CELL_DATA section, and whether it is point data.
    let mut section: Option<(usize, bool)> = None;
    while let Some(word) = c.word() {
        let lower = word.to_ascii_lowercase();
        match (lower.as_slice(), section) {
            (b"dimensions", _) => {
                dims = Some([
                    c.number("DIMENSIONS")?,
                    c.number("DIMENSIONS")?,
                    c.number("DIMENSIONS")?,
                ])
            }
            (b"spacing" | b"aspect_ratio", _) => spacing = three(&mut c, "SPACING")?,
            (b"origin", _) => origin = three(&mut c, "ORIGIN")?,
            (b"direction", _) => {
                for d in &mut direction {
                    *d = c.number("DIRECTION")?;
                }
            }
            (b"metadata", _) => skip_metadata(&mut c),
            (b"field", None) => skip_field(&mut c, encoding)?,
            (b"point_data" | b"cell_data", _) => {
                let tuples: usize = c.number("attribute count")?;
                section = Some((tuples, lower == b"point_data"));
            }
            (b"scalars", Some((tuples, true))) => {
                let dims = dims.ok_or_else(|| Error::format("POINT_DATA before DIMENSIONS"))?;
                let voxels = dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d));
                if voxels != Some(tuples) {
                    return Err(Error::format(format!(
                        "POINT_DATA {tuples} does not match DIMENSIONS {dims:?}"
                    )));
                }
                let (ty, components) = scalars_header(&mut c)?;
                if components != 1 {
                    return Err(Error::format(format!(
                        "the point SCALARS have {components} components; an image for \
                         segmentation needs one (extract a component first)"
                    )));
                }
                let scalar_type = ty.scalar_type().ok_or_else(|| {
                    Error::format(
                        "64-bit integer voxels are not supported; convert to int or double",
                    )
                })?;
                end_line(&mut c, encoding);
                let buffer = scan::voxels(&mut c, tuples, scalar_type, encoding)?;
                let geometry = image_geometry(spacing, origin, direction)?;
                return Image::new(buffer, dims, geometry).map_err(|e| Error::format(e.message()));
            }
            (_, Some((tuples, _))) => skip_attribute(&mut c, encoding, word, tuples)?,
            _ => {
                return Err(Error::format(format!(
                    "unexpected keyword {} in STRUCTURED_POINTS",
                    scan::show(word)
                )))
            }
        }
    }
    Err(Error::format(
        "no point SCALARS found; the image voxels must be stored as SCALARS in POINT_DATA",
    ))
}

/// Reads a cell section whose keyword was just read, calling `cell` with each cell's vertices.
fn cells(c: &mut Cursor, encoding: Encoding, mut cell: impl FnMut(&[u32])) -> Result<()> {
    let cells: usize = c.number("cell count")?;
    let size: usize = c.number("cell array size")?;
    let mut corners = Vec::new();
    let mut emit = |indices: &[f64]| -> Result<()> {
        corners.clear();
        for &v in indices {
            corners.push(polygons::index(v)?);
        }
        cell(&corners);
        Ok(())
    };
    if c.peek_word().is_some_and(|w| is(w, "offsets")) {
        // Version 5.1: `cells` is the number of offsets (one more than of cells).
        c.word();
        let ty = num_type(c.expect_word()?)?;
        end_line(c, encoding);
        let offsets = scan::numbers(c, cells, ty, encoding, "cell offsets")?;
        let keyword = c.expect_word()?;
        if !is(keyword, "connectivity") {
            return Err(Error::format(format!(
                "expected CONNECTIVITY after OFFSETS, found {}",
                scan::show(keyword)
            )));
        }
        let ty = num_type(c.expect_word()?)?;
        end_line(c, encoding);
        let connectivity = scan::numbers(c, size, ty, encoding, "cell connectivity entries")?;
        if offsets.first().is_some_and(|&o| o != 0.0) {
            return Err(Error::format("the first cell offset must be 0"));
        }
        for (i, pair) in offsets.windows(2).enumerate() {
            let (start, end) = (count(pair[0], "offset")?, count(pair[1], "offset")?);
            if start > end || end > connectivity.len() {
                return Err(Error::format(format!(
                    "cell {i}: offsets {start}..{end} are outside the {} connectivity entries",
                    connectivity.len()
                )));
            }
            emit(&connectivity[start..end]).map_err(|e| e.context(format!("cell {i}")))?;
        }
    } else {
        end_line(c, encoding);
        let values = scan::numbers(c, size, NumType::I32, encoding, "cell array entries")?;
        let mut at = 0;
        for i in 0..cells {
            let n = values
                .get(at)
                .ok_or_else(|| {
                    Error::format(format!("cell {i} of {cells} is beyond the cell array"))
                })
                .and_then(|&n| count(n, "cell size"))?;
            let indices = values.get(at + 1..at + 1 + n).ok_or_else(|| {
                Error::format(format!(
                    "cell {i} of {cells}: {n} vertices overrun the cell array"
                ))
            })?;
            emit(indices).map_err(|e| e.context(format!("cell {i} of {cells}")))?;
            at += 1 + n;
        }
        if at != size {
            return Err(Error::format(format!(
                "{cells} cells use {at} entries of a cell array of {size}"
            )));
        }
    }
    Ok(())
}

pub(crate) fn parse_mesh(bytes: &[u8]) -> Result<TriMesh> {
    let (mut c, encoding) = header(bytes, "POLYDATA")?;
    let mut points = Vec::new();
    let mut triangles = Vec::new();
    while let Some(word) = c.word() {
        let lower = word.to_ascii_lowercase();
        match lower.as_slice() {
            b"points" => {
                let n: usize = c.number("point count")?;
                let ty = num_type(c.expect_word()?)?;
                end_line(&mut c, encoding);
                let values = n.saturating_mul(3);
                let xyz = scan::numbers(&mut c, values, ty, encoding, "point coordinates")?;
                points = xyz
                    .chunks_exact(3)
                    .map(|p| DVec3::new(p[0], p[1], p[2]))
                    .collect();
            }
            b"polygons" => cells(&mut c, encoding, |p| {
                polygons::push_polygon(&mut triangles, p)
            })
            .map_err(|e| e.context("POLYGONS"))?,
            b"triangle_strips" => cells(&mut c, encoding, |s| {
                polygons::push_strip(&mut triangles, s)
            })
            .map_err(|e| e.context("TRIANGLE_STRIPS"))?,
            b"vertices" | b"lines" => cells(&mut c, encoding, |_| {})?,
            b"metadata" => skip_metadata(&mut c),
            b"field" => skip_field(&mut c, encoding)?,
            // Attributes follow the geometry and do not change it.
            b"point_data" | b"cell_data" => break,
            _ => {
                return Err(Error::format(format!(
                    "unexpected keyword {} in POLYDATA",
                    scan::show(word)
                )))
            }
        }
    }
    polygons::mesh(points, triangles)
}

fn check_fits(mesh: &TriMesh) -> Result<()> {
    let size = mesh.triangles().len().checked_mul(4);
    if mesh.points().len() > i32::MAX as usize || size.map_or(true, |s| s > i32::MAX as usize) {
        return Err(Error::invalid_argument(format!(
            "{} points and {} triangles exceed the 32-bit cell arrays of legacy VTK; write .vtp",
            mesh.points().len(),
            mesh.triangles().len()
        )));
    }
    Ok(())
}

/// Big-endian ints followed by the line end that closes a binary block.
fn write_ints(w: &mut impl Write, values: &[i32]) -> std::io::Result<()> {
    for v in values {
        w.write_all(&v.to_be_bytes())?;
    }
    writeln!(w)
}

fn write_mesh_to(
    w: &mut impl Write,
    mesh: &TriMesh,
    point_data: &[PointData],
    cell_data: &[CellData],
) -> std::io::Result<()> {
    let n = mesh.points().len();
    let m = mesh.triangles().len();
    write!(
        w,
        "# vtk DataFile Version 4.2\nballoonseg surface\nBINARY\nDATASET POLYDATA\n\
         POINTS {n} double\n"
    )?;
    for p in mesh.points() {
        for x in p.to_array() {
            w.write_all(&x.to_be_bytes())?;
        }
    }
    write!(w, "\nPOLYGONS {m} {}\n", 4 * m)?;
    for t in mesh.triangles() {
        w.write_all(&3i32.to_be_bytes())?;
        for &v in t {
            w.write_all(&(v as i32).to_be_bytes())?;
        }
    }
    writeln!(w)?;
    if let Some((first, others)) = cell_data.split_first() {
        write!(
            w,
            "CELL_DATA {m}\nSCALARS {} int 1\nLOOKUP_TABLE default\n",
            first.name
        )?;
        write_ints(w, first.values)?;
        if !others.is_empty() {
            writeln!(w, "FIELD FieldData {}", others.len())?;
        }
        for data in others {
            writeln!(w, "{} 1 {m} int", data.name)?;
            write_ints(w, data.values)?;
        }
    }
    if !point_data.is_empty() {
        writeln!(w, "POINT_DATA {n}\nFIELD FieldData {}", point_data.len())?;
    }
    for data in point_data {
        match data.values {
            PointValues::U8(v) => {
                writeln!(w, "{} 1 {n} unsigned_char", data.name)?;
                w.write_all(v)?;
            }
            PointValues::F64(v) => {
                writeln!(w, "{} 1 {n} double", data.name)?;
                for x in v {
                    w.write_all(&x.to_be_bytes())?;
                }
            }
        }
        writeln!(w)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{assert_never_panics, shared_data};
    use super::*;
    use crate::mesh::test_shapes::{cube, icosphere};
    use crate::volume::{ScalarType, VoxelBuffer};

    fn to_bytes(mesh: &TriMesh, point_data: &[PointData]) -> Vec<u8> {
        let mut bytes = Vec::new();
        write_mesh_to(&mut bytes, mesh, point_data, &[]).unwrap();
        bytes
    }

    #[test]
    fn empty_mesh_round_trips() {
        assert_eq!(
            parse_mesh(&to_bytes(&TriMesh::default(), &[])).unwrap(),
            TriMesh::default()
        );
    }

    #[test]
    fn mesh_round_trip_with_point_data_is_bit_exact() {
        let mesh = icosphere(DVec3::new(-3.3, 1.0 / 7.0, 250.0), 4.1, 2);
        let state = vec![2u8; mesh.points().len()];
        let dist: Vec<f64> = (0..mesh.points().len())
            .map(|i| (i as f64).sqrt())
            .collect();
        let data = [
            PointData {
                name: "state",
                values: PointValues::U8(&state),
            },
            PointData {
                name: "d",
                values: PointValues::F64(&dist),
            },
        ];
        assert_eq!(parse_mesh(&to_bytes(&mesh, &data)).unwrap(), mesh);
    }

    #[test]
    fn cell_data_are_cell_scalars_then_a_cell_field_before_the_point_data() {
        let mesh = icosphere(DVec3::ZERO, 2.0, 1);
        let m = mesh.triangles().len();
        let object: Vec<i32> = (0..m as i32).map(|t| t % 4 - 1).collect();
        let extremes: Vec<i32> = (0..m).map(|t| [i32::MIN, i32::MAX, 0][t % 3]).collect();
        let state = vec![7u8; mesh.points().len()];
        let point_data = [PointData {
            name: "state",
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
        write_mesh_to(&mut bytes, &mesh, &point_data, &cell_data).unwrap();
        assert_eq!(parse_mesh(&bytes).unwrap(), mesh);
        // The attributes follow the geometry, which is all a file without them holds.
        let geometry = to_bytes(&mesh, &[]);
        assert_eq!(bytes[..geometry.len()], geometry[..]);
        let mut c = Cursor::new(&bytes[geometry.len()..]);
        let binary = Encoding::Binary { big_endian: true };
        fn words(c: &mut Cursor, n: usize) -> Vec<String> {
            let words = (0..n).map(|_| c.expect_word().unwrap());
            words.map(|w| String::from_utf8_lossy(w).into()).collect()
        }
        let cells = format!("{m}");
        let scalars = ["CELL_DATA", &cells, "SCALARS", "object", "int", "1"];
        let table = ["LOOKUP_TABLE", "default"];
        assert_eq!(words(&mut c, 8), [&scalars[..], &table].concat());
        end_line(&mut c, binary);
        let values = scan::numbers(&mut c, m, num_type(b"int").unwrap(), binary, "object");
        assert_eq!(
            values.unwrap(),
            object.iter().map(|&v| v as f64).collect::<Vec<_>>()
        );
        let field = ["FIELD", "FieldData", "1", "extremes", "1", &cells, "int"];
        assert_eq!(words(&mut c, 7), field);
        end_line(&mut c, binary);
        let values = scan::numbers(&mut c, m, NumType::I32, binary, "extremes");
        assert_eq!(
            values.unwrap(),
            extremes.iter().map(|&v| v as f64).collect::<Vec<_>>()
        );
        assert_eq!(c.word(), Some(&b"POINT_DATA"[..]));
    }

    /// A unit square as one quad, a triangle strip over it and metadata, as VTK 9 writes 5.1.
    const ASCII_51: &[u8] = b"# vtk DataFile Version 5.1\nvtk output\nASCII\nDATASET POLYDATA\n\
        FIELD FieldData 1\nTimeValue 1 1 double\n0.5\n\
        POINTS 4 float\n0 0 0 1 0 0 1 1 0\n0 1 0\n\nMETADATA\nINFORMATION 1\n\
        NAME L2_NORM_RANGE LOCATION vtkDataArray\nDATA 2 0 1.41421\n\n\
        VERTICES 2 1\nOFFSETS vtktypeint64\n0 1\nCONNECTIVITY vtktypeint64\n3\n\
        POLYGONS 2 4\nOFFSETS vtktypeint64\n0 4\nCONNECTIVITY vtktypeint64\n0 1 2 3\n\
        TRIANGLE_STRIPS 2 4\nOFFSETS vtktypeint64\n0 4\nCONNECTIVITY vtktypeint64\n0 1 3 2\n\
        POINT_DATA 4\nNORMALS Normals float\n0 0 1 0 0 1 0 0 1 0 0 1\n";

    #[test]
    fn vtk_51_ascii_polygons_strips_field_and_metadata() {
        let mesh = parse_mesh(ASCII_51).unwrap();
        assert_eq!(mesh.points().len(), 4);
        assert_eq!(
            mesh.triangles(),
            &[[0, 1, 2], [0, 2, 3], [0, 1, 3], [1, 2, 3]]
        );
        assert!((mesh.area() - 2.0).abs() < 1e-12);
    }

    #[test]
    fn vtk_51_binary_with_int64_offsets() {
        let mut bytes = b"# vtk DataFile Version 5.1\nvtk output\nBINARY\nDATASET POLYDATA\n\
            POINTS 3 float\n"
            .to_vec();
        for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
            bytes.extend(v.to_be_bytes());
        }
        bytes.extend(b"\nPOLYGONS 2 3\nOFFSETS vtktypeint64\n");
        for v in [0i64, 3] {
            bytes.extend(v.to_be_bytes());
        }
        bytes.extend(b"\nCONNECTIVITY vtktypeint64\n");
        for v in [2i64, 1, 0] {
            bytes.extend(v.to_be_bytes());
        }
        bytes.push(b'\n');
        let mesh = parse_mesh(&bytes).unwrap();
        assert_eq!(mesh.triangles(), &[[2, 1, 0]]);
        assert_eq!(mesh.points()[1], DVec3::X);
    }

    #[test]
    fn classic_cell_arrays_must_add_up() {
        let text = b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n\
            POINTS 4 double\n0 0 0 1 0 0 1 1 0 0 1 0\nPOLYGONS 1 5\n4 0 1 2 3\n";
        assert_eq!(parse_mesh(text).unwrap().triangles().len(), 2);
        let short = b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n\
            POINTS 4 double\n0 0 0 1 0 0 1 1 0 0 1 0\nPOLYGONS 1 4\n4 0 1 2 3\n";
        let e = parse_mesh(short).unwrap_err();
        assert!(e.message().contains("POLYGONS: cell 0 of 1"), "{e}");
        let out_of_range = b"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n\
            POINTS 3 double\n0 0 0 1 0 0 1 1 0\nPOLYGONS 1 4\n3 0 1 3\n";
        let e = parse_mesh(out_of_range).unwrap_err();
        assert!(e.message().contains("3 points"), "{e}");
    }

    #[test]
    fn image_skips_cell_data_field_and_vectors_and_flips_negative_spacing() {
        let text = b"# vtk DataFile Version 3.0\nimage\nASCII\nDATASET STRUCTURED_POINTS\n\
            DIMENSIONS 3 2 1\nASPECT_RATIO 0.5 -2 1\nORIGIN 1 2 3\n\
            CELL_DATA 2\nSCALARS c int 1\nLOOKUP_TABLE default\n7 8\n\
            POINT_DATA 6\nFIELD f 1\narr 2 6 float\n0 0 0 0 0 0 0 0 0 0 0 0\n\
            VECTORS v double\n0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0\n\
            COLOR_SCALARS rgb 3\n0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0\n\
            SCALARS val short 1\nLOOKUP_TABLE default\n-1 2 -3 4 -5 6\n\
            SCALARS second float\nLOOKUP_TABLE default\n0 0 0 0 0 0\n";
        let image = parse_image(text).unwrap();
        assert_eq!(image.dims(), [3, 2, 1]);
        assert_eq!(image.buffer(), &VoxelBuffer::I16(vec![-1, 2, -3, 4, -5, 6]));
        let g = image.geometry();
        assert_eq!(g.spacing(), [0.5, 2.0, 1.0]);
        assert_eq!(
            g.index_to_world(DVec3::new(2.0, 1.0, 0.0)),
            DVec3::new(2.0, 0.0, 3.0)
        );
    }

    #[test]
    fn image_direction_line_and_binary_voxels() {
        let mut bytes = b"# vtk DataFile Version 3.0\nimage\nBINARY\nDATASET STRUCTURED_POINTS\n\
            DIMENSIONS 2 1 1\nSPACING 1 1 1\nORIGIN 0 0 0\nDIRECTION 0 -1 0 1 0 0 0 0 1\n\
            POINT_DATA 2\nSCALARS s unsigned_short\nLOOKUP_TABLE default\n"
            .to_vec();
        bytes.extend([0x01, 0x02, 0xff, 0x00]);
        let image = parse_image(&bytes).unwrap();
        assert_eq!(image.buffer(), &VoxelBuffer::U16(vec![0x0102, 0xff00]));
        let i_axis = image.geometry().index_to_world(DVec3::X);
        assert_eq!(i_axis, DVec3::Y);
    }

    #[test]
    fn images_that_cannot_be_segmented_are_rejected_with_the_reason() {
        let head = "# vtk DataFile Version 3.0\ni\nASCII\nDATASET STRUCTURED_POINTS\n\
                    DIMENSIONS 2 1 1\n";
        for (body, needle) in [
            (
                "POINT_DATA 3\nSCALARS s float\nLOOKUP_TABLE default\n1 2 3\n",
                "does not match",
            ),
            (
                "POINT_DATA 2\nSCALARS s float 3\nLOOKUP_TABLE default\n1 2 3 4 5 6\n",
                "3 components",
            ),
            (
                "POINT_DATA 2\nVECTORS v float\n1 2 3 4 5 6\n",
                "no point SCALARS",
            ),
            (
                "SPACING 0 1 1\nPOINT_DATA 2\nSCALARS s float\nLOOKUP_TABLE default\n1 2\n",
                "spacing",
            ),
            (
                "POINT_DATA 2\nSCALARS s float\nLOOKUP_TABLE default\n1\n",
                "end of file",
            ),
        ] {
            let e = parse_image(format!("{head}{body}").as_bytes()).unwrap_err();
            assert!(e.message().contains(needle), "{needle}: {e}");
        }
        let e = parse_image(ASCII_51).unwrap_err();
        assert!(e.message().contains("STRUCTURED_POINTS"), "{e}");
    }

    #[test]
    fn carotid_reads_with_its_geometry_and_matches_the_metaimage() {
        let Some(path) = shared_data("vtk-carotid/carotid.vtk") else {
            return;
        };
        let image = read_image(&path).unwrap();
        assert_eq!(image.dims(), [76, 49, 45]);
        assert_eq!(image.scalar_type(), ScalarType::F32);
        assert_eq!(image.geometry().spacing(), [1.0; 3]);
        assert_eq!(image.geometry().origin(), [100.0, 80.0, 1.0]);
        let seed = image.view().get_f64(17, 23, 8);
        assert!((272.0..=431.0).contains(&seed), "{seed}");
        let Some(mha) = shared_data("vtk-carotid/carotid.mha") else {
            return;
        };
        // The MetaImage holds the same float32 voxels, zlib-compressed after its text header.
        let mha = std::fs::read(mha).unwrap();
        let marker = b"ElementDataFile = LOCAL\n";
        let start = mha.windows(marker.len()).position(|w| w == marker).unwrap() + marker.len();
        let mut raw = Vec::new();
        std::io::Read::read_to_end(&mut flate2::read::ZlibDecoder::new(&mha[start..]), &mut raw)
            .unwrap();
        assert_eq!(image.buffer().to_le_bytes(), raw);
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
        assert!(assert_never_panics(&bytes, 500, parse_mesh) > 0);
        assert!(assert_never_panics(ASCII_51, 500, parse_mesh) > 0);
        let mut image = b"# vtk DataFile Version 3.0\ni\nBINARY\nDATASET STRUCTURED_POINTS\n\
            DIMENSIONS 2 2 1\nSPACING 1 1 1\nORIGIN 0 0 0\nPOINT_DATA 4\n\
            VECTORS v float\n"
            .to_vec();
        image.extend([0u8; 48]);
        image.extend(b"\nSCALARS s float 1\nLOOKUP_TABLE default\n");
        image.extend([0x3f, 0x80, 0, 0].repeat(4));
        assert!(parse_image(&image).is_ok());
        assert!(assert_never_panics(&image, 500, parse_image) > 0);
    }
}
