// Shared helpers of the C++ tests: the real-data folder, C ABI calls wrapped into owned meshes,
// MetaImage header geometry, timing.
#pragma once

#include <balloonseg.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <sys/stat.h>
#include <vector>

namespace support
{

// An owned triangle mesh as the C ABI returns it.
struct Mesh
{
  std::vector<double> points;      // x, y, z per point, world mm
  std::vector<uint32_t> triangles; // 3 per triangle
  std::vector<uint8_t> state;      // one per point (segmentations only)
  size_t PointCount() const { return points.size() / 3; }
  size_t TriangleCount() const { return triangles.size() / 3; }
};

inline std::string LastError(BalloonStatus status)
{
  std::string message(balloon_last_error_message(nullptr, 0) + 1, '\0');
  balloon_last_error_message(&message[0], message.size());
  message.resize(message.size() - 1);
  return std::string(balloon_status_string(status)) + ": " + message;
}

// A volume over a contiguous, i-fastest buffer.
inline BalloonVolume MakeVolume(const void* data, BalloonScalarType type,
  std::array<size_t, 3> dims, std::array<double, 3> spacing = { 1, 1, 1 },
  std::array<double, 3> origin = { 0, 0, 0 },
  std::array<double, 9> direction = { 1, 0, 0, 0, 1, 0, 0, 0, 1 })
{
  BalloonVolume v{};
  v.data = data;
  v.scalar_type = type;
  for (int a = 0; a < 3; ++a)
  {
    v.dims[a] = dims[a];
    v.spacing[a] = spacing[a];
    v.origin[a] = origin[a];
  }
  v.strides[0] = 1;
  v.strides[1] = static_cast<ptrdiff_t>(dims[0]);
  v.strides[2] = static_cast<ptrdiff_t>(dims[0] * dims[1]);
  std::copy(direction.begin(), direction.end(), v.direction);
  return v;
}

inline Mesh CopyMesh(const BalloonMesh& view)
{
  Mesh m;
  m.points.assign(view.points, view.points + 3 * view.point_count);
  m.triangles.assign(view.triangles, view.triangles + 3 * view.triangle_count);
  if (view.vertex_state)
  {
    m.state.assign(view.vertex_state, view.vertex_state + view.point_count);
  }
  return m;
}

// balloon_marching_cubes into an owned mesh; fails the test on an error.
inline Mesh MarchingCubes(const BalloonVolume& volume, double level, uint32_t threads)
{
  BalloonTriMesh* out = nullptr;
  const BalloonStatus status = balloon_marching_cubes(&volume, level, threads, &out);
  EXPECT_EQ(status, BALLOON_OK) << LastError(status);
  if (status != BALLOON_OK)
  {
    return {};
  }
  BalloonMesh view;
  EXPECT_EQ(balloon_trimesh_view(out, &view), BALLOON_OK);
  Mesh m = CopyMesh(view);
  balloon_trimesh_free(out);
  return m;
}

// The whole method through the C ABI (balloon_init, balloon_add_seed, balloon_segment).
inline Mesh Segment(const BalloonVolume& volume, const std::vector<std::array<double, 3>>& seeds,
  uint32_t threads = 2)
{
  BalloonParams params;
  EXPECT_EQ(balloon_params_default(&params), BALLOON_OK);
  params.threads = threads;
  BalloonSegmenter* s = nullptr;
  BalloonStatus status = balloon_init(&volume, &params, seeds.at(0).data(), &s);
  EXPECT_EQ(status, BALLOON_OK) << LastError(status);
  if (status != BALLOON_OK)
  {
    return {};
  }
  for (size_t i = 1; i < seeds.size(); ++i)
  {
    status = balloon_add_seed(s, seeds[i].data());
    EXPECT_EQ(status, BALLOON_OK) << LastError(status);
  }
  status = balloon_segment(s);
  EXPECT_EQ(status, BALLOON_OK) << LastError(status);
  Mesh m;
  BalloonMesh view;
  if (status == BALLOON_OK && balloon_mesh(s, &view) == BALLOON_OK)
  {
    m = CopyMesh(view);
  }
  balloon_free(s);
  return m;
}

inline BalloonMeshReport Check(const Mesh& m)
{
  BalloonMeshReport report{};
  report.struct_size = sizeof(BalloonMeshReport);
  const BalloonStatus status = balloon_mesh_check(
    m.points.data(), m.PointCount(), m.triangles.data(), m.TriangleCount(), &report);
  EXPECT_EQ(status, BALLOON_OK) << LastError(status);
  return report;
}

// balloon_self_intersections: sorted pairs (t0 < t1), sized by a first call.
inline std::vector<std::pair<uint32_t, uint32_t>> SelfIntersections(
  const std::vector<double>& points, const std::vector<uint32_t>& triangles)
{
  size_t count = 0;
  BalloonStatus status = balloon_self_intersections(
    points.data(), points.size() / 3, triangles.data(), triangles.size() / 3, nullptr, 0, &count);
  EXPECT_TRUE(status == BALLOON_OK || status == BALLOON_BUFFER_TOO_SMALL) << LastError(status);
  std::vector<uint32_t> flat(2 * count);
  status = balloon_self_intersections(points.data(), points.size() / 3, triangles.data(),
    triangles.size() / 3, flat.data(), count, &count);
  EXPECT_EQ(status, BALLOON_OK) << LastError(status);
  std::vector<std::pair<uint32_t, uint32_t>> pairs;
  for (size_t p = 0; p + 1 < flat.size(); p += 2)
  {
    pairs.emplace_back(flat[p], flat[p + 1]);
  }
  return pairs;
}

inline double Area(const Mesh& m)
{
  double area = 0.0;
  for (size_t t = 0; t < m.TriangleCount(); ++t)
  {
    const double* a = &m.points[3 * m.triangles[3 * t]];
    const double* b = &m.points[3 * m.triangles[3 * t + 1]];
    const double* c = &m.points[3 * m.triangles[3 * t + 2]];
    const double u[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] };
    const double v[3] = { c[0] - a[0], c[1] - a[1], c[2] - a[2] };
    const double n[3] = { u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
      u[0] * v[1] - u[1] * v[0] };
    area += 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  }
  return area;
}

