// balloon_marching_cubes against VTK's vtkFlyingEdges3D on the same grids: a torus distance
// field, a gyroid, integer-valued samples exactly at the level, and the vmtk aorta level set.
//
// VTK 9.1 writes float32 points, so the comparison runs in index space (spacing 1, origin 0,
// identity direction), where our vertices rounded to float32 must be exactly VTK's: the same set
// of positions, the same triangles (as corner-position triples; VTK's winding is the reverse of
// ours) and the same area and volume to 1e-6. With a real geometry (the aorta's spacing, origin
// and diag(-1,-1,1) direction) our vertices must be the index-space ones mapped to world, to
// 1e-9 of the spacing. Prints ours/VTK wall-time ratios (2 threads each; no thresholds).
#include "support.h"

#include <vtkFlyingEdges3D.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkMetaImageReader.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSMPTools.h>
#include <vtkCellArray.h>

#include <cstdio>
#include <map>

namespace
{
using support::Mesh;

constexpr int kThreads = 2;

struct Field
{
  std::string name;
  std::array<size_t, 3> dims;
  std::vector<float> values; // i fastest
  double level = 0.0;
};

template <class F>
Field Sample(const std::string& name, size_t n, double lo, double hi, F f)
{
  Field field{ name, { n, n, n }, std::vector<float>(n * n * n), 0.0 };
  const double h = (hi - lo) / double(n - 1);
  for (size_t k = 0; k < n; ++k)
    for (size_t j = 0; j < n; ++j)
      for (size_t i = 0; i < n; ++i)
        field.values[(k * n + j) * n + i] = float(f(lo + h * i, lo + h * j, lo + h * k));
  return field;
}

Field Torus(size_t n)
{
  return Sample("torus " + std::to_string(n) + "^3", n, -1.0, 1.0, [](double x, double y, double z) {
    const double ring = std::sqrt(x * x + y * y) - 0.55;
    return std::sqrt(ring * ring + z * z) - 0.25;
  });
}

Field Gyroid(size_t n, double periods)
{
  return Sample("gyroid " + std::to_string(n) + "^3", n, 0.0, 2.0 * M_PI * periods,
    [](double x, double y, double z) {
      return std::sin(x) * std::cos(y) + std::sin(y) * std::cos(z) + std::sin(z) * std::cos(x);
    });
}

// Integer squared distances: many samples exactly at the level (scikit-image #8116).
Field ExactHits(size_t n)
{
  Field field{ "exact hits", { n, n, n }, std::vector<float>(n * n * n), 49.0 };
  const long c = long(n - 1) / 2;
  for (size_t k = 0; k < n; ++k)
    for (size_t j = 0; j < n; ++j)
      for (size_t i = 0; i < n; ++i)
      {
        const long x = long(i) - c, y = long(j) - c, z = long(k) - c;
        field.values[(k * n + j) * n + i] = float(x * x + y * y + z * z);
      }
  return field;
}

// vtkFlyingEdges3D on the field in index space; the image borrows the field's buffer.
struct VtkRun
{
  Mesh mesh;
  double seconds;
};

VtkRun RunFlyingEdges(Field& field, int repeats, const support::MetaGeometry* geometry = nullptr)
{
  vtkNew<vtkFloatArray> scalars;
  scalars->SetArray(field.values.data(), vtkIdType(field.values.size()), 1);
  vtkNew<vtkImageData> image;
  image->SetDimensions(int(field.dims[0]), int(field.dims[1]), int(field.dims[2]));
  if (geometry)
  {
    image->SetSpacing(geometry->spacing.data());
    image->SetOrigin(geometry->origin.data());
    image->SetDirectionMatrix(geometry->direction.data());
  }
  image->GetPointData()->SetScalars(scalars);
  vtkNew<vtkFlyingEdges3D> contour;
  contour->SetInputData(image);
  contour->SetValue(0, field.level);
  contour->ComputeNormalsOff();
  contour->ComputeGradientsOff();
  contour->ComputeScalarsOff();
  const double seconds = support::BestSeconds(repeats, [&] {
    contour->Modified();
    contour->Update();
  });
  vtkPolyData* out = contour->GetOutput();
  Mesh m;
  m.points.resize(3 * size_t(out->GetNumberOfPoints()));
  for (vtkIdType p = 0; p < out->GetNumberOfPoints(); ++p)
  {
    out->GetPoint(p, &m.points[3 * size_t(p)]);
  }
  EXPECT_TRUE(out->GetNumberOfPoints() == 0 || out->GetPoints()->GetDataType() == VTK_FLOAT)
    << "VTK's points are not float32 any more: compare to 1e-9 directly";
  vtkNew<vtkIdList> cell;
  vtkCellArray* polys = out->GetPolys();
  for (polys->InitTraversal(); polys->GetNextCell(cell);)
  {
    EXPECT_EQ(cell->GetNumberOfIds(), 3);
    for (vtkIdType c = 0; c < 3; ++c)
    {
      m.triangles.push_back(uint32_t(cell->GetId(c)));
    }
  }
  return { m, seconds };
}

using Key = std::array<float, 3>;

std::vector<Key> RoundedPoints(const Mesh& m)
{
  std::vector<Key> keys(m.PointCount());
  for (size_t p = 0; p < keys.size(); ++p)
  {
    keys[p] = { float(m.points[3 * p]), float(m.points[3 * p + 1]), float(m.points[3 * p + 2]) };
  }
  return keys;
}

std::vector<Key> UniqueSorted(std::vector<Key> keys)
{
  std::sort(keys.begin(), keys.end());
  keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
  return keys;
}

// Triangles as sorted, rotation-normalised triples of position ids in `table`.
std::vector<std::array<size_t, 3>> CanonicalTriangles(
  const Mesh& m, const std::vector<Key>& table, bool reverse)
{
  const std::vector<Key> keys = RoundedPoints(m);
  std::vector<std::array<size_t, 3>> out(m.TriangleCount());
  for (size_t t = 0; t < out.size(); ++t)
  {
    std::array<size_t, 3> ids;
    for (int c = 0; c < 3; ++c)
    {
      const Key& k = keys[m.triangles[3 * t + (reverse && c ? 3 - c : c)]];
      ids[c] = size_t(std::lower_bound(table.begin(), table.end(), k) - table.begin());
    }
    std::rotate(ids.begin(), std::min_element(ids.begin(), ids.end()), ids.end());
    out[t] = ids;
  }
  std::sort(out.begin(), out.end());
  return out;
}

double Diagonal(const Field& f)
{
  return std::sqrt(double(f.dims[0] * f.dims[0] + f.dims[1] * f.dims[1] + f.dims[2] * f.dims[2]));
}

// Index space, ours against VTK: the whole comparison, plus the timing line.
Mesh CompareInIndexSpace(Field& field, int repeats)
{
  const BalloonVolume volume =
    support::MakeVolume(field.values.data(), BALLOON_SCALAR_F32, field.dims);
  // Timed: the library call alone (VTK's time likewise covers building its output).
  const double our_seconds = support::BestSeconds(repeats, [&] {
    BalloonTriMesh* out = nullptr;
    EXPECT_EQ(balloon_marching_cubes(&volume, field.level, kThreads, &out), BALLOON_OK);
    balloon_trimesh_free(out);
  });
  const Mesh ours = support::MarchingCubes(volume, field.level, kThreads);
  const VtkRun theirs = RunFlyingEdges(field, repeats);

  EXPECT_EQ(ours.PointCount(), theirs.mesh.PointCount()) << field.name;
  EXPECT_EQ(ours.TriangleCount(), theirs.mesh.TriangleCount()) << field.name;
  const std::vector<Key> table = UniqueSorted(RoundedPoints(theirs.mesh));
  EXPECT_TRUE(UniqueSorted(RoundedPoints(ours)) == table)
    << field.name << ": the vertex positions differ from VTK's";
  // VTK's right-hand normals point towards decreasing values, ours towards increasing ones.
  EXPECT_TRUE(CanonicalTriangles(ours, table, false) == CanonicalTriangles(theirs.mesh, table, true))
    << field.name << ": the triangles differ from VTK's";

  const double area = support::Area(ours), their_area = support::Area(theirs.mesh);
  EXPECT_NEAR(area, their_area, 1e-6 * their_area) << field.name;
  const double volume_scale = std::max(std::abs(support::SignedVolume(theirs.mesh)), their_area * Diagonal(field));
  EXPECT_NEAR(support::SignedVolume(ours), -support::SignedVolume(theirs.mesh), 1e-6 * volume_scale)
    << field.name;

  std::printf("RATIO marching cubes %-18s %9zu triangles: ours %.4f s, vtkFlyingEdges3D %.4f s, "
              "ours/VTK %.2f\n",
    field.name.c_str(), ours.TriangleCount(), our_seconds, theirs.seconds,
    our_seconds / theirs.seconds);
  return ours;
}

class MarchingCubesVsFlyingEdges : public ::testing::Test
{
protected:
  static void SetUpTestSuite()
  {
    vtkSMPTools::Initialize(kThreads);
    std::printf("VTK SMP backend %s with %d threads; ours %d threads\n", vtkSMPTools::GetBackend(),
      vtkSMPTools::GetEstimatedNumberOfThreads(), kThreads);
  }
};

TEST_F(MarchingCubesVsFlyingEdges, Torus)
{
  Field f = Torus(256);
  CompareInIndexSpace(f, 5);
}

TEST_F(MarchingCubesVsFlyingEdges, Gyroid)
{
  Field f = Gyroid(192, 6);
  CompareInIndexSpace(f, 3);
}

TEST_F(MarchingCubesVsFlyingEdges, ExactHits)
{
  Field f = ExactHits(23);
  CompareInIndexSpace(f, 1);
}

TEST_F(MarchingCubesVsFlyingEdges, AortaLevelSet)
{
  REQUIRE_DATA_FILE(path, "vmtk-aorta/aorta-reference-levelset.mha");
  vtkNew<vtkMetaImageReader> reader;
  reader->SetFileName(path.c_str());
  reader->Update();
  vtkImageData* image = reader->GetOutput();
  const support::MetaGeometry geometry = support::ReadMetaGeometry(path);
  ASSERT_EQ(image->GetScalarType(), VTK_FLOAT);
  Field field{ "aorta level set", geometry.dims, {}, 0.0 };
  const auto* voxels = static_cast<const float*>(image->GetScalarPointer());
  field.values.assign(voxels, voxels + geometry.dims[0] * geometry.dims[1] * geometry.dims[2]);
  const Mesh index_mesh = CompareInIndexSpace(field, 5);
  ASSERT_GT(index_mesh.TriangleCount(), 10000u);

  // World geometry: the same vertices, mapped once from index space.
  const BalloonVolume world_volume = support::MakeVolume(field.values.data(), BALLOON_SCALAR_F32,
    geometry.dims, geometry.spacing, geometry.origin, geometry.direction);
  const Mesh world = support::MarchingCubes(world_volume, 0.0, kThreads);
  ASSERT_EQ(world.PointCount(), index_mesh.PointCount());
  ASSERT_EQ(world.TriangleCount(), index_mesh.TriangleCount());
  const double min_spacing = *std::min_element(geometry.spacing.begin(), geometry.spacing.end());
  double worst = 0.0;
  for (size_t p = 0; p < world.PointCount(); ++p)
  {
    for (int r = 0; r < 3; ++r)
    {
      double expected = geometry.origin[r];
      for (int c = 0; c < 3; ++c)
      {
        expected += geometry.direction[3 * r + c] * geometry.spacing[c] * index_mesh.points[3 * p + c];
      }
      worst = std::max(worst, std::abs(world.points[3 * p + r] - expected));
    }
  }
  EXPECT_LE(worst, 1e-9 * min_spacing) << "world vertices are not the index vertices mapped";
  // diag(-1, -1, 1) is a rotation: the world volume is the index volume times the voxel's.
  const double index_volume = support::SignedVolume(index_mesh);
  const double voxel = geometry.spacing[0] * geometry.spacing[1] * geometry.spacing[2];
  EXPECT_NEAR(support::SignedVolume(world), index_volume * voxel, 1e-9 * std::abs(index_volume * voxel));

  // VTK with the same geometry on its image: equal area and enclosed volume.
  const VtkRun theirs = RunFlyingEdges(field, 1, &geometry);
  const double their_area = support::Area(theirs.mesh);
  EXPECT_NEAR(support::Area(world), their_area, 1e-6 * their_area);
  EXPECT_NEAR(std::abs(support::SignedVolume(world)), std::abs(support::SignedVolume(theirs.mesh)),
    1e-6 * std::abs(support::SignedVolume(world)));
}
} // namespace
