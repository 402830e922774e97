//! VTK XML files: PolyData surfaces (`.vtp`, read and written) and ImageData images (`.vti`,
//! read). Array storage (ascii, base64, appended, zlib) is handled by `vtk_xml_data`.
//!
//! PolyData: every Piece's Points and its Polys (fan-triangulated) and Strips; Verts and Lines
//! are ignored. ImageData: Origin, Spacing, the row-major Direction VTK 9 writes, and the
//! extent; voxel (0, 0, 0) is the extent's minimum corner, so the image origin is
//! `Origin + Direction · (Spacing ⊙ extent_min)`. The voxels are the active point scalars (the
//! PointData `Scalars` attribute), else the first point array.
//!
//! The writer stores appended raw data with a UInt64 header and Int64 cells, which VTK reads
//! from 6.2 on, zlib-compressed by default like VTK's own writer. Cell data arrays are Int32
//! CellData arrays, the first marked as the active cell scalars (`Scalars="name"`), as the
//! legacy writer's SCALARS does, so that VTK and ParaView colour by it in both formats.
//!
//! Ours rather than `vtkio` (0.7.0-rc2), measured in BENCHMARKS.md ("io: our readers against
//! the crates"): it cannot read raw appended data (`encoding="raw"`, what this writer and
//! VTK's default appended mode produce), it panics (capacity overflow) on a valid
//! zlib-compressed .vtp from VTK 9 and on 352 of 2000 mutations of it, and it has no
//! ImageData Direction. The XML itself is parsed by quick-xml (xml.rs).

use std::io::Write;
use std::path::Path;

use glam::DVec3;

use super::files;
use super::point_data::{self, CellData, PointData, PointValues};
use super::polygons;
use super::vtk_legacy::image_geometry;
use super::vtk_xml_data::{encode, Storage};
use super::xml::{self, Element};
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::volume::Image;

/// Whether [`write_vtp_with`] compresses the arrays.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Compression {
    /// Raw arrays: the fastest to write and read.
    None,
    /// zlib at its fastest level, in 32 KiB blocks (`vtkZLibDataCompressor`).
    #[default]
    Zlib,
}

/// Reads the surface of a `.vtp` file.
pub fn read_vtp(path: &Path) -> Result<TriMesh> {
    files::parse_file(path, parse_vtp)
}

/// Writes a zlib-compressed `.vtp` file with each point data array as a PointData array.
pub fn write_vtp(path: &Path, mesh: &TriMesh, point_data: &[PointData]) -> Result<()> {
    write_vtp_with(path, mesh, point_data, Compression::default())
}

/// Writes a `.vtp` file with the chosen compression.
pub fn write_vtp_with(
    path: &Path,
    mesh: &TriMesh,
    point_data: &[PointData],
    compression: Compression,
) -> Result<()> {
    write_vtp_with_cells(path, mesh, point_data, &[], compression)
}

/// Writes a `.vtp` file with the chosen compression and each cell data array as an Int32
/// CellData array.
pub fn write_vtp_with_cells(
    path: &Path,
    mesh: &TriMesh,
    point_data: &[PointData],
    cell_data: &[CellData],
    compression: Compression,
) -> Result<()> {
    point_data::check(mesh, point_data, &[])?;
    point_data::check_cells(mesh, cell_data, &[])?;
    files::write(path, |w| {
        write_vtp_to(w, mesh, point_data, cell_data, compression)
    })
}

/// Reads the point scalars of a `.vti` file as an image.
pub fn read_vti(path: &Path) -> Result<Image> {
    files::parse_file(path, parse_vti)
}

