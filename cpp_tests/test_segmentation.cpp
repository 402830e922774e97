// Segmentation outputs checked by other libraries, and the VTK filter in VTK pipelines.
//
// SegmentationOutputs: each segmentation (sphere, ellipsoid and torus phantoms made here, the vmtk aorta,
// the VTK carotid) through the C ABI must be, for OpenMesh, a closed 2-manifold (every face
// accepted by add_face, no boundary halfedge, every vertex manifold) with the Euler
// characteristic balloon_mesh_check reports; for CGAL closed, bounding a volume, equal in
// volume to our report to 1e-9, and free of self-intersections.
//
// VtkFilter: vtkMetaImageReader -> vtkBalloonSegmentation -> vtkXMLPolyDataWriter on the aorta
// and the carotid gives exactly the C ABI's mesh (the direction matrix is set from the header,
// since Debian's VTK 9.1 reader ignores TransformMatrix); extents that do not start at 0, a
// rotated direction, several components and every scalar type are honoured; progress events
// fire; AbortExecute cancels with an error and an empty output; the filter re-executes when a
// parameter changes and not otherwise; SetSimplificationError gives a smaller surface that
// OpenMesh finds a closed 2-manifold and CGAL free of self-intersections.
//
// VtkFilterObjects: labelled seeds (two balls apart, a bar cut between two objects), a stop seed
// and a region of interest; the "object" cell array holds each triangle's label, every object is
// a closed 2-manifold for OpenMesh and CGAL, the multiblock output has one block per object
// named by its label, and one object without stops or region is the single balloon's mesh.
//
// Each segmentation runs once per process (cached), so this file is one ctest test.
#include "support.h"

#include <vtkBalloonSegmentation.h>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>

#include <vtkCallbackCommand.h>
#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkCompositeDataSet.h>
#include <vtkInformation.h>
#include <vtkIntArray.h>
#include <vtkMultiBlockDataSet.h>
#include <vtkCommand.h>
#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkMatrix3x3.h>
#include <vtkMetaImageReader.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkUnsignedCharArray.h>
#include <vtkXMLMultiBlockDataReader.h>
#include <vtkXMLMultiBlockDataWriter.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLPolyDataWriter.h>

#include <cstdio>
#include <map>

namespace
{
using support::Mesh;

struct OpenMeshTraits : public OpenMesh::DefaultTraits
{
  using Point = OpenMesh::Vec3d;
};
using OMesh = OpenMesh::TriMesh_ArrayKernelT<OpenMeshTraits>;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using CgalMesh = CGAL::Surface_mesh<Kernel::Point_3>;
namespace PMP = CGAL::Polygon_mesh_processing;

// --- Inputs ----------------------------------------------------------------------------------------

// A phantom: an image (u8 values 20 outside, 200 inside) and a seed inside.
struct Phantom
{
  vtkSmartPointer<vtkImageData> image;
  std::array<double, 3> seed;
};

template <class Inside>
Phantom MakePhantom(std::array<int, 3> dims, std::array<double, 3> spacing,
  std::array<double, 3> seed, Inside inside)
{
  Phantom p{ vtkSmartPointer<vtkImageData>::New(), seed };
  p.image->SetDimensions(dims.data());
  p.image->SetSpacing(spacing.data());
  p.image->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  auto* voxels = static_cast<unsigned char*>(p.image->GetScalarPointer());
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i)
      {
        double w[3];
        p.image->TransformIndexToPhysicalPoint(i, j, k, w);
        voxels[(size_t(k) * dims[1] + j) * dims[0] + i] = inside(w[0], w[1], w[2]) ? 200 : 20;
      }
  return p;
}

Phantom SpherePhantom()
{
  return MakePhantom({ 36, 36, 36 }, { 1, 1, 1 }, { 17.5, 17.5, 17.5 },
    [](double x, double y, double z) {
      return (x - 17.5) * (x - 17.5) + (y - 17.5) * (y - 17.5) + (z - 17.5) * (z - 17.5) < 100.0;
    });
}

// An ellipsoid (semi-axes 12, 8, 6 mm) with its axes along the grid's: a direction matrix that
// is ignored or transposed moves or turns it.
Phantom EllipsoidPhantom()
{
  return MakePhantom({ 36, 36, 36 }, { 1, 1, 1 }, { 17.5, 17.5, 17.5 },
    [](double x, double y, double z) {
      const double u = (x - 17.5) / 12.0, v = (y - 17.5) / 8.0, w = (z - 17.5) / 6.0;
      return u * u + v * v + w * w < 1.0;
    });
}

// A torus (ring radius 9 mm, tube radius 3.5 mm) on an anisotropic grid; the balloon grows
// round the ring from one side and meets itself.
Phantom TorusPhantom()
{
  return MakePhantom({ 40, 40, 14 }, { 0.8, 0.8, 1.2 }, { 16.0 + 9.0, 16.0, 7.8 },
    [](double x, double y, double z) {
      const double ring = std::sqrt((x - 16.0) * (x - 16.0) + (y - 16.0) * (y - 16.0)) - 9.0;
      return ring * ring + (z - 7.8) * (z - 7.8) < 3.5 * 3.5;
    });
}

BalloonVolume VolumeOf(vtkImageData* image)
{
  int dims[3];
  image->GetDimensions(dims);
  BalloonVolume v = support::MakeVolume(image->GetScalarPointer(),
    image->GetScalarType() == VTK_FLOAT ? BALLOON_SCALAR_F32 : BALLOON_SCALAR_U8,
    { size_t(dims[0]), size_t(dims[1]), size_t(dims[2]) });
  for (int a = 0; a < 3; ++a)
  {
    v.spacing[a] = image->GetSpacing()[a];
    v.origin[a] = image->GetOrigin()[a];
  }
  std::copy(image->GetDirectionMatrix()->GetData(), image->GetDirectionMatrix()->GetData() + 9,
    v.direction);
  return v;
}

