// The C API from C++: the header compiles as C++ (extern "C"), handles wrapped in RAII, and
// two handles segmenting at once on two std::threads give bit for bit the meshes of the
// sequential runs. Every function is called. Exits non-zero when a check fails.
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "test_support.h"

namespace {

struct SegmenterDeleter {
  void operator()(BalloonSegmenter *s) const { balloon_free(s); }
};
struct TriMeshDeleter {
  void operator()(BalloonTriMesh *m) const { balloon_trimesh_free(m); }
};
struct ObjectsDeleter {
  void operator()(BalloonObjects *r) const { balloon_objects_free(r); }
};
using Segmenter = std::unique_ptr<BalloonSegmenter, SegmenterDeleter>;
using Objects = std::unique_ptr<BalloonObjects, ObjectsDeleter>;
using TriMesh = std::unique_ptr<BalloonTriMesh, TriMeshDeleter>;

struct Voxels {
  void *buffer = nullptr;  // before `volume`, which ball_volume fills it for
  BalloonVolume volume;
  Voxels(const Ball *balls, int count, uint32_t type, Layout layout)
      : volume(ball_volume(balls, count, type, layout, &buffer)) {}
  ~Voxels() { free(buffer); }
  Voxels(const Voxels &) = delete;
  Voxels &operator=(const Voxels &) = delete;
};

// What a thread brings back: only plain data, checked on the main thread.
struct Run {
  BalloonStatus status = BALLOON_INTERNAL_ERROR;
  std::vector<double> points;
  std::vector<uint32_t> triangles;
  std::vector<uint8_t> states;
};

Run segment(const BalloonVolume &v, const BalloonParams &p, const double seed[3]) {
  Run run;
  BalloonSegmenter *raw = nullptr;
  run.status = balloon_init(&v, &p, seed, &raw);
  Segmenter s(raw);
  if (run.status != BALLOON_OK) return run;
  run.status = balloon_segment(s.get());
  BalloonMesh m;
  if (run.status == BALLOON_OK) run.status = balloon_mesh(s.get(), &m);
  if (run.status != BALLOON_OK) return run;
  run.points.assign(m.points, m.points + 3 * m.point_count);
  run.triangles.assign(m.triangles, m.triangles + 3 * m.triangle_count);
  run.states.assign(m.vertex_state, m.vertex_state + m.point_count);
  return run;
}

BalloonMesh view(const Run &r) {
  BalloonMesh m = {r.points.data(), r.points.size() / 3, r.triangles.data(),
                   r.triangles.size() / 3, r.states.data()};
  return m;
}

bool same(const Run &a, const Run &b) {
  return a.status == b.status && a.points.size() == b.points.size() &&
         std::memcmp(a.points.data(), b.points.data(), a.points.size() * sizeof(double)) == 0 &&
         a.triangles == b.triangles && a.states == b.states;
}

const Ball kBall = {11.5, 12.0, 11.0, 7.0};
const Ball kSmall = {12.0, 11.0, 12.5, 5.5};

void two_handles_on_two_threads() {
  Voxels a(&kBall, 1, BALLOON_SCALAR_I16, I_FASTEST);
  Voxels b(&kSmall, 1, BALLOON_SCALAR_F32, K_FASTEST);
  BalloonParams pa = window_params(1), pb = window_params(2);
  double seed_a[3], seed_b[3];
  index_to_world(&kBall, seed_a);
  index_to_world(&kSmall, seed_b);

  const Run seq_a = segment(a.volume, pa, seed_a), seq_b = segment(b.volume, pb, seed_b);
  CHECK(seq_a.status == BALLOON_OK && seq_b.status == BALLOON_OK, "sequential runs: %d %d",
        seq_a.status, seq_b.status);
  BalloonMesh ma = view(seq_a), mb = view(seq_b);
  expect_valid_spheres(&ma, 1, "sequential a");
  expect_valid_spheres(&mb, 1, "sequential b");

  Run par_a, par_b;
  size_t fresh_thread_message = 12345;
  std::thread ta([&] {
    fresh_thread_message = balloon_last_error_message(nullptr, 0);
    par_a = segment(a.volume, pa, seed_a);
  });
  std::thread tb([&] { par_b = segment(b.volume, pb, seed_b); });
  ta.join();
  tb.join();
  CHECK(fresh_thread_message == 0, "a new thread has no message (%zu)", fresh_thread_message);
  CHECK(same(par_a, seq_a), "thread a: %zu points vs %zu", par_a.points.size() / 3,
        seq_a.points.size() / 3);
  CHECK(same(par_b, seq_b), "thread b: %zu points vs %zu", par_b.points.size() / 3,
        seq_b.points.size() / 3);

  // An error on one thread does not show on another.
  std::string other;
  std::thread tc([&] {
    balloon_init(nullptr, nullptr, nullptr, nullptr);
    std::vector<char> text(balloon_last_error_message(nullptr, 0) + 1);
    balloon_last_error_message(text.data(), text.size());
    other = text.data();
  });
  tc.join();
  CHECK(!other.empty() && other != last_error(), "per-thread messages: \"%s\"", other.c_str());
}

int cancel_after_two(double, const char *, void *user_data) {
  return ++*static_cast<int *>(user_data) >= 2;
}

void every_function_once() {
  CHECK(std::string(balloon_version()) ==
            std::to_string(BALLOON_VERSION_MAJOR) + "." + std::to_string(BALLOON_VERSION_MINOR) +
                "." + std::to_string(BALLOON_VERSION_PATCH),
        "version %s", balloon_version());
  CHECK(std::string(balloon_status_string(static_cast<BalloonStatus>(42))) == "unknown status",
        "out of range");
  CHECK(std::string(balloon_status_string(BALLOON_OK)) != "unknown status", "OK");

  Voxels v(&kBall, 1, BALLOON_SCALAR_U8, I_REVERSED);
  BalloonParams p;
  EXPECT_OK(balloon_params_default(&p));
  EXPECT_ERROR(balloon_params_default(nullptr), BALLOON_NULL_POINTER, "out");
  // The parameters by name, as a binding that builds its setters from the table would.
  std::vector<std::string> names;
  for (std::size_t i = 0; i < balloon_param_count(); ++i) {
    BalloonParamInfo info{};
    info.struct_size = sizeof info;
    EXPECT_OK(balloon_param_info(i, &info));
    names.emplace_back(info.name);
  }
  CHECK(names.size() == 14 && names.front() == "reference_intensity" &&
            names.back() == "simplify_error_mm",
        "%zu parameters", names.size());
  EXPECT_OK(balloon_params_set(&p, "reference_intensity", 200));
  EXPECT_OK(balloon_params_set(&p, "tolerance", 100));
  double tolerance = 0;
  EXPECT_OK(balloon_params_get(&p, "tolerance", &tolerance));
  CHECK(p.reference_intensity == 200 && tolerance == 100, "set by name");
  double seed[3];
  index_to_world(&kBall, seed);
  BalloonSegmenter *raw = nullptr;
  EXPECT_ERROR(balloon_init(&v.volume, &p, nullptr, &raw), BALLOON_NULL_POINTER, "seed_world");
  EXPECT_OK(balloon_init(&v.volume, &p, seed, &raw));
  Segmenter s(raw);
  int calls = 0;
  EXPECT_OK(balloon_set_progress_callback(s.get(), cancel_after_two, &calls));
  EXPECT_ERROR(balloon_step(s.get(), 50, nullptr), BALLOON_CANCELLED, "cancelled");
  BalloonMesh m;
  EXPECT_OK(balloon_mesh(s.get(), &m));
  expect_valid_spheres(&m, 1, "cancelled step");
  EXPECT_OK(balloon_set_progress_callback(s.get(), nullptr, nullptr));
  uint32_t active = 0;
  EXPECT_OK(balloon_step(s.get(), 5, &active));
  size_t frozen = 0;
  EXPECT_OK(balloon_freeze_self_intersections(s.get(), &frozen));
  EXPECT_OK(balloon_reparametrize(s.get()));
  double second[3] = {seed[0] + 3.0, seed[1], seed[2]};
  EXPECT_OK(balloon_add_seed(s.get(), second));
  EXPECT_OK(balloon_segment(s.get()));
  EXPECT_OK(balloon_mesh(s.get(), &m));
  expect_valid_spheres(&m, 1, "two overlapping seeds");
  BalloonStats stats;
  stats.struct_size = sizeof stats;
  EXPECT_OK(balloon_stats(s.get(), &stats));
  CHECK(stats.reparametrizations >= 1, "%u", stats.reparametrizations);

  BalloonTriMesh *raw_mesh = nullptr;
  EXPECT_OK(balloon_marching_cubes(&v.volume, 100.0, 0, &raw_mesh));
  TriMesh mc(raw_mesh);
  EXPECT_OK(balloon_trimesh_view(mc.get(), &m));
  expect_inward_sphere(&m, "marching cubes");
  size_t count = 0;
  EXPECT_OK(balloon_self_intersections(m.points, m.point_count, m.triangles, m.triangle_count,
                                       nullptr, 0, &count));
  CHECK(count == 0, "%zu pairs", count);
  BalloonTriMesh *raw_simplified = nullptr;
  EXPECT_OK(balloon_simplify(m.points, m.point_count, m.triangles, m.triangle_count, 0.2,
                             &raw_simplified));
  TriMesh simplified(raw_simplified);
  const uint32_t *map = nullptr;
  size_t map_count = 0;
  EXPECT_OK(balloon_trimesh_vertex_map(simplified.get(), &map, &map_count));
  CHECK(map != nullptr && map_count == m.point_count, "%zu map entries", map_count);
  BalloonMesh reduced;
  EXPECT_OK(balloon_trimesh_view(simplified.get(), &reduced));
  expect_inward_sphere(&reduced, "simplified marching cubes");
  CHECK(reduced.triangle_count < m.triangle_count, "%zu of %zu triangles",
        reduced.triangle_count, m.triangle_count);
  EXPECT_ERROR(balloon_simplify(m.points, m.point_count, m.triangles, m.triangle_count, -1.0,
                                &raw_simplified),
               BALLOON_INVALID_ARGUMENT, "positive distance");
  int simplify_calls = 0;
  EXPECT_ERROR(balloon_simplify_with_progress(m.points, m.point_count, m.triangles,
                                              m.triangle_count, 0.2, cancel_after_two,
                                              &simplify_calls, &raw_simplified),
               BALLOON_CANCELLED, "cancelled");
  CHECK(simplify_calls == 2, "%d progress calls before the cancel", simplify_calls);

  BalloonObjectSeeds object = {5, seed, 1};
  BalloonObjects *raw_objects = nullptr;
  EXPECT_OK(balloon_segment_objects(&v.volume, &p, &object, 1, nullptr, 0, nullptr, nullptr,
                                    nullptr, &raw_objects));
  Objects objects(raw_objects);
  size_t object_count = 0;
  uint32_t label = 0;
  EXPECT_OK(balloon_objects_count(objects.get(), &object_count));
  EXPECT_OK(balloon_objects_label(objects.get(), 0, &label));
  CHECK(object_count == 1 && label == 5, "%zu objects, label %u", object_count, label);
  EXPECT_OK(balloon_objects_mesh(objects.get(), 0, &m));
  expect_valid_spheres(&m, 1, "one object");
  EXPECT_OK(balloon_objects_stats(objects.get(), 0, &stats));
  balloon_objects_free(nullptr);
  std::vector<char> small(4, 'x');
  size_t n = balloon_last_error_message(small.data(), small.size());
  CHECK(n > 3 && small[3] == '\0', "truncated to 3 bytes of %zu", n);
  balloon_free(nullptr);
  balloon_trimesh_free(nullptr);
}

}  // namespace

int main() {
  every_function_once();
  two_handles_on_two_threads();
  return report("test_cpp_api");
}
