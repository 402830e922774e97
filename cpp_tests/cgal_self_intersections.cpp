// Peer measurement for balloonseg's self-intersection search: CGAL's
// Polygon_mesh_processing::self_intersections (sequential) on an OFF triangle mesh.
//
// Build: g++ -O2 -std=c++17 cpp_tests/cgal_self_intersections.cpp -lgmp -lmpfr \
//            -o target/cgal_self_intersections
// Usage: cgal_self_intersections <mesh.off> <pairs.txt> [repeats]
//
// The mesh is read as a polygon soup and entered face by face with add_face, so that face i
// of the Surface_mesh is face i of the file (the pairs are compared by index with ours). The
// pairs are written one per line as "a b" with a <= b, sorted; a degenerate face f appears as
// "f f". Prints "cgal_seconds <best wall time of repeats> pairs <count> cpu_seconds <best
// process CPU time>".

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/IO/OFF.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Surface_mesh.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <iterator>
#include <limits>
#include <string>
#include <utility>
#include <vector>

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
using Face = Mesh::Face_index;

namespace PMP = CGAL::Polygon_mesh_processing;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: " << argv[0] << " <mesh.off> <pairs.txt> [repeats]\n";
    return 2;
  }
  const std::string input = argv[1];
  const std::string output = argv[2];
  const int repeats = argc > 3 ? std::max(1, std::atoi(argv[3])) : 3;

  std::vector<Point> points;
  std::vector<std::vector<std::size_t>> polygons;
  if (!CGAL::IO::read_OFF(input, points, polygons)) {
    std::cerr << input << ": cannot read as OFF\n";
    return 1;
  }
  Mesh mesh;
  std::vector<Mesh::Vertex_index> vertices;
  vertices.reserve(points.size());
  for (const Point& p : points) vertices.push_back(mesh.add_vertex(p));
  for (std::size_t i = 0; i < polygons.size(); ++i) {
    const auto& poly = polygons[i];
    if (poly.size() != 3) {
      std::cerr << input << ": face " << i << " is not a triangle\n";
      return 1;
    }
    const Face f = mesh.add_face(vertices[poly[0]], vertices[poly[1]], vertices[poly[2]]);
    if (f == Mesh::null_face() || static_cast<std::size_t>(f) != i) {
      std::cerr << input << ": face " << i
                << " cannot be added in file order (non-manifold or badly oriented)\n";
      return 1;
    }
  }

  std::vector<std::pair<Face, Face>> pairs;
  double best = std::numeric_limits<double>::infinity();
  double best_cpu = std::numeric_limits<double>::infinity();
  for (int r = 0; r < repeats; ++r) {
    pairs.clear();
    const auto start = std::chrono::steady_clock::now();
    const std::clock_t cpu_start = std::clock();
    PMP::self_intersections<CGAL::Sequential_tag>(faces(mesh), mesh, std::back_inserter(pairs));
    const std::clock_t cpu_stop = std::clock();
    const auto stop = std::chrono::steady_clock::now();
    best = std::min(best, std::chrono::duration<double>(stop - start).count());
    best_cpu = std::min(best_cpu, double(cpu_stop - cpu_start) / CLOCKS_PER_SEC);
  }

  std::vector<std::pair<std::size_t, std::size_t>> sorted;
  sorted.reserve(pairs.size());
  for (const auto& [f, g] : pairs) {
    const std::size_t a = static_cast<std::size_t>(f), b = static_cast<std::size_t>(g);
    sorted.emplace_back(std::min(a, b), std::max(a, b));
  }
  std::sort(sorted.begin(), sorted.end());
  std::ofstream out(output);
  for (const auto& [a, b] : sorted) out << a << ' ' << b << '\n';
  if (!out) {
    std::cerr << output << ": cannot write\n";
    return 1;
  }
  std::printf("cgal_seconds %.6f pairs %zu cpu_seconds %.6f\n", best, sorted.size(), best_cpu);
  return 0;
}
