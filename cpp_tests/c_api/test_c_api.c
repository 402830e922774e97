/* The C API from C: every function on its success path and on every error path, against
 * include/balloonseg.h and libballoonseg.so only. Exits non-zero when a check fails. */
#include <stddef.h>
#include <stdint.h>

#include "test_support.h"

static const Ball BALL = {11.5, 12.0, 11.0, 7.0};

static void test_version_and_status_strings(void) {
  char expected[64];
  snprintf(expected, sizeof expected, "%d.%d.%d", BALLOON_VERSION_MAJOR, BALLOON_VERSION_MINOR,
           BALLOON_VERSION_PATCH);
  CHECK(strcmp(balloon_version(), expected) == 0, "version %s, macros %s", balloon_version(),
        expected);
  for (int s = BALLOON_OK; s <= BALLOON_OUT_OF_MEMORY; ++s) {
    const char *text = balloon_status_string((BalloonStatus)s);
    CHECK(text != NULL && strlen(text) > 0, "status %d has no description", s);
    CHECK(strcmp(text, "unknown status") != 0, "status %d is unknown", s);
    for (int t = BALLOON_OK; t < s; ++t)
      CHECK(strcmp(text, balloon_status_string((BalloonStatus)t)) != 0,
            "statuses %d and %d share a description", s, t);
  }
  CHECK(strcmp(balloon_status_string((BalloonStatus)99), "unknown status") == 0, "99: %s",
        balloon_status_string((BalloonStatus)99));
  CHECK(strcmp(balloon_status_string((BalloonStatus)-1), "unknown status") == 0, "-1");
}

static void test_last_error_message(void) {
  char buffer[8];
  char full[512];
  EXPECT_ERROR(balloon_params_default(NULL), BALLOON_NULL_POINTER, "out");
  size_t n = balloon_last_error_message(NULL, 0);
  CHECK(n > 8, "message length %zu", n);
  CHECK(balloon_last_error_message(full, sizeof full) == n, "same length into a big buffer");
  CHECK(strlen(full) == n, "the whole message is copied");
  memset(buffer, 'x', sizeof buffer);
  CHECK(balloon_last_error_message(buffer, 5) == n, "the full length when truncated");
  CHECK(memcmp(buffer, full, 4) == 0 && buffer[4] == '\0' && buffer[5] == 'x',
        "4 bytes and a NUL, nothing more");
  CHECK(balloon_last_error_message(buffer, 1) == n && buffer[0] == '\0', "size 1: just a NUL");
  CHECK(balloon_last_error_message(NULL, 16) == n, "a NULL buffer only measures");
  /* A success does not clear it (errno-like). */
  BalloonParams p;
  EXPECT_OK(balloon_params_default(&p));
  CHECK(balloon_last_error_message(NULL, 0) == n, "kept after a success");
}

static void test_params(void) {
  BalloonParams p;
  EXPECT_OK(balloon_params_default(&p));
  CHECK(p.struct_size == sizeof(BalloonParams), "struct_size %zu", p.struct_size);
  CHECK(isnan(p.reference_intensity) && isnan(p.tolerance) && isnan(p.edge_length_mm),
        "estimated values are NaN");
  CHECK(p.max_iterations > 0 && p.self_intersection_interval > 0 && p.max_vertices >= 64 &&
            p.step_fraction > 0 && p.threads == 0,
        "defaults");
}

static void test_param_table(void) {
  size_t count = balloon_param_count();
  CHECK(count == 14, "%zu parameters", count);
  BalloonParams p;
  EXPECT_OK(balloon_params_default(&p));
  int seen_step_fraction = 0;
  for (size_t i = 0; i < count; ++i) {
    BalloonParamInfo info;
    info.struct_size = sizeof info;
    EXPECT_OK(balloon_param_info(i, &info));
    CHECK(info.name && *info.name && info.doc && *info.doc && info.allowed && info.unset,
          "parameter %zu has its texts", i);
    CHECK(info.minimum <= info.maximum, "%s: range", info.name);
    double value = 0;
    EXPECT_OK(balloon_params_get(&p, info.name, &value));
    CHECK((isnan(value) && info.optional) || value == info.default_value,
          "%s: default %g, table %g", info.name, value, info.default_value);
    if (strcmp(info.name, "step_fraction") == 0) {
      seen_step_fraction = 1;
      CHECK(info.kind == BALLOON_PARAM_REAL && info.minimum == 0 && !info.minimum_inclusive &&
                info.maximum == 1 && info.maximum_inclusive,
            "step_fraction is a real in (0, 1]");
    }
  }
  CHECK(seen_step_fraction, "the table has step_fraction");
  BalloonParamInfo info;
  info.struct_size = sizeof info;
  EXPECT_ERROR(balloon_param_info(count, &info), BALLOON_INVALID_ARGUMENT, "out of range");
  EXPECT_ERROR(balloon_param_info(0, NULL), BALLOON_NULL_POINTER, "out");
  info.struct_size = 8;
  EXPECT_ERROR(balloon_param_info(0, &info), BALLOON_PARAMS_SIZE_MISMATCH, "BalloonParamInfo");

  EXPECT_OK(balloon_params_set(&p, "max_iterations", 25));
  CHECK(p.max_iterations == 25, "set by name reaches the field: %u", p.max_iterations);
  EXPECT_OK(balloon_params_set(&p, "tolerance", 80));
  CHECK(p.tolerance == 80, "tolerance %g", p.tolerance);
  EXPECT_OK(balloon_params_set(&p, "tolerance", NAN));
  CHECK(isnan(p.tolerance), "NaN unsets an optional parameter");
  EXPECT_ERROR(balloon_params_set(&p, "max_iterations", 2.5), BALLOON_INVALID_ARGUMENT,
               "whole number");
  EXPECT_ERROR(balloon_params_set(&p, "step_fraction", NAN), BALLOON_INVALID_ARGUMENT, "(0, 1]");
  EXPECT_ERROR(balloon_params_set(&p, "no_such", 1), BALLOON_INVALID_ARGUMENT, "tolerance");
  EXPECT_ERROR(balloon_params_set(NULL, "tolerance", 1), BALLOON_NULL_POINTER, "params");
  EXPECT_ERROR(balloon_params_set(&p, NULL, 1), BALLOON_NULL_POINTER, "name");
  double value;
  EXPECT_ERROR(balloon_params_get(&p, "max_iterations", NULL), BALLOON_NULL_POINTER, "value");
  EXPECT_ERROR(balloon_params_get(&p, NULL, &value), BALLOON_NULL_POINTER, "name");
  CHECK(p.max_iterations == 25, "a refused value changes nothing");
}

