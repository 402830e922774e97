// balloon_self_intersections against CGAL's Polygon_mesh_processing::self_intersections
// (sequential, exact predicates) on meshes with known intersections: icospheres with a cap
// pushed through the opposite side (also rotated, which makes long slivers), two overlapping
// spheres, coplanar grids, grids touching along lines and at coincident vertices, and a clean
// sphere. Sizes from ~10k to ~1.3M triangles. The pair sets must be identical (face i is face i
// in both). Prints ours/CGAL wall-time ratios (ours: the library's default pool; no thresholds).
#include "support.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include <cstdio>
#include <iterator>
#include <unordered_map>

namespace
{
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using CgalMesh = CGAL::Surface_mesh<Kernel::Point_3>;
using Face = CgalMesh::Face_index;
using Pairs = std::vector<std::pair<uint32_t, uint32_t>>;
namespace PMP = CGAL::Polygon_mesh_processing;

struct Soup
{
  std::vector<double> points;
  std::vector<uint32_t> triangles;
};

// An icosahedron subdivided `levels` times (20 * 4^levels triangles), on the sphere.
Soup Icosphere(int levels, std::array<double, 3> centre = { 0, 0, 0 }, double radius = 1.0)
{
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<std::array<double, 3>> v = { { -1, t, 0 }, { 1, t, 0 }, { -1, -t, 0 }, { 1, -t, 0 },
    { 0, -1, t }, { 0, 1, t }, { 0, -1, -t }, { 0, 1, -t }, { t, 0, -1 }, { t, 0, 1 },
    { -t, 0, -1 }, { -t, 0, 1 } };
  std::vector<std::array<uint32_t, 3>> f = { { 0, 11, 5 }, { 0, 5, 1 }, { 0, 1, 7 }, { 0, 7, 10 },
    { 0, 10, 11 }, { 1, 5, 9 }, { 5, 11, 4 }, { 11, 10, 2 }, { 10, 7, 6 }, { 7, 1, 8 },
    { 3, 9, 4 }, { 3, 4, 2 }, { 3, 2, 6 }, { 3, 6, 8 }, { 3, 8, 9 }, { 4, 9, 5 }, { 2, 4, 11 },
    { 6, 2, 10 }, { 8, 6, 7 }, { 9, 8, 1 } };
  auto normalise = [](std::array<double, 3> p) {
    const double n = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    return std::array<double, 3>{ p[0] / n, p[1] / n, p[2] / n };
  };
  for (auto& p : v)
  {
    p = normalise(p);
  }
  for (int level = 0; level < levels; ++level)
  {
    std::unordered_map<uint64_t, uint32_t> midpoints;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      const uint64_t key = (uint64_t(std::min(a, b)) << 32) | std::max(a, b);
      auto it = midpoints.find(key);
      if (it != midpoints.end())
      {
        return it->second;
      }
      v.push_back(normalise({ v[a][0] + v[b][0], v[a][1] + v[b][1], v[a][2] + v[b][2] }));
      return midpoints[key] = uint32_t(v.size() - 1);
    };
    std::vector<std::array<uint32_t, 3>> next;
    next.reserve(4 * f.size());
    for (const auto& tri : f)
    {
      const uint32_t ab = midpoint(tri[0], tri[1]), bc = midpoint(tri[1], tri[2]),
                     ca = midpoint(tri[2], tri[0]);
      next.push_back({ tri[0], ab, ca });
      next.push_back({ tri[1], bc, ab });
      next.push_back({ tri[2], ca, bc });
      next.push_back({ ab, bc, ca });
    }
    f.swap(next);
  }
  Soup s;
  for (const auto& p : v)
  {
    for (int c = 0; c < 3; ++c)
    {
      s.points.push_back(p[c] * radius + centre[c]);
    }
  }
  for (const auto& tri : f)
  {
    s.triangles.insert(s.triangles.end(), tri.begin(), tri.end());
  }
  return s;
}