/// Parses the XML up to the appended data, if any, and checks the file type.
fn open<'a>(bytes: &'a [u8], kind: &str) -> Result<(Element<'a>, Storage<'a>)> {
    let xml::Document { root, rest } = xml::parse(bytes, Some("AppendedData"))?;
    let appended = match rest {
        None => None,
        Some((tag, rest)) => {
            let data = rest
                .iter()
                .position(|b| !b.is_ascii_whitespace())
                .filter(|&n| rest[n] == b'_')
                .map(|n| &rest[n + 1..])
                .ok_or_else(|| Error::format("AppendedData does not start with '_'"))?;
            Some((tag, data))
        }
    };
    if root.name != "VTKFile" || root.attribute("type") != Some(kind) {
        return Err(Error::format(format!(
            "not a VTK XML {kind} file: the root is <{} type={:?}>",
            root.name,
            root.attribute("type").unwrap_or("")
        )));
    }
    let storage = Storage::new(&root, appended.as_ref().map(|(tag, data)| (tag, *data)))?;
    Ok((root, storage))
}

/// A count attribute, 0 when absent.
fn count_attribute(element: &Element, name: &str) -> Result<usize> {
    element.attribute(name).map_or(Ok(0), |v| {
        v.trim()
            .parse()
            .map_err(|_| Error::format(format!("{name}={v:?} is not a count")))
    })
}

/// The `N` numbers of an attribute, or `default` when it is absent.
fn numbers_attribute<const N: usize>(
    element: &Element,
    name: &str,
    default: [f64; N],
) -> Result<[f64; N]> {
    let Some(text) = element.attribute(name) else {
        return Ok(default);
    };
    let values: Vec<f64> = text
        .split_ascii_whitespace()
        .map(str::parse)
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| Error::format(format!("{name}={text:?} is not a list of numbers")))?;
    values
        .try_into()
        .map_err(|_| Error::format(format!("{name}={text:?} must hold {N} numbers")))
}

fn named_array<'e, 'a>(parent: &'e Element<'a>, name: &str) -> Option<&'e Element<'a>> {
    parent
        .children_named("DataArray")
        .find(|a| a.attribute("Name") == Some(name))
}

pub(crate) fn parse_vtp(bytes: &[u8]) -> Result<TriMesh> {
    let (root, storage) = open(bytes, "PolyData")?;
    let poly = root
        .child("PolyData")
        .ok_or_else(|| Error::format("no <PolyData> element"))?;
    let mut points = Vec::new();
    let mut triangles = Vec::new();
    for (p, piece) in poly.children_named("Piece").enumerate() {
        read_piece(&storage, piece, &mut points, &mut triangles)
            .map_err(|e| e.context(format!("piece {p}")))?;
    }
    polygons::mesh(points, triangles)
}

fn read_piece(
    storage: &Storage,
    piece: &Element,
    points: &mut Vec<DVec3>,
    triangles: &mut Vec<[u32; 3]>,
) -> Result<()> {
    let base = points.len();
    let n = count_attribute(piece, "NumberOfPoints")?;
    if n > 0 {
        let element = piece
            .child("Points")
            .and_then(|p| p.child("DataArray"))
            .ok_or_else(|| Error::format("no Points DataArray"))?;
        let array = storage.array(element)?;
        let xyz = array.numbers()?;
        if array.components != 3 || Some(xyz.len()) != n.checked_mul(3) {
            return Err(Error::format(format!(
                "the Points array holds {} values in {} components; NumberOfPoints={n} needs \
                 {n} × 3",
                xyz.len(),
                array.components
            )));
        }
        points.extend(xyz.chunks_exact(3).map(|p| DVec3::new(p[0], p[1], p[2])));
    }
    for (section, count_name, strips) in [
        ("Polys", "NumberOfPolys", false),
        ("Strips", "NumberOfStrips", true),
    ] {
        let cells = count_attribute(piece, count_name)?;
        if cells == 0 {
            continue;
        }
        let element = piece
            .child(section)
            .ok_or_else(|| Error::format(format!("{count_name}={cells} but no <{section}>")))?;
        let array = |name| {
            named_array(element, name)
                .ok_or_else(|| Error::format(format!("<{section}> has no {name} array")))
                .and_then(|a| storage.array(a))
                .and_then(|a| a.numbers())
        };
        let connectivity = array("connectivity")?;
        let offsets = array("offsets")?;
        if offsets.len() != cells {
            return Err(Error::format(format!(
                "<{section}> has {} offsets for {count_name}={cells}",
                offsets.len()
            )));
        }
        let mut corners = Vec::new();
        let mut start = 0;
        for (c, &end) in offsets.iter().enumerate() {
            let context = |e: Error| e.context(format!("{section} cell {c} of {cells}"));
            let end = polygons::index(end).map_err(context)? as usize;
            let indices = connectivity.get(start..end).ok_or_else(|| {
                context(Error::format(format!(
                    "offsets {start}..{end} are outside the {} connectivity entries",
                    connectivity.len()
                )))
            })?;
            corners.clear();
            for &v in indices {
                let global = polygons::index(v)
                    .ok()
                    .and_then(|v| u32::try_from(base + v as usize).ok())
                    .ok_or_else(|| {
                        context(Error::format(format!("vertex index {v} is out of range")))
                    })?;
                corners.push(global);
            }
            if strips {
                polygons::push_strip(triangles, &corners);
            } else {
                polygons::push_polygon(triangles, &corners);
            }
            start = end;
        }
    }
    Ok(())
}