static void test_init_errors(void) {
  void *buffer = NULL;
  BalloonVolume good = ball_volume(&BALL, 1, BALLOON_SCALAR_I16, I_FASTEST, &buffer);
  BalloonParams p = window_params(1);
  double seed[3];
  index_to_world(&BALL, seed);
  BalloonSegmenter *const sentinel = (BalloonSegmenter *)(uintptr_t)0x1234;
  BalloonSegmenter *s = sentinel;
  BalloonVolume v;

  EXPECT_ERROR(balloon_init(NULL, &p, seed, &s), BALLOON_NULL_POINTER, "volume");
  EXPECT_ERROR(balloon_init(&good, &p, NULL, &s), BALLOON_NULL_POINTER, "seed_world");
  EXPECT_ERROR(balloon_init(&good, &p, seed, NULL), BALLOON_NULL_POINTER, "out");
  v = good;
  v.data = NULL;
  EXPECT_ERROR(balloon_init(&v, &p, seed, &s), BALLOON_NULL_POINTER, "volume->data");

  BalloonParams wrong = p;
  /* The size of the struct before simplify_error_mm was added last: a caller compiled against
   * that header is refused, not misread. */
  wrong.struct_size = offsetof(BalloonParams, simplify_error_mm);
  char sizes[64];
  snprintf(sizes, sizeof sizes, "%zu", sizeof(BalloonParams));
  EXPECT_ERROR(balloon_init(&good, &wrong, seed, &s), BALLOON_PARAMS_SIZE_MISMATCH, sizes);
  wrong = p;
  wrong.max_iterations = 0;
  EXPECT_ERROR(balloon_init(&good, &wrong, seed, &s), BALLOON_INVALID_ARGUMENT, "max_iterations");
  wrong = p;
  wrong.threads = 4000000000u;
  EXPECT_ERROR(balloon_init(&good, &wrong, seed, &s), BALLOON_INVALID_ARGUMENT, "threads");
  wrong = p;
  wrong.tolerance = -1;
  EXPECT_ERROR(balloon_init(&good, &wrong, seed, &s), BALLOON_INVALID_ARGUMENT, "tolerance");

  v = good;
  v.dims[1] = 0;
  EXPECT_ERROR(balloon_init(&v, &p, seed, &s), BALLOON_INVALID_VOLUME, "dims[1] is 0");
  v = good;
  v.dims[0] = SIZE_MAX / 2;
  v.dims[2] = 4;
  EXPECT_ERROR(balloon_init(&v, &p, seed, &s), BALLOON_INVALID_VOLUME, "overflow");
  v = good;
  v.strides[2] = PTRDIFF_MAX / 4;
  EXPECT_ERROR(balloon_init(&v, &p, seed, &s), BALLOON_INVALID_VOLUME, "strides");
  v = good;
  v.strides[1] = PTRDIFF_MIN / 64; /* would start far below address 0 */
  EXPECT_ERROR(balloon_init(&v, &p, seed, &s), BALLOON_INVALID_VOLUME, "strides");
  v = good;
  v.data = (const char *)good.data + 1; /* int16 at an odd address */
  EXPECT_ERROR(balloon_init(&v, &p, seed, &s), BALLOON_INVALID_VOLUME, "aligned");
  v = good;
  v.spacing[1] = NAN;
  EXPECT_ERROR(balloon_init(&v, &p, seed, &s), BALLOON_INVALID_VOLUME, "spacing[1]");
  v = good;
  v.direction[4] = 0; /* j axis = 0 */
  EXPECT_ERROR(balloon_init(&v, &p, seed, &s), BALLOON_INVALID_VOLUME, "singular");
  v = good;
  v.scalar_type = 8;
  EXPECT_ERROR(balloon_init(&v, &p, seed, &s), BALLOON_INVALID_VOLUME, "scalar_type");
  v.scalar_type = 0xFFFFFFFFu;
  EXPECT_ERROR(balloon_init(&v, &p, seed, &s), BALLOON_INVALID_VOLUME, "scalar_type");

  double outside[3] = {1000.0, 0.0, 0.0};
  EXPECT_ERROR(balloon_init(&good, &p, outside, &s), BALLOON_INVALID_ARGUMENT, "outside");
  double background[3] = {ORIGIN[0] + 1.0, ORIGIN[1] + 1.0, ORIGIN[2] + 1.0};
  EXPECT_ERROR(balloon_init(&good, &p, background, &s), BALLOON_INVALID_ARGUMENT, "background");
  CHECK(s == sentinel, "no output is written on failure");

  /* NULL params = defaults, with the window estimated around the seed. */
  EXPECT_OK(balloon_init(&good, NULL, seed, &s));
  CHECK(s != sentinel && s != NULL, "a handle");
  BalloonStats stats;
  stats.struct_size = sizeof stats;
  EXPECT_OK(balloon_stats(s, &stats));
  CHECK(stats.reference_intensity > 100 && stats.tolerance > 0, "estimated %g +- %g",
        stats.reference_intensity, stats.tolerance);
  balloon_free(s);
  free(buffer);
}