// The cap above z = 0.7 pushed 2.4 down, through the other side; rotated, the ring of long
// slivers around it has fat bounding boxes in every axis.
Soup PushedCap(int levels, bool rotated)
{
  Soup s = Icosphere(levels);
  const double a = 0.3, b = 0.7, c = 1.1;
  const double rz[9] = { std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1 };
  const double ry[9] = { std::cos(b), 0, std::sin(b), 0, 1, 0, -std::sin(b), 0, std::cos(b) };
  const double rx[9] = { 1, 0, 0, 0, std::cos(c), -std::sin(c), 0, std::sin(c), std::cos(c) };
  for (size_t p = 0; p < s.points.size(); p += 3)
  {
    double* q = &s.points[p];
    if (q[2] > 0.7)
    {
      q[2] -= 2.4;
    }
    if (rotated)
    {
      for (const double* r : { rx, ry, rz })
      {
        const double x = q[0], y = q[1], z = q[2];
        for (int row = 0; row < 3; ++row)
        {
          q[row] = r[3 * row] * x + r[3 * row + 1] * y + r[3 * row + 2] * z;
        }
      }
    }
  }
  return s;
}

Soup Merged(std::initializer_list<Soup> parts)
{
  Soup out;
  for (const Soup& part : parts)
  {
    const uint32_t offset = uint32_t(out.points.size() / 3);
    out.points.insert(out.points.end(), part.points.begin(), part.points.end());
    for (uint32_t index : part.triangles)
    {
      out.triangles.push_back(index + offset);
    }
  }
  return out;
}

// A flat nx-by-ny grid of unit squares (times `step`) in the plane z = origin z.
Soup Grid(int nx, int ny, std::array<double, 3> origin = { 0, 0, 0 }, double step = 1.0)
{
  Soup s;
  for (int i = 0; i <= nx; ++i)
    for (int j = 0; j <= ny; ++j)
      s.points.insert(s.points.end(), { origin[0] + i * step, origin[1] + j * step, origin[2] });
  auto id = [ny](int i, int j) { return uint32_t(i * (ny + 1) + j); };
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
    {
      s.triangles.insert(s.triangles.end(), { id(i, j), id(i + 1, j), id(i + 1, j + 1) });
      s.triangles.insert(s.triangles.end(), { id(i, j), id(i + 1, j + 1), id(i, j + 1) });
    }
  return s;
}

// Two coplanar grids, the second shifted by (0.5, 0.25): coplanar overlaps everywhere.
Soup CoplanarGrids(int n)
{
  return Merged({ Grid(n, n), Grid(n, n, { 0.5, 0.25, 0.0 }) });
}

// Coplanar grids meeting along a line (distinct vertices at the same places), one whose
// vertices coincide with another's, and one standing vertically on it.
Soup TouchingGrids()
{
  Soup standing = Grid(20, 10);
  for (size_t p = 0; p < standing.points.size(); p += 3)
  {
    const double y = standing.points[p + 1];
    standing.points[p] += 5.0;
    standing.points[p + 1] = 20.5;
    standing.points[p + 2] = y;
  }
  return Merged({ Grid(40, 40), Grid(40, 40, { 40, 0, 0 }), Grid(20, 20, { 10, 10, 0 }), standing });
}