pub(crate) fn parse_vti(bytes: &[u8]) -> Result<Image> {
    let (root, storage) = open(bytes, "ImageData")?;
    let image = root
        .child("ImageData")
        .ok_or_else(|| Error::format("no <ImageData> element"))?;
    let pieces: Vec<&Element> = image.children_named("Piece").collect();
    let [piece] = pieces[..] else {
        return Err(Error::format(format!(
            "{} pieces; only single-piece images are supported (merge the pieces in VTK first)",
            pieces.len()
        )));
    };
    let whole = numbers_attribute(image, "WholeExtent", [f64::NAN; 6])?;
    let extent = numbers_attribute(piece, "Extent", whole)?;
    let mut dims = [0usize; 3];
    for (axis, d) in dims.iter_mut().enumerate() {
        let (lo, hi) = (extent[2 * axis], extent[2 * axis + 1]);
        let n = hi - lo + 1.0;
        if !(lo.fract() == 0.0 && hi.fract() == 0.0 && n >= 1.0 && n <= u32::MAX as f64) {
            return Err(Error::format(format!(
                "the extent {extent:?} is missing or empty along axis {axis}"
            )));
        }
        *d = n as usize;
    }
    let spacing = numbers_attribute(image, "Spacing", [1.0; 3])?;
    let origin = numbers_attribute(image, "Origin", [0.0; 3])?;
    let direction = numbers_attribute(image, "Direction", [1., 0., 0., 0., 1., 0., 0., 0., 1.])?;
    let point_data = piece
        .child("PointData")
        .ok_or_else(|| Error::format("the piece has no PointData"))?;
    let element = match point_data.attribute("Scalars") {
        Some(name) => named_array(point_data, name),
        None => point_data.child("DataArray"),
    }
    .ok_or_else(|| Error::format("the PointData holds no scalar array"))?;
    let array = storage.array(element)?;
    if array.components != 1 {
        return Err(Error::format(format!(
            "the point scalars have {} components; an image for segmentation needs one",
            array.components
        )));
    }
    let scalar_type = array.ty.scalar_type().ok_or_else(|| {
        Error::format("64-bit integer voxels are not supported; convert to Int32 or Float64")
    })?;
    let count = dims
        .iter()
        .try_fold(1usize, |a, &d| a.checked_mul(d))
        .ok_or_else(|| Error::format(format!("the extent {extent:?} is too large")))?;
    let buffer = array.voxels(count, scalar_type)?;
    let lowest = DVec3::new(extent[0], extent[2], extent[4]);
    let corner = image_geometry(spacing, origin, direction)?.index_to_world(lowest);
    let geometry = image_geometry(spacing, corner.to_array(), direction)?;
    Image::new(buffer, dims, geometry).map_err(|e| Error::format(e.message()))
}