// A real scan read by vtkMetaImageReader, its direction set from the header (ITK meaning).
struct Scan
{
  vtkSmartPointer<vtkImageData> image;
  support::MetaGeometry header;
  std::array<double, 3> seed;
};

Scan ReadScan(const std::string& path, std::array<double, 3> seed)
{
  vtkNew<vtkMetaImageReader> reader;
  reader->SetFileName(path.c_str());
  reader->Update();
  Scan scan{ vtkSmartPointer<vtkImageData>::New(), support::ReadMetaGeometry(path), seed };
  scan.image->ShallowCopy(reader->GetOutput());
  const double* read_direction = reader->GetOutput()->GetDirectionMatrix()->GetData();
  if (!std::equal(read_direction, read_direction + 9, scan.header.direction.begin()))
  {
    std::printf("note: vtkMetaImageReader's direction for %s differs from the header's "
                "TransformMatrix (Debian VTK 9.1 ignores it); using the header's\n",
      path.c_str());
  }
  scan.image->SetDirectionMatrix(scan.header.direction.data());
  for (int a = 0; a < 3; ++a)
  {
    EXPECT_DOUBLE_EQ(scan.image->GetSpacing()[a], scan.header.spacing[a]);
    EXPECT_DOUBLE_EQ(scan.image->GetOrigin()[a], scan.header.origin[a]);
  }
  return scan;
}

// The C ABI on the scan's voxels with the header's geometry (not the VTK image's).
Mesh SegmentScanDirectly(const Scan& scan)
{
  EXPECT_EQ(scan.image->GetScalarType(), VTK_FLOAT);
  const BalloonVolume volume = support::MakeVolume(scan.image->GetScalarPointer(),
    BALLOON_SCALAR_F32, scan.header.dims, scan.header.spacing, scan.header.origin,
    scan.header.direction);
  return support::Segment(volume, { scan.seed });
}

const char* kAorta = "vmtk-aorta/aorta.mha";
const char* kCarotid = "vtk-carotid/carotid.mha";
// The data README's seeds, world mm (voxels (74, 150, 15) and (17, 23, 8), rounded as the Rust
// tests use them).
const std::array<double, 3> kAortaSeed = { -221.484, -156.445, 22.501 };
const std::array<double, 3> kCarotidSeed = { 117.0, 103.0, 9.0 };