// Divergence theorem about the bounding-box centre (as TriMesh::signed_volume).
inline double SignedVolume(const Mesh& m)
{
  if (m.points.empty())
  {
    return 0.0;
  }
  double lo[3], hi[3];
  for (int c = 0; c < 3; ++c)
  {
    lo[c] = std::numeric_limits<double>::infinity();
    hi[c] = -lo[c];
  }
  for (size_t p = 0; p < m.PointCount(); ++p)
  {
    for (int c = 0; c < 3; ++c)
    {
      lo[c] = std::min(lo[c], m.points[3 * p + c]);
      hi[c] = std::max(hi[c], m.points[3 * p + c]);
    }
  }
  double volume = 0.0;
  for (size_t t = 0; t < m.TriangleCount(); ++t)
  {
    double q[3][3];
    for (int k = 0; k < 3; ++k)
    {
      for (int c = 0; c < 3; ++c)
      {
        q[k][c] = m.points[3 * m.triangles[3 * t + k] + c] - 0.5 * (lo[c] + hi[c]);
      }
    }
    volume += q[0][0] * (q[1][1] * q[2][2] - q[1][2] * q[2][1]) -
      q[0][1] * (q[1][0] * q[2][2] - q[1][2] * q[2][0]) +
      q[0][2] * (q[1][0] * q[2][1] - q[1][1] * q[2][0]);
  }
  return volume / 6.0;
}

// --- Real data -------------------------------------------------------------------------------------

inline bool FileExists(const std::string& path)
{
  struct stat st;
  return stat(path.c_str(), &st) == 0;
}

// $BALLOONSEG_DATA, else ../shared/data next to the repository.
inline std::string DataDir()
{
  const char* env = std::getenv("BALLOONSEG_DATA");
  return env && *env ? std::string(env) : std::string(BALLOONSEG_REPO_DIR "/../shared/data");
}

inline bool InCI()
{
  const char* ci = std::getenv("CI");
  return ci && std::string(ci) == "true";
}

// Path of a data file; when it is missing the test is skipped loudly (failed under CI=true).
#define REQUIRE_DATA_FILE(var, relative)                                                           \
  const std::string var = support::DataDir() + "/" + (relative);                                   \
  if (!support::FileExists(var))                                                                   \
  {                                                                                                \
    if (support::InCI())                                                                           \
    {                                                                                              \
      FAIL() << var << " is missing and CI=true: set BALLOONSEG_DATA to the shared data folder";  \
    }                                                                                              \
    GTEST_SKIP() << "SKIPPED: " << var << " not found (set BALLOONSEG_DATA to the folder with "    \
                 << "vmtk-aorta/ and vtk-carotid/)";                                               \
  }

// Geometry from a MetaImage header, in ITK's meaning (TransformMatrix lists the direction
// column by column); Debian's VTK 9.1 reader ignores TransformMatrix.
struct MetaGeometry
{
  std::array<size_t, 3> dims{};
  std::array<double, 3> spacing{ 1, 1, 1 };
  std::array<double, 3> origin{};
  std::array<double, 9> direction{ 1, 0, 0, 0, 1, 0, 0, 0, 1 }; // row-major
};

inline MetaGeometry ReadMetaGeometry(const std::string& path)
{
  MetaGeometry g;
  std::ifstream in(path, std::ios::binary);
  std::string line;
  while (std::getline(in, line))
  {
    const size_t eq = line.find('=');
    if (eq == std::string::npos)
    {
      break;
    }
    std::string key = line.substr(0, eq);
    key.erase(key.find_last_not_of(' ') + 1);
    std::istringstream values(line.substr(eq + 1));
    if (key == "DimSize")
    {
      values >> g.dims[0] >> g.dims[1] >> g.dims[2];
    }
    else if (key == "ElementSpacing")
    {
      values >> g.spacing[0] >> g.spacing[1] >> g.spacing[2];
    }
    else if (key == "Offset" || key == "Origin" || key == "Position")
    {
      values >> g.origin[0] >> g.origin[1] >> g.origin[2];
    }
    else if (key == "TransformMatrix" || key == "Rotation" || key == "Orientation")
    {
      double m[9];
      for (double& e : m)
      {
        values >> e;
      }
      for (int r = 0; r < 3; ++r)
      {
        for (int c = 0; c < 3; ++c)
        {
          g.direction[3 * r + c] = m[3 * c + r];
        }
      }
    }
    else if (key == "ElementDataFile")
    {
      break;
    }
  }
  return g;
}

// --- Timing -------------------------------------------------------------------------------------------

inline double BestSeconds(int repeats, const std::function<void()>& run)
{
  double best = std::numeric_limits<double>::infinity();
  for (int r = 0; r < repeats; ++r)
  {
    const auto start = std::chrono::steady_clock::now();
    run();
    best = std::min(best,
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  return best;
}

} // namespace support