fn escape(name: &str) -> String {
    name.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The concatenated bytes of `count` 8-byte values.
fn le_bytes(count: usize, values: impl Iterator<Item = [u8; 8]>) -> Vec<u8> {
    let mut out = Vec::with_capacity(8 * count);
    for v in values {
        out.extend_from_slice(&v);
    }
    out
}

fn write_vtp_to(
    w: &mut impl Write,
    mesh: &TriMesh,
    point_data: &[PointData],
    cell_data: &[CellData],
    compression: Compression,
) -> std::io::Result<()> {
    let compress = compression == Compression::Zlib;
    let (n, m) = (mesh.points().len(), mesh.triangles().len());
    let mut appended = Vec::new();
    let mut offset = 0;
    let mut array = |attributes: String, raw: Vec<u8>| {
        let pieces = encode(raw, compress);
        let tag = format!("<DataArray {attributes} format=\"appended\" offset=\"{offset}\"/>");
        offset += pieces.iter().map(Vec::len).sum::<usize>();
        appended.extend(pieces);
        tag
    };
    let point_arrays: Vec<String> = point_data
        .iter()
        .map(|data| {
            let (ty, raw) = match data.values {
                PointValues::U8(v) => ("UInt8", v.to_vec()),
                PointValues::F64(v) => (
                    "Float64",
                    le_bytes(v.len(), v.iter().map(|x| x.to_le_bytes())),
                ),
            };
            array(format!("type=\"{ty}\" Name=\"{}\"", escape(data.name)), raw)
        })
        .collect();
    let cell_arrays: Vec<String> = cell_data
        .iter()
        .map(|data| {
            let raw = data.values.iter().flat_map(|v| v.to_le_bytes()).collect();
            array(
                format!("type=\"Int32\" Name=\"{}\"", escape(data.name)),
                raw,
            )
        })
        .collect();
    let coordinates = mesh.points().iter().flat_map(|p| p.to_array());
    let points = array(
        "type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\"".into(),
        le_bytes(3 * n, coordinates.map(f64::to_le_bytes)),
    );
    let indices = mesh.triangles().iter().flatten().map(|&v| v as i64);
    let connectivity = array(
        "type=\"Int64\" Name=\"connectivity\"".into(),
        le_bytes(3 * m, indices.map(i64::to_le_bytes)),
    );
    let ends = (1..=m).map(|t| 3 * t as i64);
    let offsets = array(
        "type=\"Int64\" Name=\"offsets\"".into(),
        le_bytes(m, ends.map(i64::to_le_bytes)),
    );
    let compressor = if compress {
        " compressor=\"vtkZLibDataCompressor\""
    } else {
        ""
    };
    write!(
        w,
        "<?xml version=\"1.0\"?>\n\
         <VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" \
         header_type=\"UInt64\"{compressor}>\n  <PolyData>\n    \
         <Piece NumberOfPoints=\"{n}\" NumberOfVerts=\"0\" NumberOfLines=\"0\" \
         NumberOfStrips=\"0\" NumberOfPolys=\"{m}\">\n      <PointData>\n"
    )?;
    for tag in point_arrays {
        writeln!(w, "        {tag}")?;
    }
    writeln!(w, "      </PointData>")?;
    if let Some(first) = cell_data.first() {
        writeln!(w, "      <CellData Scalars=\"{}\">", escape(first.name))?;
        for tag in cell_arrays {
            writeln!(w, "        {tag}")?;
        }
        writeln!(w, "      </CellData>")?;
    }
    write!(
        w,
        "      <Points>\n        {points}\n      </Points>\n      <Polys>\n        \
         {connectivity}\n        {offsets}\n      </Polys>\n    </Piece>\n  </PolyData>\n  \
         <AppendedData encoding=\"raw\">\n   _"
    )?;
    for block in &appended {
        w.write_all(block)?;
    }
    write!(w, "\n  </AppendedData>\n</VTKFile>\n")
}

#[cfg(test)]
mod tests {
    use super::super::scan::NumType;
    use super::super::test_support::{assert_never_panics, shared_data};
    use super::*;
    use crate::mesh::test_shapes::{cube, icosphere};
    use crate::volume::{ScalarType, VoxelBuffer};
    use base64::engine::general_purpose::STANDARD;
    use base64::Engine;

    fn to_bytes(mesh: &TriMesh, point_data: &[PointData], compression: Compression) -> Vec<u8> {
        let mut bytes = Vec::new();
        write_vtp_to(&mut bytes, mesh, point_data, &[], compression).unwrap();
        bytes
    }

    #[test]
    fn round_trip_is_bit_exact_with_and_without_compression() {
        // Big enough for several 32 KiB compression blocks.
        let mesh = icosphere(DVec3::new(12.5, -1.0 / 3.0, 1e3), 3.7, 4);
        let n = mesh.points().len();
        let state: Vec<u8> = (0..n).map(|i| (i % 5) as u8).collect();
        let dist: Vec<f64> = (0..n).map(|i| (i as f64).ln_1p()).collect();
        let data = [
            PointData {
                name: "state",
                values: PointValues::U8(&state),
            },
            PointData {
                name: "a&b",
                values: PointValues::F64(&dist),
            },
        ];
        for compression in [Compression::None, Compression::Zlib] {
            let bytes = to_bytes(&mesh, &data, compression);
            assert_eq!(parse_vtp(&bytes).unwrap(), mesh, "{compression:?}");
            let empty = TriMesh::default();
            assert_eq!(
                parse_vtp(&to_bytes(&empty, &[], compression)).unwrap(),
                empty
            );
        }
    }

    #[test]
    fn cell_data_are_int32_cell_arrays_the_first_the_active_scalars() {
        let mesh = icosphere(DVec3::new(1.0, 2.0, 3.0), 4.0, 2);
        let m = mesh.triangles().len() as i32;
        let object: Vec<i32> = (0..m).map(|t| t % 3 + 1).collect();
        let extremes: Vec<i32> = (0..m)
            .map(|t| [i32::MIN, i32::MAX, -t, t][t as usize % 4])
            .collect();
        let state = vec![2u8; mesh.points().len()];
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
                name: "a&b",
                values: &extremes,
            },
        ];
        for compression in [Compression::None, Compression::Zlib] {
            let mut bytes = Vec::new();
            write_vtp_to(&mut bytes, &mesh, &point_data, &cell_data, compression).unwrap();
            assert_eq!(parse_vtp(&bytes).unwrap(), mesh, "{compression:?}");
            let (root, storage) = open(&bytes, "PolyData").unwrap();
            let piece = root.child("PolyData").and_then(|p| p.child("Piece"));
            let cells = piece.and_then(|p| p.child("CellData")).unwrap();
            assert_eq!(cells.attribute("Scalars"), Some("object"));
            for data in &cell_data {
                let array = storage
                    .array(named_array(cells, data.name).unwrap())
                    .unwrap();
                assert_eq!(array.ty, NumType::I32);
                let expected: Vec<f64> = data.values.iter().map(|&v| v as f64).collect();
                assert_eq!(array.numbers().unwrap(), expected, "{}", data.name);
            }
            let points = piece.and_then(|p| p.child("PointData")).unwrap();
            let state = storage
                .array(named_array(points, "object").unwrap())
                .unwrap();
            assert_eq!(state.numbers().unwrap(), vec![2.0; mesh.points().len()]);
        }
    }

    #[test]
    fn compressed_output_and_reading_do_not_depend_on_the_thread_count() {
        let mesh = icosphere(DVec3::ZERO, 1.0, 5);
        let run = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let bytes = to_bytes(&mesh, &[], Compression::Zlib);
                let back = parse_vtp(&bytes).unwrap();
                (bytes, back)
            })
        };
        let (one, two) = (run(1), run(2));
        assert!(one.0 == two.0 && one.1 == two.1 && one.1 == mesh);
    }

    /// A VTK XML file with `arrays` (xml, raw little-endian bytes) inline as base64, the header
    /// and data encoded separately (as VTK does) or as one stream.
    fn inline_vtp(points: &[f32], connectivity: &[i32], separately: bool) -> Vec<u8> {
        let encode = |raw: Vec<u8>| {
            let header = (raw.len() as u32).to_le_bytes();
            if separately {
                STANDARD.encode(header) + &STANDARD.encode(&raw)
            } else {
                STANDARD.encode([&header[..], &raw].concat())
            }
        };
        let p = encode(points.iter().flat_map(|v| v.to_le_bytes()).collect());
        let c = encode(connectivity.iter().flat_map(|v| v.to_le_bytes()).collect());
        let o = encode(
            (1..=connectivity.len() / 3)
                .flat_map(|t| (3 * t as i32).to_le_bytes())
                .collect(),
        );
        format!(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\">\n<PolyData>\n\
             <Piece NumberOfPoints=\"{}\" NumberOfPolys=\"{}\">\n<Points>\n\
             <DataArray type=\"Float32\" NumberOfComponents=\"3\" format=\"binary\">\n  {p}\n\
             </DataArray>\n</Points>\n<Polys>\n\
             <DataArray type=\"Int32\" Name=\"connectivity\" format=\"binary\">{c}</DataArray>\n\
             <DataArray type=\"Int32\" Name=\"offsets\" format=\"binary\">{o}</DataArray>\n\
             </Polys>\n</Piece>\n</PolyData>\n</VTKFile>\n",
            points.len() / 3,
            connectivity.len() / 3
        )
        .into_bytes()
    }

    #[test]
    fn inline_base64_decodes_with_header_encoded_separately_or_jointly() {
        let points = [
            0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.1, 0.2, 0.3f32,
        ];
        let connectivity = [0, 1, 2, 0, 2, 3, 1, 3, 2];
        for separately in [true, false] {
            let mesh = parse_vtp(&inline_vtp(&points, &connectivity, separately)).unwrap();
            assert_eq!(mesh.triangles(), &[[0, 1, 2], [0, 2, 3], [1, 3, 2]]);
            assert_eq!(
                mesh.points()[3],
                DVec3::new(0.1f32 as f64, 0.2f32 as f64, 0.3f32 as f64)
            );
        }
    }

    /// Written by VTK 9.7's vtkXMLPolyDataWriter (ascii mode; InformationKey children as VTK
    /// writes them), with a triangle strip and a quad.
    const ASCII_VTP: &[u8] = br#"<?xml version="1.0"?>