// Every segmentation once per process.
const Mesh& Cached(const std::string& key, const std::function<Mesh()>& make)
{
  static std::map<std::string, Mesh> cache;
  auto it = cache.find(key);
  if (it == cache.end())
  {
    const auto start = std::chrono::steady_clock::now();
    it = cache.emplace(key, make()).first;
    std::printf("segmented %s through the C ABI: %zu points, %zu triangles in %.2f s\n",
      key.c_str(), it->second.PointCount(), it->second.TriangleCount(),
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  return it->second;
}

const Mesh& PhantomSegmentation(const std::string& name, const Phantom& p)
{
  return Cached(name, [&] { return support::Segment(VolumeOf(p.image), { p.seed }); });
}

// --- Checks of a segmentation by OpenMesh and CGAL ---------------------------------------------------

void CheckWithOpenMeshAndCgal(const std::string& name, const Mesh& m)
{
  ASSERT_GT(m.TriangleCount(), 100u) << name;
  const BalloonMeshReport report = support::Check(m);
  EXPECT_TRUE(report.closed && report.manifold && report.oriented && report.outward) << name;
  EXPECT_EQ(report.self_intersecting_pairs, 0u) << name;
  EXPECT_TRUE(support::SelfIntersections(m.points, m.triangles).empty()) << name;

  OMesh om;
  std::vector<OMesh::VertexHandle> vh;
  for (size_t p = 0; p < m.PointCount(); ++p)
  {
    vh.push_back(om.add_vertex(OMesh::Point(m.points[3 * p], m.points[3 * p + 1], m.points[3 * p + 2])));
  }
  size_t rejected = 0;
  for (size_t t = 0; t < m.TriangleCount(); ++t)
  {
    const auto f = om.add_face(vh[m.triangles[3 * t]], vh[m.triangles[3 * t + 1]], vh[m.triangles[3 * t + 2]]);
    rejected += f.is_valid() ? 0 : 1;
  }
  EXPECT_EQ(rejected, 0u) << name << ": OpenMesh rejected faces (complex edges or vertices)";
  size_t boundary = 0, nonmanifold = 0;
  for (auto h : om.halfedges())
  {
    boundary += om.is_boundary(h) ? 1 : 0;
  }
  for (auto v : om.vertices())
  {
    nonmanifold += om.is_manifold(v) ? 0 : 1;
  }
  EXPECT_EQ(boundary, 0u) << name;
  EXPECT_EQ(nonmanifold, 0u) << name;
  const long long euler = static_cast<long long>(om.n_vertices()) -
    static_cast<long long>(om.n_edges()) + static_cast<long long>(om.n_faces());
  EXPECT_EQ(euler, report.euler_characteristic) << name;

  CgalMesh cm;
  std::vector<CgalMesh::Vertex_index> cv;
  for (size_t p = 0; p < m.PointCount(); ++p)
  {
    cv.push_back(cm.add_vertex({ m.points[3 * p], m.points[3 * p + 1], m.points[3 * p + 2] }));
  }
  for (size_t t = 0; t < m.TriangleCount(); ++t)
  {
    EXPECT_NE(cm.add_face(cv[m.triangles[3 * t]], cv[m.triangles[3 * t + 1]], cv[m.triangles[3 * t + 2]]),
      CgalMesh::null_face())
      << name << ": CGAL rejected face " << t;
  }
  EXPECT_TRUE(CGAL::is_closed(cm)) << name;
  EXPECT_TRUE(PMP::does_bound_a_volume(cm)) << name;
  EXPECT_FALSE(PMP::does_self_intersect<CGAL::Sequential_tag>(cm)) << name;
  const double volume = CGAL::to_double(PMP::volume(cm));
  EXPECT_NEAR(volume, report.volume_mm3, 1e-9 * std::abs(report.volume_mm3)) << name;
  std::printf("%s: %zu vertices, %zu triangles, Euler characteristic %lld, genus %lld, "
              "%zu component(s), volume %.3f mm^3 (CGAL %.3f)\n",
    name.c_str(), m.PointCount(), m.TriangleCount(), euler,
    static_cast<long long>(report.genus), report.components, report.volume_mm3, volume);
}

TEST(SegmentationOutputs, SpherePhantom)
{
  const Phantom p = SpherePhantom();
  CheckWithOpenMeshAndCgal("sphere phantom", PhantomSegmentation("sphere phantom", p));
}

TEST(SegmentationOutputs, EllipsoidPhantom)
{
  const Phantom p = EllipsoidPhantom();
  CheckWithOpenMeshAndCgal("ellipsoid phantom", PhantomSegmentation("ellipsoid phantom", p));
}

TEST(SegmentationOutputs, TorusPhantom)
{
  const Phantom p = TorusPhantom();
  CheckWithOpenMeshAndCgal("torus phantom", PhantomSegmentation("torus phantom", p));
}

TEST(SegmentationOutputs, Aorta)
{
  REQUIRE_DATA_FILE(path, kAorta);
  const Scan scan = ReadScan(path, kAortaSeed);
  CheckWithOpenMeshAndCgal("aorta", Cached("aorta", [&] { return SegmentScanDirectly(scan); }));
}

TEST(SegmentationOutputs, Carotid)
{
  REQUIRE_DATA_FILE(path, kCarotid);
  const Scan scan = ReadScan(path, kCarotidSeed);
  CheckWithOpenMeshAndCgal("carotid", Cached("carotid", [&] { return SegmentScanDirectly(scan); }));
}

// --- The VTK filter ------------------------------------------------------------------------------------

Mesh FromPolyData(vtkPolyData* pd)
{
  Mesh m;
  m.points.resize(3 * size_t(pd->GetNumberOfPoints()));
  for (vtkIdType p = 0; p < pd->GetNumberOfPoints(); ++p)
  {
    pd->GetPoint(p, &m.points[3 * size_t(p)]);
  }
  vtkNew<vtkIdList> cell;
  for (pd->GetPolys()->InitTraversal(); pd->GetPolys()->GetNextCell(cell);)
  {
    EXPECT_EQ(cell->GetNumberOfIds(), 3);
    for (vtkIdType c = 0; c < cell->GetNumberOfIds(); ++c)
    {
      m.triangles.push_back(uint32_t(cell->GetId(c)));
    }
  }
  if (auto* state = vtkUnsignedCharArray::SafeDownCast(pd->GetPointData()->GetArray("vertex_state")))
  {
    m.state.assign(state->GetPointer(0), state->GetPointer(0) + state->GetNumberOfValues());
  }
  return m;
}

void ExpectSameMesh(const Mesh& a, const Mesh& b, const std::string& what, double tolerance = 0.0)
{
  ASSERT_EQ(a.PointCount(), b.PointCount()) << what;
  ASSERT_EQ(a.triangles, b.triangles) << what;
  EXPECT_EQ(a.state, b.state) << what;
  double worst = 0.0;
  for (size_t c = 0; c < a.points.size(); ++c)
  {
    worst = std::max(worst, std::abs(a.points[c] - b.points[c]));
  }
  EXPECT_LE(worst, tolerance) << what;
}

// Counts the events a filter fires and keeps the last error message.
struct EventLog
{
  int starts = 0;
  int progress = 0;
  int errors = 0;
  std::string last_error;
  std::function<void(vtkBalloonSegmentation*)> on_progress;

  void Watch(vtkBalloonSegmentation* filter)
  {
    for (unsigned long event : { vtkCommand::StartEvent, vtkCommand::ProgressEvent, vtkCommand::ErrorEvent })
    {
      vtkNew<vtkCallbackCommand> callback;
      callback->SetClientData(this);
      callback->SetCallback([](vtkObject* caller, unsigned long id, void* client, void* call) {
        auto* log = static_cast<EventLog*>(client);
        auto* filter = static_cast<vtkBalloonSegmentation*>(caller);
        if (id == vtkCommand::StartEvent)
        {
          ++log->starts;
        }
        else if (id == vtkCommand::ProgressEvent)
        {
          ++log->progress;
          if (log->on_progress)
          {
            log->on_progress(filter);
          }
        }
        else
        {
          ++log->errors;
          log->last_error = call ? static_cast<const char*>(call) : "";
        }
      });
      filter->AddObserver(event, callback);
    }
  }
};

Mesh RunFilter(vtkImageData* image, const std::array<double, 3>& seed, EventLog* log = nullptr)
{
  vtkNew<vtkBalloonSegmentation> filter;
  if (log)
  {
    log->Watch(filter);
  }
  filter->SetInputData(image);
  filter->SetSeed(seed.data());
  filter->SetThreads(2);
  filter->Update();
  return FromPolyData(filter->GetOutput());
}

void FilterMatchesCApi(const char* relative, std::array<double, 3> seed, const std::string& key)
{
  const std::string path = support::DataDir() + "/" + relative;
  const Scan scan = ReadScan(path, seed);
  const Mesh& direct = Cached(key, [&] { return SegmentScanDirectly(scan); });
  ASSERT_GT(direct.TriangleCount(), 0u) << key << ": the C ABI gave no mesh; the filter is not run";

  vtkNew<vtkMetaImageReader> reader;
  reader->SetFileName(path.c_str());
  reader->Update();
  vtkNew<vtkImageData> oriented; // the reader's voxels (not copied), the header's direction
  oriented->ShallowCopy(reader->GetOutput());
  oriented->SetDirectionMatrix(scan.header.direction.data());
  vtkNew<vtkBalloonSegmentation> filter;
  EventLog log;
  log.Watch(filter);
  filter->SetInputData(oriented);
  filter->SetSeed(scan.seed.data());
  filter->SetThreads(2);
  const std::string vtp = key + "-filter.vtp";
  vtkNew<vtkXMLPolyDataWriter> writer;
  writer->SetInputConnection(filter->GetOutputPort());
  writer->SetFileName(vtp.c_str());
  writer->SetDataModeToBinary();
  ASSERT_EQ(writer->Write(), 1);
  ASSERT_EQ(log.errors, 0) << log.last_error;
  EXPECT_GT(log.progress, 2);
  ExpectSameMesh(FromPolyData(filter->GetOutput()), direct, key + ": filter vs C ABI");

  vtkNew<vtkXMLPolyDataReader> back;
  back->SetFileName(vtp.c_str());
  back->Update();
  ASSERT_NE(back->GetOutput()->GetPoints(), nullptr) << vtp << " has no points";
  ExpectSameMesh(FromPolyData(back->GetOutput()), direct, key + ": written .vtp vs C ABI");
  EXPECT_EQ(back->GetOutput()->GetPoints()->GetDataType(), VTK_DOUBLE);

  // The seed is inside the mesh's bounds: the points are in the same world space as the seed,
  // which the direction matrix (diag(-1,-1,1) for the aorta) moves far from an identity's.
  double bounds[6];
  back->GetOutput()->GetBounds(bounds);
  for (int a = 0; a < 3; ++a)
  {
    EXPECT_LE(bounds[2 * a], scan.seed[a]) << key;
    EXPECT_GE(bounds[2 * a + 1], scan.seed[a]) << key;
  }
}

TEST(VtkFilter, AortaMatchesCApi)
{
  REQUIRE_DATA_FILE(path, kAorta);
  FilterMatchesCApi(kAorta, kAortaSeed, "aorta");
}

TEST(VtkFilter, CarotidMatchesCApi)
{
  REQUIRE_DATA_FILE(path, kCarotid);
  FilterMatchesCApi(kCarotid, kCarotidSeed, "carotid");
}

TEST(VtkFilter, PhantomMatchesCApi)
{
  const Phantom p = TorusPhantom();
  ExpectSameMesh(RunFilter(p.image, p.seed), PhantomSegmentation("torus phantom", p), "torus");
}

// SetSimplificationError: the output is the balloon simplified within the bound, with fewer
// triangles, still a closed 2-manifold for OpenMesh and free of self-intersections for CGAL, of
// the same genus, with a state per vertex; 0 gives the balloon as it was; a negative bound is
// the library's error.
TEST(VtkFilter, SimplificationErrorGivesASmallerValidSurface)
{
  const Phantom p = TorusPhantom();
  vtkNew<vtkBalloonSegmentation> filter;
  EventLog log;
  log.Watch(filter);
  filter->SetInputData(p.image);
  filter->SetSeed(p.seed.data());
  filter->SetThreads(2);
  EXPECT_EQ(filter->GetSimplificationError(), 0.0);
  filter->Update();
  const Mesh full = FromPolyData(filter->GetOutput());
  filter->SetSimplificationError(0.2);
  EXPECT_EQ(filter->GetSimplificationError(), 0.2);
  EXPECT_EQ(filter->GetSimplifyErrorMm(), 0.2);
  filter->Update();
  ASSERT_EQ(log.errors, 0) << log.last_error;
  const Mesh simplified = FromPolyData(filter->GetOutput());
  EXPECT_LT(simplified.TriangleCount(), full.TriangleCount());
  EXPECT_EQ(simplified.state.size(), simplified.PointCount());
  CheckWithOpenMeshAndCgal("torus phantom simplified within 0.2 mm", simplified);
  EXPECT_EQ(support::Check(simplified).genus, support::Check(full).genus);

  filter->SetSimplificationError(-1.0);
  filter->Update();
  EXPECT_EQ(log.errors, 1);
  EXPECT_NE(log.last_error.find("simplify_error_mm"), std::string::npos) << log.last_error;
  EXPECT_EQ(filter->GetOutput()->GetNumberOfPoints(), 0);
  filter->SetSimplificationError(0.0);
  filter->Update();
  ExpectSameMesh(FromPolyData(filter->GetOutput()), full, "torus with SimplificationError 0");
}

// The same world geometry expressed with an extent that starts at (7, 3, 0): the same mesh.
TEST(VtkFilter, HonoursExtent)
{
  const Phantom p = SpherePhantom();
  vtkNew<vtkImageData> shifted;
  shifted->ShallowCopy(p.image);
  shifted->SetExtent(7, 7 + 35, 3, 3 + 35, 0, 35);
  shifted->SetOrigin(-7.0, -3.0, 0.0);
  ExpectSameMesh(RunFilter(shifted, p.seed), PhantomSegmentation("sphere phantom", p),
    "extent (7, 3, 0)", 1e-9);
}

// A 90-degree rotation about z and a new origin: the ellipsoid's mesh is the reference mesh
// rotated and moved. Not vertex for vertex (the balloon starts as a small sphere built along the
// world axes, so its triangulation turns with the world, not with the image), but in place,
// extent (the long axis now along y) and volume. An ignored or transposed direction puts the
// seed outside the image.
TEST(VtkFilter, HonoursDirection)
{
  const Phantom p = EllipsoidPhantom();
  const double r[9] = { 0, -1, 0, 1, 0, 0, 0, 0, 1 };
  const double origin[3] = { 5.0, -2.0, 3.0 };
  auto move = [&](const double* q, double* out) {
    for (int row = 0; row < 3; ++row)
    {
      out[row] = origin[row] + r[3 * row] * q[0] + r[3 * row + 1] * q[1] + r[3 * row + 2] * q[2];
    }
  };
  vtkNew<vtkImageData> rotated;
  rotated->ShallowCopy(p.image);
  rotated->SetDirectionMatrix(r);
  rotated->SetOrigin(origin);
  std::array<double, 3> seed;
  move(p.seed.data(), seed.data());
  Mesh expected = PhantomSegmentation("ellipsoid phantom", p);
  for (size_t q = 0; q < expected.PointCount(); ++q)
  {
    const double original[3] = { expected.points[3 * q], expected.points[3 * q + 1], expected.points[3 * q + 2] };
    move(original, &expected.points[3 * q]);
  }
  EventLog log;
  const Mesh m = RunFilter(rotated, seed, &log);
  ASSERT_EQ(log.errors, 0) << log.last_error;
  auto bounds = [](const Mesh& mesh) {
    std::array<double, 6> b{ 1e300, -1e300, 1e300, -1e300, 1e300, -1e300 };
    for (size_t q = 0; q < mesh.PointCount(); ++q)
    {
      for (int a = 0; a < 3; ++a)
      {
        b[2 * a] = std::min(b[2 * a], mesh.points[3 * q + a]);
        b[2 * a + 1] = std::max(b[2 * a + 1], mesh.points[3 * q + a]);
      }
    }
    return b;
  };
  const std::array<double, 6> got = bounds(m), want = bounds(expected);
  for (int e = 0; e < 6; ++e)
  {
    EXPECT_NEAR(got[e], want[e], 0.5) << "bound " << e << " (mm; the voxels are 1 mm)";
  }
  EXPECT_GT(got[3] - got[2], got[1] - got[0] + 6.0) << "the long axis should now lie along y";
  EXPECT_NEAR(support::SignedVolume(m), support::SignedVolume(expected), 0.01 * support::SignedVolume(expected));
}

// Every scalar type the library takes gives the same mesh for the same values (10 outside, 100
// inside: they fit signed char); the first of several components is segmented (the second holds
// the inverted image); other types are refused with an error and an empty output.
TEST(VtkFilter, ScalarTypesAndComponents)
{
  const Phantom p = SpherePhantom();
  auto convert = [&](int type, int components) {
    vtkSmartPointer<vtkImageData> image = vtkSmartPointer<vtkImageData>::New();
    image->CopyStructure(p.image);
    image->AllocateScalars(type, components);
    vtkDataArray* in = p.image->GetPointData()->GetScalars();
    vtkDataArray* out = image->GetPointData()->GetScalars();
    for (vtkIdType v = 0; v < in->GetNumberOfTuples(); ++v)
    {
      const double value = in->GetComponent(v, 0) * 0.5;
      out->SetComponent(v, 0, value);
      for (int c = 1; c < components; ++c)
      {
        out->SetComponent(v, c, c == 1 ? 110.0 - value : 0.0);
      }
    }
    return image;
  };
  const Mesh reference = RunFilter(convert(VTK_UNSIGNED_CHAR, 1), p.seed);
  ASSERT_GT(reference.TriangleCount(), 100u);
  for (int type : { VTK_UNSIGNED_CHAR, VTK_CHAR, VTK_SIGNED_CHAR, VTK_SHORT, VTK_UNSIGNED_SHORT,
         VTK_INT, VTK_UNSIGNED_INT, VTK_FLOAT, VTK_DOUBLE })
  {
    for (int components : { 1, 3 })
    {
      auto image = convert(type, components);
      EventLog log;
      const Mesh m = RunFilter(image, p.seed, &log);
      const std::string what = std::string(image->GetPointData()->GetScalars()->GetDataTypeAsString()) +
        " x" + std::to_string(components);
      EXPECT_EQ(log.errors, 0) << what << ": " << log.last_error;
      ExpectSameMesh(m, reference, what);
    }
  }
  vtkNew<vtkImageData> image;
  image->CopyStructure(p.image);
  image->AllocateScalars(VTK_LONG_LONG, 1);
  image->GetPointData()->GetScalars()->Fill(0);
  EventLog log;
  const Mesh m = RunFilter(image, p.seed, &log);
  EXPECT_EQ(m.TriangleCount(), 0u);
  EXPECT_GE(log.errors, 1);
  EXPECT_NE(log.last_error.find("not supported"), std::string::npos) << log.last_error;
}

TEST(VtkFilter, ErrorsCarryTheLibraryMessage)
{
  const Phantom p = SpherePhantom();
  EventLog log;
  const Mesh m = RunFilter(p.image, { 1000.0, 0.0, 0.0 }, &log); // seed outside the image
  EXPECT_EQ(m.TriangleCount(), 0u);
  EXPECT_GE(log.errors, 1);
  EXPECT_NE(log.last_error.find("balloon_init"), std::string::npos) << log.last_error;
  std::printf("error reported for a seed outside the image: %s\n", log.last_error.c_str());

  vtkNew<vtkBalloonSegmentation> no_seed;
  EventLog log2;
  log2.Watch(no_seed);
  no_seed->SetInputData(p.image);
  no_seed->Update();
  EXPECT_EQ(no_seed->GetOutput()->GetNumberOfPolys(), 0);
  EXPECT_NE(log2.last_error.find("no seed"), std::string::npos) << log2.last_error;
}

TEST(VtkFilter, ProgressAndAbort)
{
  const Phantom p = EllipsoidPhantom();
  vtkNew<vtkBalloonSegmentation> filter;
  EventLog log;
  std::vector<double> fractions;
  log.on_progress = [&](vtkBalloonSegmentation* f) {
    fractions.push_back(f->GetProgress());
    if (f->GetProgress() > 0.0 && f->GetProgress() < 1.0)
    {
      f->AbortExecuteOn();
    }
  };
  log.Watch(filter);
  filter->SetInputData(p.image);
  filter->SetSeed(p.seed.data());
  filter->Update();
  EXPECT_EQ(filter->GetOutput()->GetNumberOfPoints(), 0);
  EXPECT_GE(log.errors, 1);
  EXPECT_NE(log.last_error.find("cancelled"), std::string::npos) << log.last_error;
  EXPECT_TRUE(std::any_of(fractions.begin(), fractions.end(), [](double f) { return f > 0.0 && f < 1.0; }))
    << "no progress inside (0, 1) before the abort";

  // After the abort, a new request (Modified) runs to the end. (The library's fraction is the
  // share of frozen vertices, which may step back when remeshing adds vertices.)
  fractions.clear();
  log.on_progress = [&](vtkBalloonSegmentation* f) { fractions.push_back(f->GetProgress()); };
  log.errors = 0;
  filter->Modified();
  filter->Update();
  EXPECT_EQ(log.errors, 0) << log.last_error;
  EXPECT_GT(filter->GetOutput()->GetNumberOfPolys(), 100);
  EXPECT_GT(fractions.size(), 3u);
  EXPECT_TRUE(std::all_of(fractions.begin(), fractions.end(), [](double f) { return f >= 0.0 && f <= 1.0; }));
  EXPECT_DOUBLE_EQ(fractions.back(), 1.0);
}

TEST(VtkFilter, ReexecutesOnlyWhenSomethingChanged)
{
  const Phantom p = SpherePhantom();
  vtkNew<vtkBalloonSegmentation> filter;
  EventLog log;
  log.Watch(filter);
  filter->SetInputData(p.image);
  filter->SetSeed(p.seed.data());
  filter->Update();
  ASSERT_EQ(log.starts, 1);
  const vtkIdType triangles = filter->GetOutput()->GetNumberOfPolys();
  EXPECT_GT(triangles, 100);

  filter->Update();
  filter->SetSeed(p.seed.data());
  filter->SetElasticWeight(filter->GetElasticWeight());
  filter->SetReferenceIntensity(filter->GetReferenceIntensity()); // NaN again
  filter->SetTolerance(filter->GetTolerance());
  filter->Update();
  EXPECT_EQ(log.starts, 1) << "an unchanged pipeline re-executed";

  filter->SetEdgeLengthMm(2.0);
  filter->Update();
  EXPECT_EQ(log.starts, 2) << "changing a parameter did not re-execute";
  EXPECT_LT(filter->GetOutput()->GetNumberOfPolys(), triangles) << "a coarser edge length";

  filter->AddSeed(17.5, 17.5, 15.0);
  filter->Update();
  EXPECT_EQ(log.starts, 3);
  filter->RemoveAllSeeds();
  EXPECT_EQ(filter->GetNumberOfSeeds(), 0);
  p.image->Modified();
  filter->SetSeed(p.seed.data());
  filter->Update();
  EXPECT_EQ(log.starts, 4) << "a modified input did not re-execute";

  std::ostringstream printed;
  filter->Print(printed);
  EXPECT_NE(printed.str().find("EdgeLengthMm: 2"), std::string::npos) << printed.str();
  EXPECT_NE(printed.str().find("MaxVertices: 1000000\n"), std::string::npos)
    << "whole-number parameters print as integers";
}
// --- Several objects -----------------------------------------------------------------------------

// Two bright balls (radius 4.5 mm) apart along x, centres (8, 12, 12) and (21, 12, 12).
Phantom TwoBallsPhantom()
{
  return MakePhantom({ 30, 24, 24 }, { 1, 1, 1 }, { 8.0, 12.0, 12.0 },
    [](double x, double y, double z) {
      auto in = [&](double c) { return (x - c) * (x - c) + (y - 12) * (y - 12) + (z - 12) * (z - 12) <= 4.5 * 4.5; };
      return in(8.0) || in(21.0);
    });
}

// One bright bar along x (x = 4..25, y and z = 4..11): two seeds in it give objects that meet.
Phantom BarPhantom()
{
  return MakePhantom({ 30, 16, 16 }, { 1, 1, 1 }, { 8.0, 7.5, 7.5 },
    [](double x, double y, double z) {
      return x >= 4 && x <= 25 && y >= 4 && y <= 11 && z >= 4 && z <= 11;
    });
}

std::vector<int> ObjectArray(vtkPolyData* pd)
{
  auto* object = vtkIntArray::SafeDownCast(pd->GetCellData()->GetArray("object"));
  EXPECT_NE(object, nullptr) << "no Int32 cell array \"object\"";
  if (!object)
  {
    return {};
  }
  EXPECT_EQ(object->GetNumberOfValues(), pd->GetNumberOfPolys());
  return std::vector<int>(object->GetPointer(0), object->GetPointer(0) + object->GetNumberOfValues());
}

// The blocks of port 1: count, names (the labels) and their order.
std::vector<std::string> BlockNames(vtkMultiBlockDataSet* blocks)
{
  std::vector<std::string> names;
  for (unsigned int b = 0; b < blocks->GetNumberOfBlocks(); ++b)
  {
    names.push_back(blocks->HasMetaData(b) && blocks->GetMetaData(b)->Has(vtkCompositeDataSet::NAME())
        ? blocks->GetMetaData(b)->Get(vtkCompositeDataSet::NAME())
        : "(no name)");
  }
  return names;
}

double MinX(const Mesh& m)
{
  double x = 1e300;
  for (size_t p = 0; p < m.PointCount(); ++p)
    x = std::min(x, m.points[3 * p]);
  return x;
}

double MaxX(const Mesh& m)
{
  double x = -1e300;
  for (size_t p = 0; p < m.PointCount(); ++p)
    x = std::max(x, m.points[3 * p]);
  return x;
}

// Labels 7 then 3: port 0 holds object 7's triangles then object 3's, with the "object" array;
// port 1 two blocks named "7" and "3", each the part of port 0 with its label, closed and valid.
TEST(VtkFilterObjects, TwoBallsObjectArrayAndBlocks)
{
  const Phantom p = TwoBallsPhantom();
  vtkNew<vtkBalloonSegmentation> filter;
  EventLog log;
  log.Watch(filter);
  filter->SetInputData(p.image);
  filter->AddLabelledSeed(7, 21.0, 12.0, 12.0);
  filter->AddLabelledSeed(3, 8.0, 12.0, 12.0);
  filter->SetReferenceIntensity(200.0);
  filter->SetTolerance(100.0);
  filter->SetThreads(2);
  EXPECT_EQ(filter->GetNumberOfObjects(), 2);
  EXPECT_EQ(filter->GetSeedLabel(0), 7u);
  EXPECT_EQ(filter->GetSeedLabel(2), 0u);
  filter->Update();
  ASSERT_EQ(log.errors, 0) << log.last_error;
  EXPECT_GT(log.progress, 2);
  EXPECT_EQ(filter->GetNumberOfOutputPorts(), 2);

  vtkPolyData* all = filter->GetOutput();
  const std::vector<int> labels = ObjectArray(all);
  ASSERT_FALSE(labels.empty());
  const auto sevens = std::count(labels.begin(), labels.end(), 7);
  const auto threes = std::count(labels.begin(), labels.end(), 3);
  EXPECT_GT(sevens, 100);
  EXPECT_GT(threes, 100);
  EXPECT_EQ(sevens + threes, static_cast<long>(labels.size()));
  EXPECT_TRUE(std::is_sorted(labels.begin(), labels.end(), std::greater<int>()))
    << "object 7's triangles first, then object 3's";

  vtkMultiBlockDataSet* blocks = filter->GetMultiBlockOutput();
  ASSERT_NE(blocks, nullptr);
  EXPECT_EQ(blocks->GetNumberOfBlocks(), 2u);
  EXPECT_EQ(BlockNames(blocks), (std::vector<std::string>{ "7", "3" }));
  vtkIdType points = 0, triangles = 0;
  for (unsigned int b = 0; b < blocks->GetNumberOfBlocks(); ++b)
  {
    auto* block = vtkPolyData::SafeDownCast(blocks->GetBlock(b));
    ASSERT_NE(block, nullptr);
    const int label = b == 0 ? 7 : 3;
    const std::vector<int> own = ObjectArray(block);
    EXPECT_TRUE(std::all_of(own.begin(), own.end(), [&](int l) { return l == label; }));
    const Mesh m = FromPolyData(block);
    CheckWithOpenMeshAndCgal("two balls, object " + std::to_string(label), m);
    EXPECT_EQ(m.state.size(), m.PointCount());
    const double centre = label == 7 ? 21.0 : 8.0;
    EXPECT_LT(MinX(m), centre);
    EXPECT_GT(MaxX(m), centre);
    EXPECT_LT(MaxX(m) - MinX(m), 11.0) << "object " << label << " left its ball";
    // Port 0 is the blocks one after the other (point ids shifted).
    for (vtkIdType q = 0; q < block->GetNumberOfPoints(); ++q)
    {
      double a[3], c[3];
      block->GetPoint(q, a);
      all->GetPoint(points + q, c);
      ASSERT_TRUE(a[0] == c[0] && a[1] == c[1] && a[2] == c[2]) << "point " << q;
    }
    points += block->GetNumberOfPoints();
    triangles += block->GetNumberOfPolys();
  }
  EXPECT_EQ(points, all->GetNumberOfPoints());
  EXPECT_EQ(triangles, all->GetNumberOfPolys());

  // The multiblock port in a pipeline: a .vtm (one .vtp per object) read back with its names.
  vtkNew<vtkXMLMultiBlockDataWriter> writer;
  writer->SetInputConnection(filter->GetMultiBlockOutputPort());
  writer->SetFileName("two-balls-objects.vtm");
  ASSERT_EQ(writer->Write(), 1);
  vtkNew<vtkXMLMultiBlockDataReader> reader;
  reader->SetFileName("two-balls-objects.vtm");
  reader->Update();
  auto* back = vtkMultiBlockDataSet::SafeDownCast(reader->GetOutputDataObject(0));
  ASSERT_NE(back, nullptr);
  EXPECT_EQ(BlockNames(back), (std::vector<std::string>{ "7", "3" }));
  ExpectSameMesh(FromPolyData(vtkPolyData::SafeDownCast(back->GetBlock(1))),
    FromPolyData(vtkPolyData::SafeDownCast(blocks->GetBlock(1))), "object 3 written and read");

  std::ostringstream printed;
  filter->Print(printed);
  EXPECT_NE(printed.str().find("Seed labels: 7 3"), std::string::npos) << printed.str();
}

// Two objects in one bar stop at each other: each stays on its side, and neither is empty.
TEST(VtkFilterObjects, ObjectsInOneBarStopAtEachOther)
{
  const Phantom p = BarPhantom();
  vtkNew<vtkBalloonSegmentation> filter;
  EventLog log;
  log.Watch(filter);
  filter->SetInputData(p.image);
  filter->SetSeed(8.0, 7.5, 7.5); // object 1
  filter->AddLabelledSeed(2, 21.0, 7.5, 7.5);
  filter->SetReferenceIntensity(200.0);
  filter->SetTolerance(100.0);
  filter->SetThreads(2);
  filter->Update();
  ASSERT_EQ(log.errors, 0) << log.last_error;
  vtkMultiBlockDataSet* blocks = filter->GetMultiBlockOutput();
  ASSERT_EQ(blocks->GetNumberOfBlocks(), 2u);
  EXPECT_EQ(BlockNames(blocks), (std::vector<std::string>{ "1", "2" }));
  const Mesh one = FromPolyData(vtkPolyData::SafeDownCast(blocks->GetBlock(0)));
  const Mesh two = FromPolyData(vtkPolyData::SafeDownCast(blocks->GetBlock(1)));
  CheckWithOpenMeshAndCgal("bar, object 1", one);
  CheckWithOpenMeshAndCgal("bar, object 2", two);
  // Each on its own side of the contact (which need not be flat), and no crossing (CGAL, on
  // port 0's two objects together).
  EXPECT_LT(MaxX(one), MinX(two) + 2.0) << "the objects overlap along the bar";
  const Mesh both = FromPolyData(filter->GetOutput());
  ASSERT_EQ(both.TriangleCount(), one.TriangleCount() + two.TriangleCount());
  CgalMesh cm;
  std::vector<CgalMesh::Vertex_index> cv;
  for (size_t q = 0; q < both.PointCount(); ++q)
  {
    cv.push_back(cm.add_vertex({ both.points[3 * q], both.points[3 * q + 1], both.points[3 * q + 2] }));
  }
  for (size_t t = 0; t < both.TriangleCount(); ++t)
  {
    ASSERT_NE(cm.add_face(cv[both.triangles[3 * t]], cv[both.triangles[3 * t + 1]], cv[both.triangles[3 * t + 2]]),
      CgalMesh::null_face());
  }
  EXPECT_FALSE(PMP::does_self_intersect<CGAL::Sequential_tag>(cm)) << "the objects cross";
  EXPECT_LT(MinX(one), 5.0);
  EXPECT_GT(MaxX(two), 24.0);
  const std::vector<int> labels = ObjectArray(filter->GetOutput());
  EXPECT_EQ(std::count(labels.begin(), labels.end(), 1), static_cast<long>(one.TriangleCount()));
  EXPECT_EQ(std::count(labels.begin(), labels.end(), 2), static_cast<long>(two.TriangleCount()));
}

// One object through AddLabelledSeed, without stops or region, is the single balloon: the same
// points, triangles and states as SetSeed, with "object" all equal to its label; a stop seed in
// the other ball changes nothing there but is not in the output; a region cuts the ball.
TEST(VtkFilterObjects, OneObjectStopSeedsAndRegion)
{
  const Phantom p = TwoBallsPhantom();
  const Mesh single = RunFilter(p.image, p.seed);
  ASSERT_GT(single.TriangleCount(), 100u);

  vtkNew<vtkBalloonSegmentation> filter;
  EventLog log;
  log.Watch(filter);
  filter->SetInputData(p.image);
  filter->AddLabelledSeed(5, p.seed.data());
  filter->SetThreads(2);
  filter->Update();
  ASSERT_EQ(log.errors, 0) << log.last_error;
  ExpectSameMesh(FromPolyData(filter->GetOutput()), single, "one labelled object vs SetSeed");
  const std::vector<int> labels = ObjectArray(filter->GetOutput());
  EXPECT_TRUE(std::all_of(labels.begin(), labels.end(), [](int l) { return l == 5; }));
  EXPECT_EQ(BlockNames(filter->GetMultiBlockOutput()), (std::vector<std::string>{ "5" }));
  // SetSeed's output has the same "object" array, label 1.
  vtkNew<vtkBalloonSegmentation> plain;
  plain->SetInputData(p.image);
  plain->SetSeed(p.seed.data());
  plain->SetThreads(2);
  plain->Update();
  const std::vector<int> ones = ObjectArray(plain->GetOutput());
  EXPECT_TRUE(!ones.empty() && std::all_of(ones.begin(), ones.end(), [](int l) { return l == 1; }));

  filter->AddStopSeed(21.0, 12.0, 12.0);
  EXPECT_EQ(filter->GetNumberOfStopSeeds(), 1);
  filter->Update();
  ASSERT_EQ(log.errors, 0) << log.last_error;
  EXPECT_EQ(log.starts, 2);
  const Mesh stopped = FromPolyData(filter->GetOutput());
  EXPECT_EQ(filter->GetMultiBlockOutput()->GetNumberOfBlocks(), 1u) << "the stop seed's balloon is output";
  EXPECT_LT(MaxX(stopped), 14.0);
  CheckWithOpenMeshAndCgal("ball with a stop seed", stopped);

  filter->RemoveAllStopSeeds();
  const double roi[6] = { 0.0, 9.0, 0.0, 23.0, 0.0, 23.0 }; // xmin, xmax, ymin, ymax, zmin, zmax
  filter->SetRegionOfInterest(roi);
  double back[6];
  ASSERT_TRUE(filter->GetRegionOfInterest(back));
  EXPECT_TRUE(std::equal(roi, roi + 6, back));
  filter->Update();
  ASSERT_EQ(log.errors, 0) << log.last_error;
  const Mesh cut = FromPolyData(filter->GetOutput());
  EXPECT_LT(MaxX(cut), 9.6) << "the balloon grew beyond the region's xmax";
  EXPECT_LT(MinX(cut), 5.0);
  EXPECT_GT(MaxX(single), 12.0);
  CheckWithOpenMeshAndCgal("ball cut by a region", cut);

  filter->ClearRegionOfInterest();
  EXPECT_FALSE(filter->HasRegionOfInterest());
  filter->Update();
  ExpectSameMesh(FromPolyData(filter->GetOutput()), single, "region cleared");
}

TEST(VtkFilterObjects, ErrorsCarryTheLibraryMessage)
{
  const Phantom p = TwoBallsPhantom();
  vtkNew<vtkBalloonSegmentation> filter;
  EventLog log;
  log.Watch(filter);
  filter->SetInputData(p.image);
  filter->AddLabelledSeed(0, 8.0, 12.0, 12.0); // label 0 is refused by the library
  filter->AddLabelledSeed(2, 21.0, 12.0, 12.0);
  filter->Update();
  EXPECT_EQ(filter->GetOutput()->GetNumberOfPolys(), 0);
  EXPECT_EQ(filter->GetMultiBlockOutput()->GetNumberOfBlocks(), 0u);
  EXPECT_GE(log.errors, 1);
  EXPECT_NE(log.last_error.find("balloon_segment_objects"), std::string::npos) << log.last_error;
  std::printf("error reported for label 0: %s\n", log.last_error.c_str());

  filter->RemoveAllSeeds();
  filter->AddLabelledSeed(1, 8.0, 12.0, 12.0);
  filter->SetRegionOfInterest(10.0, 20.0, 0.0, 23.0, 0.0, 23.0); // the seed is outside
  log.errors = 0;
  filter->Update();
  EXPECT_GE(log.errors, 1);
  EXPECT_EQ(filter->GetOutput()->GetNumberOfPolys(), 0);
  EXPECT_NE(log.last_error.find("balloon_segment_objects"), std::string::npos) << log.last_error;
  std::printf("error reported for a seed outside the region: %s\n", log.last_error.c_str());
}
} // namespace
