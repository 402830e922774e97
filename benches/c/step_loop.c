/* balloon_step(s, 1) in a loop through the C ABI, on the vmtk aorta (float32 voxels, i fastest,
 * as SimpleITK's GetArrayFromImage(...).tofile(...) writes them): the time of 400 single steps
 * and the final mesh's size. Build and run (BENCHMARKS.md, "The C ABI's meshes as views"):
 *   cargo build --release --lib
 *   cc -O2 -std=gnu99 benches/c/step_loop.c -Iinclude target/release/libballoonseg.a \
 *      -lpthread -ldl -lm -lgcc_s -o step_loop && ./step_loop aorta.raw */
#include <balloonseg.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
int main(int argc, char **argv) {
  if (argc != 2) return 1;
  FILE *f = fopen(argv[1], "rb");
  float *voxels = malloc(sizeof(float) * 157 * 393 * 34);
  if (!f || fread(voxels, sizeof(float), 157 * 393 * 34, f) != 157 * 393 * 34) return 2;
  BalloonVolume v = {0};
  v.data = voxels; v.scalar_type = BALLOON_SCALAR_F32;
  v.dims[0] = 157; v.dims[1] = 393; v.dims[2] = 34;
  v.strides[0] = 1; v.strides[1] = 157; v.strides[2] = 157 * 393;
  v.spacing[0] = v.spacing[1] = 0.878906; v.spacing[2] = 1.50009;
  v.origin[0] = -156.445; v.origin[1] = -24.6094; v.origin[2] = 0.0;
  v.direction[0] = -1.0; v.direction[4] = -1.0; v.direction[8] = 1.0;
  const double seed[3] = {-221.484, -156.445, 22.501};
  BalloonParams p; balloon_params_default(&p); p.threads = 2;
  BalloonSegmenter *s = NULL;
  if (balloon_init(&v, &p, seed, &s) != BALLOON_OK) return 3;
  struct timespec a, b; clock_gettime(CLOCK_MONOTONIC, &a);
  uint32_t moving = 0; int n = 0;
  for (; n < 400; ++n) if (balloon_step(s, 1, &moving) != BALLOON_OK) return 4;
  clock_gettime(CLOCK_MONOTONIC, &b);
  BalloonMesh m; balloon_mesh(s, &m);
  printf("%d steps: %.3f s, %zu points at the end, %u moving, first point %.6f\n", n,
         (b.tv_sec - a.tv_sec) + 1e-9 * (b.tv_nsec - a.tv_nsec), m.point_count, moving, m.points[0]);
  balloon_free(s);
  return 0;
}