<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">
  <PolyData>
    <Piece NumberOfPoints="4" NumberOfVerts="1" NumberOfLines="0" NumberOfStrips="1" NumberOfPolys="1">
      <PointData>
      </PointData>
      <Points>
        <DataArray type="Float32" Name="Points" NumberOfComponents="3" format="ascii" RangeMin="0" RangeMax="1.4142135624">
          0 0 0 1 0 0
          1 1 0 0 1 0
          <InformationKey name="L2_NORM_RANGE" location="vtkDataArray" length="2">
            <Value index="0">
              0
            </Value>
          </InformationKey>
        </DataArray>
      </Points>
      <Verts>
        <DataArray type="Int64" Name="connectivity" format="ascii">3</DataArray>
        <DataArray type="Int64" Name="offsets" format="ascii">1</DataArray>
      </Verts>
      <Strips>
        <DataArray type="Int64" Name="connectivity" format="ascii" RangeMin="0" RangeMax="3">
          0 1 3 2
        </DataArray>
        <DataArray type="Int64" Name="offsets" format="ascii" RangeMin="4" RangeMax="4">
          4
        </DataArray>
      </Strips>
      <Polys>
        <DataArray type="Int64" Name="connectivity" format="ascii">0 1 2 3</DataArray>
        <DataArray type="Int64" Name="offsets" format="ascii">4</DataArray>
      </Polys>
    </Piece>
  </PolyData>