/* Every handle function with a NULL handle or output; then stats with a wrong size. */
static void test_handle_errors(BalloonSegmenter *s, const double seed[3]) {
  BalloonMesh m;
  BalloonStats stats;
  size_t frozen = 777;
  EXPECT_ERROR(balloon_add_seed(NULL, seed), BALLOON_NULL_POINTER, "s");
  EXPECT_ERROR(balloon_add_seed(s, NULL), BALLOON_NULL_POINTER, "seed_world");
  double outside[3] = {-1000.0, 0.0, 0.0};
  EXPECT_ERROR(balloon_add_seed(s, outside), BALLOON_INVALID_ARGUMENT, "outside");
  double background[3] = {ORIGIN[0] + 1.0, ORIGIN[1] + 1.0, ORIGIN[2] + 1.0};
  EXPECT_ERROR(balloon_add_seed(s, background), BALLOON_INVALID_ARGUMENT, "background");
  EXPECT_ERROR(balloon_step(NULL, 1, NULL), BALLOON_NULL_POINTER, "s");
  EXPECT_ERROR(balloon_freeze_self_intersections(NULL, &frozen), BALLOON_NULL_POINTER, "s");
  EXPECT_ERROR(balloon_freeze_self_intersections(s, NULL), BALLOON_NULL_POINTER,
               "frozen_vertices_out");
  EXPECT_ERROR(balloon_reparametrize(NULL), BALLOON_NULL_POINTER, "s");
  EXPECT_ERROR(balloon_segment(NULL), BALLOON_NULL_POINTER, "s");
  EXPECT_ERROR(balloon_mesh(NULL, &m), BALLOON_NULL_POINTER, "s");
  EXPECT_ERROR(balloon_mesh(s, NULL), BALLOON_NULL_POINTER, "out");
  EXPECT_ERROR(balloon_stats(NULL, &stats), BALLOON_NULL_POINTER, "s");
  EXPECT_ERROR(balloon_stats(s, NULL), BALLOON_NULL_POINTER, "out");
  stats.struct_size = 3;
  EXPECT_ERROR(balloon_stats(s, &stats), BALLOON_PARAMS_SIZE_MISMATCH, "BalloonStats");
  CHECK(stats.struct_size == 3, "nothing written on failure");
  EXPECT_ERROR(balloon_set_progress_callback(NULL, NULL, NULL), BALLOON_NULL_POINTER, "s");
  CHECK(frozen == 777, "nothing written on failure");
  balloon_free(NULL);
  balloon_trimesh_free(NULL);
}

/* The method driven by hand: steps, a self-intersection search, a re-parametrisation, more
 * steps, then the whole method to its end. */
static void test_driven_by_hand(void) {
  void *buffer = NULL;
  BalloonVolume v = ball_volume(&BALL, 1, BALLOON_SCALAR_U8, I_FASTEST, &buffer);
  BalloonParams p = window_params(2);
  double seed[3];
  index_to_world(&BALL, seed);
  BalloonSegmenter *s = NULL;
  BalloonMesh m;
  EXPECT_OK(balloon_init(&v, &p, seed, &s));
  test_handle_errors(s, seed);

  EXPECT_OK(balloon_mesh(s, &m));
  CHECK(m.point_count > 0 && m.vertex_state != NULL, "the initial sphere");
  expect_valid_spheres(&m, 1, "initial sphere");
  uint32_t active = 0;
  EXPECT_OK(balloon_step(s, 10, &active));
  EXPECT_OK(balloon_step(s, 2, NULL));
  EXPECT_OK(balloon_mesh(s, &m));
  CHECK(active > 0 && active <= m.point_count, "%u active of %zu", active, m.point_count);
  size_t frozen = 12345;
  EXPECT_OK(balloon_freeze_self_intersections(s, &frozen));
  CHECK(frozen == 0, "a growing sphere does not meet itself (%zu frozen)", frozen);
  EXPECT_OK(balloon_reparametrize(s));
  EXPECT_OK(balloon_mesh(s, &m));
  expect_valid_spheres(&m, 1, "re-parametrised");
  /* Vertices inside the window move again; those outside it, which can only be at the ball's
   * edge (the window is 100-300, the ball 200 on 0), stay frozen at the border. */
  size_t moving = 0;
  for (size_t i = 0; i < m.point_count; ++i) {
    double r2 = 0;
    const double centre[3] = {BALL.x, BALL.y, BALL.z};
    for (int a = 0; a < 3; ++a) {
      double d = (m.points[3 * i + a] - ORIGIN[a]) / SPACING[a] - centre[a];
      r2 += d * d;
    }
    if (m.vertex_state[i] == BALLOON_VERTEX_MOVING) {
      ++moving;
    } else {
      CHECK(m.vertex_state[i] == BALLOON_VERTEX_FROZEN_AT_BORDER, "vertex %zu state %u", i,
            m.vertex_state[i]);
      CHECK(r2 >= (BALL.r - 1.5) * (BALL.r - 1.5), "vertex %zu frozen %.2f voxels from the centre",
            i, sqrt(r2));
    }
  }
  CHECK(moving > m.point_count / 2, "%zu of %zu move again", moving, m.point_count);
  EXPECT_OK(balloon_step(s, 400, &active));
  EXPECT_OK(balloon_mesh(s, &m));
  size_t at_border = 0;
  for (size_t i = 0; i < m.point_count; ++i) {
    CHECK(m.vertex_state[i] <= BALLOON_VERTEX_FROZEN_BY_SELF_INTERSECTION, "state %u",
          m.vertex_state[i]);
    at_border += m.vertex_state[i] == BALLOON_VERTEX_FROZEN_AT_BORDER;
  }
  CHECK(at_border > m.point_count / 2, "%zu of %zu at the border", at_border, m.point_count);
  EXPECT_OK(balloon_segment(s));
  EXPECT_OK(balloon_mesh(s, &m));
  expect_valid_spheres(&m, 1, "segmented by hand");
  BalloonStats stats;
  stats.struct_size = sizeof stats;
  EXPECT_OK(balloon_stats(s, &stats));
  CHECK(stats.iterations >= 12 && stats.reparametrizations >= 1, "%u iterations, %u reparam.",
        stats.iterations, stats.reparametrizations);
  CHECK(stats.reference_intensity == 200 && stats.tolerance == 100, "the given window");
  CHECK(stats.seconds_total >= stats.seconds_inflation && stats.seconds_inflation >= 0, "times");
  balloon_free(s);
  free(buffer);
}

typedef struct Progress {
  int calls, cancel_at;
  double last_fraction;
  int bad_phase;
} Progress;

static int on_progress(double fraction, const char *phase, void *user_data) {
  Progress *p = (Progress *)user_data;
  p->calls += 1;
  p->last_fraction = fraction;
  p->bad_phase |= phase == NULL || strlen(phase) == 0 || !(fraction >= 0 && fraction <= 1);
  return p->calls == p->cancel_at;
}

/* Also flags a phase other than "simplification" and a fraction below the one before. */
static int on_simplify_progress(double fraction, const char *phase, void *user_data) {
  Progress *p = (Progress *)user_data;
  p->bad_phase |= phase == NULL || strcmp(phase, "simplification") != 0 ||
                  !(fraction >= p->last_fraction && fraction <= 1);
  p->calls += 1;
  p->last_fraction = fraction;
  return p->calls == p->cancel_at;
}

/* A cancel leaves a usable handle whose mesh is the valid balloon of the last step; the run
 * then completes without the callback, to the same mesh as an uncancelled run. */
