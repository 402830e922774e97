// OpenMesh's decimater as a peer of `balloonseg simplify` (scripts/simplify_peers.py, issue 17):
// reads an OFF mesh, collapses edges in quadric-error order (DecimaterT with ModQuadricT, no
// error limit, as OpenMesh's documentation sets it up) down to a face count, writes the result
// as OFF with full precision and prints the seconds the decimation alone took. Standalone; not
// one of the ctest programs.
//
//   g++ -O2 -DNDEBUG -std=c++17 openmesh_decimate.cpp -lOpenMeshTools -lOpenMeshCore
//   ./a.out IN.off OUT.off FACES
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>

struct DoubleTraits : OpenMesh::DefaultTraits {
  typedef OpenMesh::Vec3d Point;
  typedef OpenMesh::Vec3d Normal;
};
using Mesh = OpenMesh::TriMesh_ArrayKernelT<DoubleTraits>;

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s IN.off OUT.off FACES\n", argv[0]);
    return 2;
  }
  Mesh mesh;
  if (!OpenMesh::IO::read_mesh(mesh, argv[1])) {
    std::fprintf(stderr, "cannot read %s\n", argv[1]);
    return 1;
  }
  const size_t faces = std::strtoul(argv[3], nullptr, 10);
  const auto start = std::chrono::steady_clock::now();
  OpenMesh::Decimater::DecimaterT<Mesh> decimater(mesh);
  OpenMesh::Decimater::ModQuadricT<Mesh>::Handle quadric;
  decimater.add(quadric);
  decimater.module(quadric).unset_max_err();
  decimater.initialize();
  decimater.decimate_to_faces(0, faces);
  mesh.garbage_collection();
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!OpenMesh::IO::write_mesh(mesh, argv[2], OpenMesh::IO::Options::Default, 17)) {
    std::fprintf(stderr, "cannot write %s\n", argv[2]);
    return 1;
  }
  std::printf("%.6f\n", seconds);
  return 0;
}