</VTKFile>
"#;

    #[test]
    fn ascii_polys_and_strips_with_information_keys() {
        let mesh = parse_vtp(ASCII_VTP).unwrap();
        assert_eq!(mesh.points().len(), 4);
        assert_eq!(
            mesh.triangles(),
            &[[0, 1, 2], [0, 2, 3], [0, 1, 3], [1, 2, 3]]
        );
    }

    /// Written by VTK 9.7's vtkXMLImageDataWriter: Int16 voxels, extent 1..4 × 0..2 × −1..0,
    /// origin (1, 2, 3), spacing (0.5, 2, 3), direction rows (0 1 0), (−1 0 0), (0 0 1); in
    /// zlib-compressed inline base64 and in appended base64.
    const VTI_BINARY: &str = r#"<?xml version="1.0"?>
<VTKFile type="ImageData" version="0.1" byte_order="LittleEndian" header_type="UInt32" compressor="vtkZLibDataCompressor">
  <ImageData WholeExtent="1 4 0 2 -1 0" Origin="1 2 3" Spacing="0.5 2 3" Direction="0 1 0 -1 0 0 0 0 1">
  <Piece Extent="1 4 0 2 -1 0">
    <PointData Scalars="val">
      <DataArray type="Int16" Name="val" format="binary" RangeMin="-50" RangeMax="180">
        AQAAAACAAAAwAAAAOQAAAA==eJw79//G/0f/3/z/9p+BgYtBhEGOQYPBiMGGwY0hgCGKIYUhj6GCoYmhh2EawwKGVQxbGADw6BAU
      </DataArray>
    </PointData>
    <CellData>
    </CellData>
  </Piece>
  </ImageData>
