/* Links libballoonseg.a from C: marching cubes of a small sphere, checked closed. */
#include <balloonseg.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#define N 16

int main(void) {
  static float field[N * N * N];
  for (int k = 0; k < N; ++k)
    for (int j = 0; j < N; ++j)
      for (int i = 0; i < N; ++i) {
        const double x = i - 7.5, y = j - 7.5, z = k - 7.5;
        field[(k * N + j) * N + i] = (float)(5.0 - sqrt(x * x + y * y + z * z));
      }
  BalloonVolume volume;
  memset(&volume, 0, sizeof volume);
  volume.data = field;
  volume.scalar_type = BALLOON_SCALAR_F32;
  for (int a = 0; a < 3; ++a) {
    volume.dims[a] = N;
    volume.spacing[a] = 1.0;
  }
  volume.strides[0] = 1;
  volume.strides[1] = N;
  volume.strides[2] = N * N;
  volume.direction[0] = volume.direction[4] = volume.direction[8] = 1.0;

  BalloonTriMesh *mesh = NULL;
  BalloonStatus status = balloon_marching_cubes(&volume, 0.0, 1, &mesh);
  if (status != BALLOON_OK) {
    char message[512];
    balloon_last_error_message(message, sizeof message);
    fprintf(stderr, "balloon_marching_cubes: %s: %s\n", balloon_status_string(status), message);
    return 1;
  }
  BalloonMesh view;
  balloon_trimesh_view(mesh, &view);
  BalloonMeshReport report;
  report.struct_size = sizeof report;
  status = balloon_mesh_check(view.points, view.point_count, view.triangles, view.triangle_count,
                              &report);
  printf("balloonseg %s (static): sphere with %zu points, %zu triangles, closed %d, genus %lld\n",
         balloon_version(), view.point_count, view.triangle_count, report.closed,
         (long long)report.genus);
  balloon_trimesh_free(mesh);
  return status == BALLOON_OK && report.closed && report.genus == 0 ? 0 : 1;
}