Pairs CgalPairs(const Soup& s, double* seconds)
{
  CgalMesh mesh;
  std::vector<CgalMesh::Vertex_index> vertices;
  for (size_t p = 0; p < s.points.size(); p += 3)
  {
    vertices.push_back(mesh.add_vertex({ s.points[p], s.points[p + 1], s.points[p + 2] }));
  }
  for (size_t t = 0; t < s.triangles.size() / 3; ++t)
  {
    const Face f = mesh.add_face(vertices[s.triangles[3 * t]], vertices[s.triangles[3 * t + 1]],
      vertices[s.triangles[3 * t + 2]]);
    EXPECT_EQ(size_t(f), t) << "CGAL cannot add face " << t << " in order";
  }
  std::vector<std::pair<Face, Face>> found;
  *seconds = support::BestSeconds(1, [&] {
    found.clear();
    PMP::self_intersections<CGAL::Sequential_tag>(faces(mesh), mesh, std::back_inserter(found));
  });
  Pairs pairs;
  for (const auto& [f, g] : found)
  {
    pairs.emplace_back(std::min(uint32_t(f), uint32_t(g)), std::max(uint32_t(f), uint32_t(g)));
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

void Compare(const std::string& name, const Soup& s, size_t expected_at_least)
{
  const Pairs ours = support::SelfIntersections(s.points, s.triangles);
  // Timed: one call with a large enough buffer (the sizing call is the caller's choice).
  std::vector<uint32_t> buffer(2 * ours.size() + 2);
  const double our_seconds = support::BestSeconds(3, [&] {
    size_t count = 0;
    EXPECT_EQ(balloon_self_intersections(s.points.data(), s.points.size() / 3, s.triangles.data(),
                s.triangles.size() / 3, buffer.data(), ours.size() + 1, &count),
      BALLOON_OK);
  });
  double cgal_seconds = 0.0;
  const Pairs theirs = CgalPairs(s, &cgal_seconds);
  EXPECT_GE(theirs.size(), expected_at_least) << name << ": the case lost its intersections";
  EXPECT_TRUE(std::is_sorted(ours.begin(), ours.end())) << name;
  EXPECT_EQ(ours.size(), theirs.size()) << name;
  if (ours != theirs)
  {
    Pairs only_ours, only_cgal;
    std::set_difference(ours.begin(), ours.end(), theirs.begin(), theirs.end(),
      std::back_inserter(only_ours));
    std::set_difference(theirs.begin(), theirs.end(), ours.begin(), ours.end(),
      std::back_inserter(only_cgal));
    ADD_FAILURE() << name << ": " << only_ours.size() << " pairs only in ours, "
                  << only_cgal.size() << " only in CGAL"
                  << (only_cgal.empty() ? "" : ", e.g. (" + std::to_string(only_cgal[0].first) +
                          ", " + std::to_string(only_cgal[0].second) + ")");
  }
  std::printf("RATIO self-intersections %-22s %8zu triangles %6zu pairs: ours %.4f s, CGAL %.4f s, "
              "ours/CGAL %.3f\n",
    name.c_str(), s.triangles.size() / 3, theirs.size(), our_seconds, cgal_seconds,
    our_seconds / cgal_seconds);
}

TEST(SelfIntersectionsVsCgal, PushedCap20k) { Compare("cap 20k", PushedCap(5, false), 100); }
TEST(SelfIntersectionsVsCgal, PushedCapRotated20k) { Compare("cap 20k rotated", PushedCap(5, true), 100); }
TEST(SelfIntersectionsVsCgal, PushedCap300k) { Compare("cap 328k", PushedCap(7, false), 1000); }
TEST(SelfIntersectionsVsCgal, PushedCap1M) { Compare("cap 1.3M", PushedCap(8, false), 1000); }
TEST(SelfIntersectionsVsCgal, OverlappingSpheres40k)
{
  Compare("two spheres 41k", Merged({ Icosphere(5), Icosphere(5, { 0.9, 0.3, 0.1 }) }), 100);
}
TEST(SelfIntersectionsVsCgal, OverlappingSpheres650k)
{
  Compare("two spheres 655k", Merged({ Icosphere(7), Icosphere(7, { 0.9, 0.3, 0.1 }) }), 1000);
}
TEST(SelfIntersectionsVsCgal, CoplanarGrids14k) { Compare("coplanar grids 14k", CoplanarGrids(60), 1000); }
TEST(SelfIntersectionsVsCgal, CoplanarGrids320k) { Compare("coplanar grids 320k", CoplanarGrids(283), 10000); }
TEST(SelfIntersectionsVsCgal, TouchingGrids) { Compare("touching grids 7.6k", TouchingGrids(), 1000); }
TEST(SelfIntersectionsVsCgal, CleanSphere300k) { Compare("clean sphere 328k", Icosphere(7), 0); }
} // namespace