</VTKFile>
"#;
    const VTI_APPENDED: &str = r#"<?xml version="1.0"?>
<VTKFile type="ImageData" version="0.1" byte_order="LittleEndian" header_type="UInt32" compressor="vtkZLibDataCompressor">
  <ImageData WholeExtent="1 4 0 2 -1 0" Origin="1 2 3" Spacing="0.5 2 3" Direction="0 1 0 -1 0 0 0 0 1">
    <Piece Extent="1 4 0 2 -1 0"                                                      >
      <PointData Scalars="val">
        <DataArray type="Int16" Name="val" format="appended" RangeMin="-50"                  RangeMax="180"                  offset="0"                   >
        </DataArray>
      </PointData>
      <CellData>
      </CellData>
    </Piece>
  </ImageData>
  <AppendedData encoding="base64">
   _AQAAAACAAAAwAAAAOQAAAA==eJw79//G/0f/3/z/9p+BgYtBhEGOQYPBiMGGwY0hgCGKIYUhj6GCoYmhh2EawwKGVQxbGADw6BAU
  </AppendedData>
</VTKFile>
"#;

    #[test]
    fn vti_from_vtk_has_its_voxels_and_oriented_geometry() {
        for text in [VTI_BINARY, VTI_APPENDED] {
            let image = parse_vti(text.as_bytes()).unwrap();
            assert_eq!(image.dims(), [4, 3, 2]);
            let expected: Vec<i16> = (0..24).map(|i| i * 10 - 50).collect();
            assert_eq!(image.buffer(), &VoxelBuffer::I16(expected));
            let g = image.geometry();
            assert_eq!(g.spacing(), [0.5, 2.0, 3.0]);
            assert_eq!(g.direction(), [0., 1., 0., -1., 0., 0., 0., 0., 1.]);
            // Voxel (0,0,0) is extent index (1, 0, -1): Origin + D·(0.5, 0, −3), as VTK 9.7's
            // GetPoint(0) gives.
            assert_eq!(g.origin(), [1.0, 1.5, 0.0]);
            // Extent index (4, 2, 0) is voxel (3, 2, 1): Origin + D·(2, 4, 0) = (5, 0, 3).
            assert_eq!(
                g.index_to_world(DVec3::new(3.0, 2.0, 1.0)),
                DVec3::new(5.0, 0.0, 3.0)
            );
        }
    }

    #[test]
    fn vti_ascii_and_rejections() {
        let vti = |extent: &str, scalars: &str, data: &str| {
            format!(
                "<VTKFile type=\"ImageData\"><ImageData WholeExtent=\"{extent}\">\
                 <Piece><PointData{scalars}>\
                 <DataArray type=\"UInt8\" Name=\"other\" format=\"ascii\">9 9</DataArray>\
                 <DataArray type=\"Float32\" Name=\"v\" format=\"ascii\">{data}</DataArray>\
                 </PointData></Piece></ImageData></VTKFile>"
            )
        };
        let image = parse_vti(vti("0 1 0 0 0 0", " Scalars=\"v\"", "0.1 2").as_bytes()).unwrap();
        assert_eq!(image.buffer(), &VoxelBuffer::F32(vec![0.1, 2.0]));
        assert_eq!(image.scalar_type(), ScalarType::F32);
        let first = parse_vti(vti("0 1 0 0 0 0", "", "1 2").as_bytes()).unwrap();
        assert_eq!(first.buffer(), &VoxelBuffer::U8(vec![9, 9]));
        for (text, needle) in [
            (vti("0 1 0 0 0 0", " Scalars=\"v\"", "1 2 3"), "more than"),
            (vti("0 1 0 0 0 0", " Scalars=\"v\"", "1"), "truncated"),
            (vti("0 -1 0 0 0 0", "", "1 2"), "extent"),
            (vti("0 1 0 0", "", "1 2"), "6 numbers"),
            (vti("0 4e9 0 4e9 0 4e9", "", "1 2"), "too large"),
            (
                vti("0 1 0 0 0 0", " Scalars=\"w\"", "1 2"),
                "no scalar array",
            ),
        ] {
            let e = parse_vti(text.as_bytes()).unwrap_err();
            assert!(e.message().contains(needle), "{needle}: {e}");
        }
        let e = parse_vti(ASCII_VTP).unwrap_err();
        assert!(e.message().contains("ImageData"), "{e}");
    }

    #[test]
    fn lying_block_headers_are_errors() {
        let mesh = cube(DVec3::ZERO, DVec3::ONE);
        let bytes = to_bytes(&mesh, &[], Compression::Zlib);
        let data = bytes.windows(2).position(|w| w == b" _").unwrap() + 2;
        // Words of the Points block header: block count, block size, last block size (the only
        // block is partial), first compressed size.
        for (word, value) in [
            (0usize, u64::MAX),
            (0, 1 << 40),
            (2, u64::MAX),
            (3, 1 << 50),
        ] {
            let mut bad = bytes.clone();
            bad[data + 8 * word..data + 8 * word + 8].copy_from_slice(&value.to_le_bytes());
            let e = parse_vtp(&bad).unwrap_err();
            assert_eq!(e.kind(), crate::ErrorKind::Format, "{e}");
        }
    }

    #[test]
    fn aorta_reference_surface_faces_inward() {
        let Some(path) = shared_data("vmtk-aorta/aorta-reference-surface.vtp") else {
            return;
        };
        let mesh = read_vtp(&path).unwrap();
        assert_eq!(mesh.points().len(), 6468);
        assert_eq!(mesh.triangles().len(), 12932);
        let volume = mesh.signed_volume();
        assert!((volume + 13184.0).abs() < 1.0, "{volume}");
    }

    #[test]
    fn corrupt_files_never_panic() {
        let mesh = cube(DVec3::ZERO, DVec3::ONE);
        let state = [1u8; 8];
        let data = [PointData {
            name: "s",
            values: PointValues::U8(&state),
        }];
        for compression in [Compression::None, Compression::Zlib] {
            let bytes = to_bytes(&mesh, &data, compression);
            assert!(assert_never_panics(&bytes, 500, parse_vtp) > 0);
        }
        assert!(assert_never_panics(ASCII_VTP, 300, parse_vtp) > 0);
        let points = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0f32];
        assert!(assert_never_panics(&inline_vtp(&points, &[0, 1, 2], true), 300, parse_vtp) > 0);
        assert!(assert_never_panics(VTI_BINARY.as_bytes(), 300, parse_vti) > 0);
        assert!(assert_never_panics(VTI_APPENDED.as_bytes(), 300, parse_vti) > 0);
    }
}
