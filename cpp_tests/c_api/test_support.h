/* Shared by test_c_api.c and test_cpp_api.cpp (written in the common subset of C99 and
 * C++11): check macros that count and report failures, and synthetic sphere volumes in any
 * scalar type and memory layout. */
#ifndef BALLOONSEG_TEST_SUPPORT_H
#define BALLOONSEG_TEST_SUPPORT_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "balloonseg.h"

static int g_checks = 0;
static int g_failures = 0;

#define CHECK(cond, ...)                                                                  \
  do {                                                                                    \
    ++g_checks;                                                                           \
    if (!(cond)) {                                                                        \
      ++g_failures;                                                                       \
      fprintf(stderr, "%s:%d: CHECK(%s) failed: ", __FILE__, __LINE__, #cond);            \
      fprintf(stderr, __VA_ARGS__);                                                       \
      fputc('\n', stderr);                                                                \
    }                                                                                     \
  } while (0)

/* The last error message of this thread (main thread only: one static buffer). */
static inline const char *last_error(void) {
  static char buffer[2048];
  balloon_last_error_message(buffer, sizeof buffer);
  return buffer;
}

#define EXPECT_OK(call)                                                                   \
  do {                                                                                    \
    BalloonStatus status_ = (call);                                                       \
    CHECK(status_ == BALLOON_OK, "%s returned %d (%s): %s", #call, (int)status_,          \
          balloon_status_string(status_), last_error());                                  \
  } while (0)

/* The call fails with `expected` and a message containing `needle`. */
#define EXPECT_ERROR(call, expected, needle)                                              \
  do {                                                                                    \
    BalloonStatus status_ = (call);                                                       \
    CHECK(status_ == (expected), "%s returned %d (%s) instead of %d; message: %s", #call, \
          (int)status_, balloon_status_string(status_), (int)(expected), last_error());   \
    CHECK(balloon_last_error_message(NULL, 0) > 0, "%s left no message", #call);          \
    CHECK(strstr(last_error(), (needle)) != NULL, "%s: message \"%s\" lacks \"%s\"", #call, \
          last_error(), (needle));                                                        \
  } while (0)

static inline int report(const char *name) {
  printf("%s: %d passed, %d failed\n", name, g_checks - g_failures, g_failures);
  return g_failures == 0 ? 0 : 1;
}

enum { N = 24 };
static const double SPACING[3] = {1.0, 1.25, 0.8};
static const double ORIGIN[3] = {-10.0, 5.0, 2.5};
static const double IDENTITY[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};

/* Balls in index space: x, y, z, radius (voxels). */
typedef struct Ball {
  double x, y, z, r;
} Ball;

static inline double intensity_at(const Ball *balls, int count, size_t i, size_t j, size_t k) {
  for (int b = 0; b < count; ++b) {
    double dx = (double)i - balls[b].x, dy = (double)j - balls[b].y, dz = (double)k - balls[b].z;
    if (dx * dx + dy * dy + dz * dz <= balls[b].r * balls[b].r) return 200.0;
  }
  return 0.0;
}

static inline size_t element_size(uint32_t type) {
  static const size_t sizes[8] = {1, 1, 2, 2, 4, 4, 4, 8};
  return sizes[type];
}

static inline void store(void *base, uint32_t type, ptrdiff_t offset, double value) {
  char *p = (char *)base + offset * (ptrdiff_t)element_size(type);
  switch (type) {
    case BALLOON_SCALAR_U8: *(uint8_t *)p = (uint8_t)value; break;
    case BALLOON_SCALAR_I8: *(int8_t *)p = (int8_t)(value / 2); break;
    case BALLOON_SCALAR_U16: *(uint16_t *)p = (uint16_t)value; break;
    case BALLOON_SCALAR_I16: *(int16_t *)p = (int16_t)value; break;
    case BALLOON_SCALAR_U32: *(uint32_t *)p = (uint32_t)value; break;
    case BALLOON_SCALAR_I32: *(int32_t *)p = (int32_t)value; break;
    case BALLOON_SCALAR_F32: *(float *)p = (float)value; break;
    default: *(double *)p = value; break;
  }
}

/* The memory layouts of one N^3 grid of voxels. */
typedef enum Layout {
  I_FASTEST,      /* VTK/ITK, numpy C order of [k][j][i], Fortran order of [i][j][k] */
  K_FASTEST,      /* numpy C order of [i][j][k] */
  I_REVERSED,     /* i runs backwards in memory: negative stride, data points at the end */
} Layout;

/* A volume of `balls` in a fresh buffer (free `*buffer` afterwards). */
static inline BalloonVolume ball_volume(const Ball *balls, int count, uint32_t type, Layout layout,
                                 void **buffer) {
  BalloonVolume v;
  ptrdiff_t n = N, first = 0;
  ptrdiff_t strides[3] = {1, n, n * n};
  if (layout == K_FASTEST) {
    strides[0] = n * n;
    strides[1] = n;
    strides[2] = 1;
  } else if (layout == I_REVERSED) {
    strides[0] = -1;
    first = n - 1;
  }
  *buffer = calloc((size_t)(n * n * n), 8);
  for (size_t k = 0; k < N; ++k)
    for (size_t j = 0; j < N; ++j)
      for (size_t i = 0; i < N; ++i)
        store(*buffer, type, first + (ptrdiff_t)i * strides[0] + (ptrdiff_t)j * strides[1] +
                                 (ptrdiff_t)k * strides[2],
              intensity_at(balls, count, i, j, k));
  v.data = (char *)*buffer + first * (ptrdiff_t)element_size(type);
  v.scalar_type = type;
  for (int a = 0; a < 3; ++a) {
    v.dims[a] = N;
    v.strides[a] = strides[a];
    v.spacing[a] = SPACING[a];
    v.origin[a] = ORIGIN[a];
  }
  memcpy(v.direction, IDENTITY, sizeof IDENTITY);
  return v;
}

static inline void index_to_world(const Ball *b, double out[3]) {
  out[0] = ORIGIN[0] + SPACING[0] * b->x;
  out[1] = ORIGIN[1] + SPACING[1] * b->y;
  out[2] = ORIGIN[2] + SPACING[2] * b->z;
}

/* An owned copy of a mesh view, to compare runs bit for bit. */
typedef struct Flat {
  double *points;
  size_t point_count;
  uint32_t *triangles;
  size_t triangle_count;
} Flat;

static inline Flat flat_copy(const BalloonMesh *m) {
  Flat f;
  f.point_count = m->point_count;
  f.triangle_count = m->triangle_count;
  f.points = (double *)malloc(3 * m->point_count * sizeof(double) + 1);
  f.triangles = (uint32_t *)malloc(3 * m->triangle_count * sizeof(uint32_t) + 1);
  if (m->point_count) memcpy(f.points, m->points, 3 * m->point_count * sizeof(double));
  if (m->triangle_count)
    memcpy(f.triangles, m->triangles, 3 * m->triangle_count * sizeof(uint32_t));
  return f;
}

static inline int flat_equal(const Flat *a, const Flat *b) {
  return a->point_count == b->point_count && a->triangle_count == b->triangle_count &&
         memcmp(a->points, b->points, 3 * a->point_count * sizeof(double)) == 0 &&
         memcmp(a->triangles, b->triangles, 3 * a->triangle_count * sizeof(uint32_t)) == 0;
}

static inline void flat_free(Flat *f) {
  free(f->points);
  free(f->triangles);
}

/* Parameters with the window given, so no estimate is involved. */
static inline BalloonParams window_params(uint32_t threads) {
  BalloonParams p;
  balloon_params_default(&p);
  p.reference_intensity = 200.0;
  p.tolerance = 100.0;
  p.threads = threads;
  return p;
}

static inline BalloonMeshReport check_mesh(const BalloonMesh *m) {
  BalloonMeshReport r;
  memset(&r, 0, sizeof r);
  r.struct_size = sizeof r;
  EXPECT_OK(balloon_mesh_check(m->points, m->point_count, m->triangles, m->triangle_count, &r));
  return r;
}

/* Closed, manifold, oriented outward, free of self-intersections, `components` spheres. */
static inline void expect_valid_spheres(const BalloonMesh *m, size_t components, const char *what) {
  BalloonMeshReport r = check_mesh(m);
  CHECK(r.closed && r.manifold && r.oriented && r.outward,
        "%s: closed %d manifold %d oriented %d outward %d", what, r.closed, r.manifold,
        r.oriented, r.outward);
  CHECK(r.self_intersecting_pairs == 0, "%s: %zu self-intersecting pairs", what,
        r.self_intersecting_pairs);
  CHECK(r.genus == 0 && r.components == components, "%s: genus %lld, %zu components", what,
        (long long)r.genus, r.components);
  CHECK(r.volume_mm3 > 0 && r.area_mm2 > 0, "%s: volume %g area %g", what, r.volume_mm3,
        r.area_mm2);
}

/* Marching cubes of a bright ball: a closed sphere whose normals point towards increasing
 * values, i.e. inward. */
static inline void expect_inward_sphere(const BalloonMesh *m, const char *what) {
  BalloonMeshReport r = check_mesh(m);
  CHECK(r.closed && r.manifold && r.oriented && !r.outward && r.genus == 0 && r.components == 1,
        "%s: closed %d manifold %d oriented %d outward %d genus %lld", what, r.closed,
        r.manifold, r.oriented, r.outward, (long long)r.genus);
  CHECK(r.volume_mm3 < 0 && r.self_intersecting_pairs == 0, "%s: volume %g, %zu pairs", what,
        r.volume_mm3, r.self_intersecting_pairs);
}

/* Segments `v` from `seed` and returns a copy of the mesh (empty on failure). */
static inline Flat segment_copy(const BalloonVolume *v, const BalloonParams *p, const double seed[3]) {
  BalloonSegmenter *s = NULL;
  BalloonMesh m;
  Flat f;
  memset(&f, 0, sizeof f);
  EXPECT_OK(balloon_init(v, p, seed, &s));
  if (!s) return f;
  EXPECT_OK(balloon_segment(s));
  EXPECT_OK(balloon_mesh(s, &m));
  f = flat_copy(&m);
  balloon_free(s);
  return f;
}

#endif