static void test_cancel(void) {
  void *buffer = NULL;
  BalloonVolume v = ball_volume(&BALL, 1, BALLOON_SCALAR_U8, I_FASTEST, &buffer);
  BalloonParams p = window_params(1);
  double seed[3];
  index_to_world(&BALL, seed);
  BalloonSegmenter *s = NULL;
  BalloonMesh m;
  Progress progress = {0, 6, -1.0, 0};
  EXPECT_OK(balloon_init(&v, &p, seed, &s));
  EXPECT_OK(balloon_set_progress_callback(s, on_progress, &progress));
  EXPECT_ERROR(balloon_segment(s), BALLOON_CANCELLED, "cancelled");
  CHECK(progress.calls == 6 && !progress.bad_phase, "%d calls", progress.calls);
  EXPECT_OK(balloon_mesh(s, &m));
  CHECK(m.point_count > 0 && m.vertex_state != NULL, "a mesh after the cancel");
  expect_valid_spheres(&m, 1, "after the cancel");

  /* A re-parametrisation cancelled before it starts leaves the mesh as it was. */
  Flat before = flat_copy(&m);
  Progress at_once = {0, 1, -1.0, 0};
  EXPECT_OK(balloon_set_progress_callback(s, on_progress, &at_once));
  EXPECT_ERROR(balloon_reparametrize(s), BALLOON_CANCELLED, "reparametrization");
  EXPECT_OK(balloon_mesh(s, &m));
  Flat after = flat_copy(&m);
  CHECK(flat_equal(&before, &after), "the mesh is unchanged by a cancelled re-parametrisation");
  flat_free(&before);
  flat_free(&after);

  EXPECT_OK(balloon_set_progress_callback(s, NULL, NULL));
  EXPECT_OK(balloon_segment(s));
  EXPECT_OK(balloon_mesh(s, &m));
  expect_valid_spheres(&m, 1, "resumed after the cancel");
  CHECK(progress.calls == 6 && at_once.calls == 1, "the callback was removed");
  balloon_free(s);

  /* A callback that never cancels sees the run to its end. */
  Progress all = {0, -1, -1.0, 0};
  EXPECT_OK(balloon_init(&v, &p, seed, &s));
  EXPECT_OK(balloon_set_progress_callback(s, on_progress, &all));
  EXPECT_OK(balloon_segment(s));
  CHECK(all.calls > 6 && all.last_fraction == 1.0 && !all.bad_phase, "%d calls, last %g",
        all.calls, all.last_fraction);
  balloon_free(s);
  free(buffer);
}

/* The same voxels in other scalar types and memory layouts give the identical mesh. */
static void test_types_and_layouts(void) {
  static const struct {
    uint32_t type;
    Layout layout;
    const char *name;
  } cases[] = {
      {BALLOON_SCALAR_I16, K_FASTEST, "int16, k fastest (C order of [i][j][k])"},
      {BALLOON_SCALAR_I16, I_REVERSED, "int16, negative i stride"},
      {BALLOON_SCALAR_F32, I_FASTEST, "float32"},
      {BALLOON_SCALAR_F64, K_FASTEST, "float64, k fastest"},
  };
  void *buffer = NULL;
  BalloonParams p = window_params(2);
  double seed[3];
  index_to_world(&BALL, seed);
  BalloonVolume v = ball_volume(&BALL, 1, BALLOON_SCALAR_I16, I_FASTEST, &buffer);
  Flat reference = segment_copy(&v, &p, seed);
  free(buffer);
  BalloonMesh view = {reference.points, reference.point_count, reference.triangles,
                      reference.triangle_count, NULL};
  expect_valid_spheres(&view, 1, "int16 sphere");
  for (size_t c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
    v = ball_volume(&BALL, 1, cases[c].type, cases[c].layout, &buffer);
    Flat f = segment_copy(&v, &p, seed);
    CHECK(flat_equal(&f, &reference), "%s: %zu points, %zu triangles vs %zu, %zu",
          cases[c].name, f.point_count, f.triangle_count, reference.point_count,
          reference.triangle_count);
    flat_free(&f);
    free(buffer);
  }
  flat_free(&reference);
}

/* Two balls, one seed each: two spheres. A tiny vertex limit is a leak. */
static void test_two_seeds_and_leak(void) {
  const Ball balls[2] = {{6.5, 7.0, 7.0, 4.5}, {17.0, 16.0, 16.5, 4.5}};
  void *buffer = NULL;
  BalloonVolume v = ball_volume(balls, 2, BALLOON_SCALAR_U16, I_FASTEST, &buffer);
  BalloonParams p = window_params(2);
  double seed0[3], seed1[3];
  index_to_world(&balls[0], seed0);
  index_to_world(&balls[1], seed1);
  BalloonSegmenter *s = NULL;
  BalloonMesh m;
  EXPECT_OK(balloon_init(&v, &p, seed0, &s));
  EXPECT_OK(balloon_add_seed(s, seed1));
  EXPECT_OK(balloon_segment(s));
  EXPECT_OK(balloon_mesh(s, &m));
  expect_valid_spheres(&m, 2, "two seeds");
  balloon_free(s);

  p.tolerance = 1000.0; /* everything is foreground */
  p.max_vertices = 64;
  EXPECT_OK(balloon_init(&v, &p, seed0, &s));
  EXPECT_ERROR(balloon_segment(s), BALLOON_LEAK, "max_vertices");
  EXPECT_OK(balloon_mesh(s, &m));
  CHECK(check_mesh(&m).closed, "the leaked balloon is still a closed mesh");
  balloon_free(s);
  free(buffer);
}

static void test_marching_cubes(void) {
  void *buffer = NULL;
  BalloonVolume v = ball_volume(&BALL, 1, BALLOON_SCALAR_F32, I_REVERSED, &buffer);
  BalloonTriMesh *mesh = NULL;
  BalloonMesh m;
  EXPECT_ERROR(balloon_marching_cubes(NULL, 100.0, 1, &mesh), BALLOON_NULL_POINTER, "volume");
  EXPECT_ERROR(balloon_marching_cubes(&v, 100.0, 1, NULL), BALLOON_NULL_POINTER, "out");
  EXPECT_ERROR(balloon_marching_cubes(&v, NAN, 1, &mesh), BALLOON_INVALID_ARGUMENT, "level");
  EXPECT_ERROR(balloon_marching_cubes(&v, 100.0, 4000000000u, &mesh), BALLOON_INVALID_ARGUMENT,
               "threads");
  BalloonVolume bad = v;
  bad.dims[2] = 0;
  EXPECT_ERROR(balloon_marching_cubes(&bad, 100.0, 1, &mesh), BALLOON_INVALID_VOLUME, "dims");
  CHECK(mesh == NULL, "no output on failure");
  EXPECT_OK(balloon_marching_cubes(&v, 100.0, 2, &mesh));
  EXPECT_ERROR(balloon_trimesh_view(NULL, &m), BALLOON_NULL_POINTER, "m");
  EXPECT_ERROR(balloon_trimesh_view(mesh, NULL), BALLOON_NULL_POINTER, "out");
  EXPECT_OK(balloon_trimesh_view(mesh, &m));
  CHECK(m.vertex_state == NULL && m.point_count > 100, "%zu points", m.point_count);
  expect_inward_sphere(&m, "marching cubes");
  balloon_trimesh_free(mesh);
  free(buffer);
}

/* Two triangles crossing each other, and a tetrahedron. */
static const double CROSS_POINTS[] = {0, 0, 0, 2, 0, 0, 0, 2, 0, 0.5, 0.5, -1, 0.5, 0.5, 1, 1.5, 1.5, 0};
static const uint32_t CROSS_TRIANGLES[] = {0, 1, 2, 3, 4, 5};
static const double TET_POINTS[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
static const uint32_t TET_TRIANGLES[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};

/* balloon_simplify on the marching-cubes sphere of a ball (closed, oriented inward): a valid
 * sphere of fewer triangles, oriented as it was, with a vertex map that covers it; every bad
 * input is its status and message, and *out is left alone. */
static void test_simplify(void) {
  void *buffer = NULL;
  BalloonVolume v = ball_volume(&BALL, 1, BALLOON_SCALAR_F32, I_FASTEST, &buffer);
  BalloonTriMesh *sphere = NULL;
  BalloonMesh in;
  EXPECT_OK(balloon_marching_cubes(&v, 100.0, 1, &sphere));
  EXPECT_OK(balloon_trimesh_view(sphere, &in));
  const uint32_t *map = (const uint32_t *)&in;
  size_t count = 999;
  EXPECT_OK(balloon_trimesh_vertex_map(sphere, &map, &count));
  CHECK(map == NULL && count == 0, "marching cubes has no vertex map");

  BalloonTriMesh *const sentinel = (BalloonTriMesh *)(uintptr_t)0x1234;
  BalloonTriMesh *out = sentinel;
  const double *p = in.points;
  const uint32_t *t = in.triangles;
  size_t np = in.point_count, nt = in.triangle_count;
  EXPECT_ERROR(balloon_simplify(p, np, t, nt, 0.2, NULL), BALLOON_NULL_POINTER, "out");
  EXPECT_ERROR(balloon_simplify(NULL, np, t, nt, 0.2, &out), BALLOON_NULL_POINTER, "points");
  EXPECT_ERROR(balloon_simplify(p, np, NULL, nt, 0.2, &out), BALLOON_NULL_POINTER, "triangles");
  const double bad_bounds[4] = {0.0, -1.0, NAN, INFINITY};
  for (int i = 0; i < 4; ++i)
    EXPECT_ERROR(balloon_simplify(p, np, t, nt, bad_bounds[i], &out), BALLOON_INVALID_ARGUMENT,
                 "positive distance");
  EXPECT_ERROR(balloon_simplify(p, np, t, nt - 1, 0.2, &out), BALLOON_INVALID_MESH,
               "not closed");
  EXPECT_ERROR(balloon_simplify(CROSS_POINTS, 6, CROSS_TRIANGLES, 2, 0.2, &out),
               BALLOON_INVALID_MESH, "not closed");
  EXPECT_ERROR(balloon_simplify(p, np - 1, t, nt, 0.2, &out), BALLOON_INVALID_MESH,
               "but the mesh has");
  EXPECT_ERROR(balloon_simplify(NULL, 0, NULL, 0, 0.2, &out), BALLOON_INVALID_MESH,
               "no triangles");
  CHECK(out == sentinel, "*out is written only on success");

  EXPECT_OK(balloon_simplify(p, np, t, nt, 0.2, &out));
  BalloonMesh m;
  EXPECT_OK(balloon_trimesh_view(out, &m));
  BalloonMeshReport before = check_mesh(&in), after = check_mesh(&m);
  CHECK(after.closed && after.manifold && after.oriented && after.outward == before.outward,
        "closed %d manifold %d oriented %d outward %d (before %d)", after.closed, after.manifold,
        after.oriented, after.outward, before.outward);
  CHECK(after.self_intersecting_pairs == 0 && after.genus == before.genus &&
            after.components == before.components,
        "%zu pairs, genus %lld, %zu components", after.self_intersecting_pairs,
        (long long)after.genus, after.components);
  CHECK(m.vertex_state == NULL && m.triangle_count < nt / 2, "%zu of %zu triangles",
        m.triangle_count, nt);
  /* A 0.2 mm bound both ways changes the enclosed volume by less than the area times 0.2. */
  CHECK(fabs(after.volume_mm3 - before.volume_mm3) < 0.2 * before.area_mm2, "volume %g vs %g",
        after.volume_mm3, before.volume_mm3);

  EXPECT_ERROR(balloon_trimesh_vertex_map(NULL, &map, &count), BALLOON_NULL_POINTER, "m");
  EXPECT_ERROR(balloon_trimesh_vertex_map(out, NULL, &count), BALLOON_NULL_POINTER, "map_out");
  EXPECT_ERROR(balloon_trimesh_vertex_map(out, &map, NULL), BALLOON_NULL_POINTER, "count_out");
  EXPECT_OK(balloon_trimesh_vertex_map(out, &map, &count));
  CHECK(map != NULL && count == np, "a map of %zu entries for %zu points", count, np);
  char *hit = (char *)calloc(m.point_count + 1, 1);
  size_t unused = 0, outside = 0;
  for (size_t i = 0; map && i < count; ++i) {
    if (map[i] == BALLOON_NO_VERTEX)
      ++unused;
    else if (map[i] >= m.point_count)
      ++outside;
    else
      hit[map[i]] = 1;
  }
  size_t missed = 0;
  for (size_t i = 0; i < m.point_count; ++i) missed += !hit[i];
  CHECK(unused == 0 && outside == 0 && missed == 0,
        "%zu points unused, %zu mapped outside, %zu output vertices without an input", unused,
        outside, missed);
  free(hit);

  /* With a callback: the same mesh, fractions rising within (0, 1] in the phase
   * "simplification"; a callback that cancels gets BALLOON_CANCELLED and *out stays as it was. */
  Progress watch = {0, -1, 0.0, 0};
  BalloonTriMesh *again = NULL;
  EXPECT_OK(balloon_simplify_with_progress(p, np, t, nt, 0.2, on_simplify_progress, &watch,
                                           &again));
  BalloonMesh m2;
  EXPECT_OK(balloon_trimesh_view(again, &m2));
  Flat first = flat_copy(&m), second = flat_copy(&m2);
  CHECK(flat_equal(&first, &second), "the callback changed the mesh");
  CHECK(watch.calls >= 1 && !watch.bad_phase && watch.last_fraction > 0.0,
        "%d calls, last fraction %g, bad phase or order %d", watch.calls, watch.last_fraction,
        watch.bad_phase);
  flat_free(&first);
  flat_free(&second);
  balloon_trimesh_free(again);
  balloon_trimesh_free(out);
  Progress stop = {0, 1, 0.0, 0};
  out = sentinel;
  EXPECT_ERROR(balloon_simplify_with_progress(p, np, t, nt, 0.2, on_simplify_progress, &stop, &out),
               BALLOON_CANCELLED, "cancelled");
  CHECK(stop.calls == 1 && out == sentinel, "%d calls, *out written on a cancel", stop.calls);
  EXPECT_ERROR(balloon_simplify_with_progress(p, np, t, nt, 0.2, NULL, NULL, NULL),
               BALLOON_NULL_POINTER, "out");

  balloon_trimesh_free(sphere);
  free(buffer);
}

/* simplify_error_mm: checked like every parameter; 0 (the default) leaves the result as it was,
 * a positive bound gives balloon_segment + balloon_mesh a simplified, still valid surface with
 * its vertex states. */
static void test_simplified_segmentation(void) {
  void *buffer = NULL;
  BalloonVolume v = ball_volume(&BALL, 1, BALLOON_SCALAR_F32, I_FASTEST, &buffer);
  BalloonParams p = window_params(2);
  double seed[3];
  index_to_world(&BALL, seed);
  CHECK(p.simplify_error_mm == 0, "off by default: %g", p.simplify_error_mm);
  EXPECT_ERROR(balloon_params_set(&p, "simplify_error_mm", -1), BALLOON_INVALID_ARGUMENT,
               "simplify_error_mm is -1");
  EXPECT_ERROR(balloon_params_set(&p, "simplify_error_mm", NAN), BALLOON_INVALID_ARGUMENT,
               "at least 0");
  EXPECT_ERROR(balloon_params_set(&p, "simplify_error_mm", INFINITY), BALLOON_INVALID_ARGUMENT,
               "finite");
  CHECK(p.simplify_error_mm == 0, "a refused value changes nothing");
  BalloonSegmenter *const sentinel = (BalloonSegmenter *)(uintptr_t)0x1234;
  BalloonSegmenter *s = sentinel;
  BalloonParams bad = p;
  bad.simplify_error_mm = -0.5;
  EXPECT_ERROR(balloon_init(&v, &bad, seed, &s), BALLOON_INVALID_ARGUMENT, "simplify_error_mm");
  CHECK(s == sentinel, "no output is written on failure");

  Flat full = segment_copy(&v, &p, seed);
  EXPECT_OK(balloon_params_set(&p, "simplify_error_mm", 0.3));
  CHECK(p.simplify_error_mm == 0.3, "set by name reaches the field: %g", p.simplify_error_mm);
  s = NULL;
  EXPECT_OK(balloon_init(&v, &p, seed, &s));
  EXPECT_OK(balloon_segment(s));
  BalloonMesh m;
  EXPECT_OK(balloon_mesh(s, &m));
  expect_valid_spheres(&m, 1, "simplified balloon");
  CHECK(m.triangle_count > 0 && m.triangle_count < full.triangle_count,
        "%zu triangles simplified, %zu before", m.triangle_count, full.triangle_count);
  CHECK(m.vertex_state != NULL, "the simplified mesh has vertex states");
  size_t at_border = 0;
  for (size_t i = 0; m.vertex_state && i < m.point_count; ++i) {
    CHECK(m.vertex_state[i] <= BALLOON_VERTEX_FROZEN_BY_SELF_INTERSECTION, "state %u",
          m.vertex_state[i]);
    at_border += m.vertex_state[i] == BALLOON_VERTEX_FROZEN_AT_BORDER;
  }
  CHECK(at_border > m.point_count / 2, "%zu of %zu at the border", at_border, m.point_count);
  balloon_free(s);
  flat_free(&full);
  free(buffer);
}


static void test_mesh_check_and_self_intersections(void) {
  BalloonMeshReport r;
  memset(&r, 0, sizeof r);
  r.struct_size = sizeof r;
  EXPECT_ERROR(balloon_mesh_check(TET_POINTS, 4, TET_TRIANGLES, 4, NULL), BALLOON_NULL_POINTER,
               "out");
  EXPECT_ERROR(balloon_mesh_check(NULL, 4, TET_TRIANGLES, 4, &r), BALLOON_NULL_POINTER,
               "points");
  EXPECT_ERROR(balloon_mesh_check(TET_POINTS, 4, NULL, 4, &r), BALLOON_NULL_POINTER,
               "triangles");
  EXPECT_ERROR(balloon_mesh_check(TET_POINTS, 3, TET_TRIANGLES, 4, &r), BALLOON_INVALID_MESH,
               "3 points");
  double nan_points[12];
  memcpy(nan_points, TET_POINTS, sizeof nan_points);
  nan_points[7] = NAN;
  EXPECT_ERROR(balloon_mesh_check(nan_points, 4, TET_TRIANGLES, 4, &r), BALLOON_INVALID_MESH,
               "finite");
  r.struct_size = sizeof r + 8;
  EXPECT_ERROR(balloon_mesh_check(TET_POINTS, 4, TET_TRIANGLES, 4, &r),
               BALLOON_PARAMS_SIZE_MISMATCH, "BalloonMeshReport");
  CHECK(r.struct_size == sizeof r + 8 && r.closed == 0, "nothing written on failure");
  r.struct_size = sizeof r;
  EXPECT_OK(balloon_mesh_check(TET_POINTS, 4, TET_TRIANGLES, 4, &r));
  CHECK(r.closed && r.manifold && r.oriented && r.outward && r.genus == 0 &&
            r.euler_characteristic == 2 && r.components == 1 && r.self_intersecting_pairs == 0,
        "tetrahedron");
  CHECK(fabs(r.volume_mm3 - 1.0 / 6.0) < 1e-12, "volume %g", r.volume_mm3);
  EXPECT_OK(balloon_mesh_check(CROSS_POINTS, 6, CROSS_TRIANGLES, 2, &r));
  CHECK(!r.closed && r.genus == -1 && r.self_intersecting_pairs == 1, "crossing triangles");
  EXPECT_OK(balloon_mesh_check(NULL, 0, NULL, 0, &r));
  CHECK(r.components == 0 && r.genus == -1, "the empty mesh");

  size_t count = 999;
  uint32_t pairs[4] = {7, 7, 7, 7};
  EXPECT_ERROR(balloon_self_intersections(CROSS_POINTS, 6, CROSS_TRIANGLES, 2, pairs, 2, NULL),
               BALLOON_NULL_POINTER, "pair_count_out");
  EXPECT_ERROR(balloon_self_intersections(CROSS_POINTS, 6, CROSS_TRIANGLES, 2, NULL, 2, &count),
               BALLOON_NULL_POINTER, "pairs_out");
  EXPECT_ERROR(balloon_self_intersections(NULL, 6, CROSS_TRIANGLES, 2, pairs, 2, &count),
               BALLOON_NULL_POINTER, "points");
  EXPECT_ERROR(balloon_self_intersections(CROSS_POINTS, 6, NULL, 2, pairs, 2, &count),
               BALLOON_NULL_POINTER, "triangles");
  EXPECT_ERROR(balloon_self_intersections(CROSS_POINTS, 5, CROSS_TRIANGLES, 2, pairs, 2, &count),
               BALLOON_INVALID_MESH, "5 points");
  CHECK(count == 999, "no count on other errors");
  /* The size-query protocol: the count comes with BUFFER_TOO_SMALL, nothing is copied. */
  EXPECT_ERROR(balloon_self_intersections(CROSS_POINTS, 6, CROSS_TRIANGLES, 2, NULL, 0, &count),
               BALLOON_BUFFER_TOO_SMALL, "room for 0");
  CHECK(count == 1, "%zu pairs", count);
  EXPECT_OK(balloon_self_intersections(CROSS_POINTS, 6, CROSS_TRIANGLES, 2, pairs, 2, &count));
  CHECK(count == 1 && pairs[0] == 0 && pairs[1] == 1 && pairs[2] == 7, "pair %u %u", pairs[0],
        pairs[1]);
  EXPECT_OK(balloon_self_intersections(TET_POINTS, 4, TET_TRIANGLES, 4, NULL, 0, &count));
  CHECK(count == 0, "a tetrahedron does not intersect itself");
}

/* Several objects at once: two balls, each an object with its own label, come back in the order
 * given, each a closed sphere; a stop seed's balloon is left out; a region of interest cuts an
 * object; pointers, sizes and labels are checked. */
static int cancel_objects(double fraction, const char *phase, void *calls) {
  (void)fraction;
  (void)phase;
  ++*(int *)calls;
  return 1;
}

static void test_objects(void) {
  const Ball balls[2] = {{6.5, 12.0, 12.0, 4.5}, {17.5, 12.0, 12.0, 4.5}};
  void *buffer = NULL;
  BalloonVolume v = ball_volume(balls, 2, BALLOON_SCALAR_F32, I_FASTEST, &buffer);
  BalloonParams p = window_params(1);
  double a[3], b[3];
  index_to_world(&balls[0], a);
  index_to_world(&balls[1], b);
  BalloonObjectSeeds objects[2];
  objects[0].label = 7;
  objects[0].points = b;
  objects[0].point_count = 1;
  objects[1].label = 3;
  objects[1].points = a;
  objects[1].point_count = 1;
  BalloonObjects *r = NULL;
  EXPECT_OK(balloon_segment_objects(&v, &p, objects, 2, NULL, 0, NULL, NULL, NULL, &r));
  size_t count = 0;
  EXPECT_OK(balloon_objects_count(r, &count));
  CHECK(count == 2, "%zu objects", count);
  double volumes[2] = {0, 0};
  for (size_t i = 0; i < count && i < 2; ++i) {
    uint32_t label = 0;
    BalloonMesh m;
    BalloonStats stats;
    EXPECT_OK(balloon_objects_label(r, i, &label));
    CHECK(label == objects[i].label, "object %zu has label %u, not %u", i, label,
          objects[i].label);
    EXPECT_OK(balloon_objects_mesh(r, i, &m));
    CHECK(m.vertex_state != NULL, "object %zu has vertex states", i);
    expect_valid_spheres(&m, 1, "an object");
    volumes[i] = check_mesh(&m).volume_mm3;
    double lo = m.points[0];
    double hi = m.points[0];
    for (size_t k = 0; k < m.point_count; ++k) {
      lo = fmin(lo, m.points[3 * k]);
      hi = fmax(hi, m.points[3 * k]);
    }
    const double *centre = objects[i].points;
    CHECK(lo < centre[0] && centre[0] < hi && hi - lo < 11.0, "object %u spans x %g..%g", label,
          lo, hi);
    stats.struct_size = sizeof stats;
    EXPECT_OK(balloon_objects_stats(r, i, &stats));
    CHECK(stats.iterations > 0 && stats.reference_intensity == 200.0, "stats of object %u",
          label);
    stats.struct_size = 8;
    EXPECT_ERROR(balloon_objects_stats(r, i, &stats), BALLOON_PARAMS_SIZE_MISMATCH, "struct_size");
  }
  /* A ball of radius 4.5 voxels of 1 x 1.25 x 0.8 mm: about 382 mm^3. */
  CHECK(fabs(volumes[0] - volumes[1]) < 0.05 * volumes[0] && volumes[0] > 250.0,
        "volumes %g and %g", volumes[0], volumes[1]);
  uint32_t label = 0;
  BalloonMesh m;
  EXPECT_ERROR(balloon_objects_label(r, 2, &label), BALLOON_INVALID_ARGUMENT, "index 2");
  EXPECT_ERROR(balloon_objects_mesh(r, 5, &m), BALLOON_INVALID_ARGUMENT, "index 5");
  EXPECT_ERROR(balloon_objects_label(r, 0, NULL), BALLOON_NULL_POINTER, "label_out");
  EXPECT_ERROR(balloon_objects_mesh(r, 0, NULL), BALLOON_NULL_POINTER, "out");
  EXPECT_ERROR(balloon_objects_count(r, NULL), BALLOON_NULL_POINTER, "count_out");
  EXPECT_ERROR(balloon_objects_count(NULL, &count), BALLOON_NULL_POINTER, "r is NULL");
  balloon_objects_free(r);
  balloon_objects_free(NULL);

  /* A stop seed in the second ball: only the first object comes back. */
  r = NULL;
  EXPECT_OK(balloon_segment_objects(&v, &p, &objects[1], 1, b, 1, NULL, NULL, NULL, &r));
  count = 0;
  if (r) {
    EXPECT_OK(balloon_objects_count(r, &count));
    EXPECT_OK(balloon_objects_label(r, 0, &label));
    CHECK(count == 1 && label == 3, "%zu objects with a stop seed, label %u", count, label);
    EXPECT_OK(balloon_objects_mesh(r, 0, &m));
    expect_valid_spheres(&m, 1, "an object beside a stop seed");
  }
  balloon_objects_free(r);

  /* A region of interest that ends 1 mm past the first ball's centre cuts it. */
  double roi[6] = {ORIGIN[0], ORIGIN[1], ORIGIN[2], a[0] + 1.0, ORIGIN[1] + 30.0,
                   ORIGIN[2] + 20.0};
  r = NULL;
  EXPECT_OK(balloon_segment_objects(&v, &p, &objects[1], 1, NULL, 0, roi, NULL, NULL, &r));
  if (r) {
    EXPECT_OK(balloon_objects_mesh(r, 0, &m));
    expect_valid_spheres(&m, 1, "an object cut by the region");
    double hi = -1e300;
    for (size_t k = 0; k < m.point_count; ++k) hi = fmax(hi, m.points[3 * k]);
    CHECK(hi < a[0] + 1.6, "the cut object reaches x = %g, the region ends at %g", hi,
          a[0] + 1.0);
  }
  balloon_objects_free(r);

  /* A stop seed outside the region is named. */
  r = NULL;
  EXPECT_ERROR(balloon_segment_objects(&v, &p, &objects[1], 1, b, 1, roi, NULL, NULL, &r),
               BALLOON_INVALID_ARGUMENT, "outside the region");
  CHECK(r == NULL, "no result on failure");

  /* Errors: nothing is written to *out. */
  BalloonObjects *untouched = (BalloonObjects *)&count;
  r = untouched;
  objects[0].label = 0;
  EXPECT_ERROR(balloon_segment_objects(&v, &p, objects, 2, NULL, 0, NULL, NULL, NULL, &r),
               BALLOON_INVALID_ARGUMENT, "label 0");
  objects[0].label = 3;
  EXPECT_ERROR(balloon_segment_objects(&v, &p, objects, 2, NULL, 0, NULL, NULL, NULL, &r),
               BALLOON_INVALID_ARGUMENT, "twice");
  objects[0].label = 7;
  EXPECT_ERROR(balloon_segment_objects(&v, &p, NULL, 2, NULL, 0, NULL, NULL, NULL, &r),
               BALLOON_NULL_POINTER, "objects is NULL");
  EXPECT_ERROR(balloon_segment_objects(&v, &p, objects, 0, NULL, 0, NULL, NULL, NULL, &r),
               BALLOON_INVALID_ARGUMENT, "no object");
  EXPECT_ERROR(balloon_segment_objects(&v, &p, objects, 2, NULL, 1, NULL, NULL, NULL, &r),
               BALLOON_NULL_POINTER, "stops is NULL");
  EXPECT_ERROR(balloon_segment_objects(NULL, &p, objects, 2, NULL, 0, NULL, NULL, NULL, &r),
               BALLOON_NULL_POINTER, "volume");
  EXPECT_ERROR(balloon_segment_objects(&v, &p, objects, 2, NULL, 0, NULL, NULL, NULL, NULL),
               BALLOON_NULL_POINTER, "out");
  objects[1].points = NULL;
  EXPECT_ERROR(balloon_segment_objects(&v, &p, objects, 2, NULL, 0, NULL, NULL, NULL, &r),
               BALLOON_NULL_POINTER, "objects[1].points");
  objects[1].points = a;
  objects[1].point_count = 0;
  EXPECT_ERROR(balloon_segment_objects(&v, &p, objects, 2, NULL, 0, NULL, NULL, NULL, &r),
               BALLOON_INVALID_ARGUMENT, "no seed");
  objects[1].point_count = 1;
  double nan_seed[3] = {NAN, b[1], b[2]};
  objects[0].points = nan_seed;
  EXPECT_ERROR(balloon_segment_objects(&v, &p, objects, 2, NULL, 0, NULL, NULL, NULL, &r),
               BALLOON_INVALID_ARGUMENT, "not finite");
  objects[0].points = b;
  EXPECT_ERROR(balloon_segment_objects(&v, &p, objects, 2, a, 1, NULL, NULL, NULL, &r),
               BALLOON_INVALID_ARGUMENT, "stop seed");
  double flat[6] = {a[0], a[1], a[2], b[0], a[1], b[2] + 1.0};
  EXPECT_ERROR(balloon_segment_objects(&v, &p, objects, 2, NULL, 0, flat, NULL, NULL, &r),
               BALLOON_INVALID_ARGUMENT, "flat");
  int calls = 0;
  EXPECT_ERROR(balloon_segment_objects(&v, &p, objects, 2, NULL, 0, NULL, cancel_objects, &calls,
                                       &r),
               BALLOON_CANCELLED, "cancel");
  CHECK(calls >= 1, "the callback was called %d times", calls);
  CHECK(r == untouched, "*out is written only on success");
  free(buffer);
}

int main(void) {
  CHECK(balloon_last_error_message(NULL, 0) == 0, "no message before the first error");
  test_version_and_status_strings();
  test_last_error_message();
  test_params();
  test_param_table();
  test_init_errors();
  test_driven_by_hand();
  test_cancel();
  test_types_and_layouts();
  test_two_seeds_and_leak();
  test_marching_cubes();
  test_simplify();
  test_simplified_segmentation();
  test_mesh_check_and_self_intersections();
  test_objects();
  return report("test_c_api");
}
