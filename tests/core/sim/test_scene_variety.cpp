// Scene variety: static look-alikes are background, object and camera motion kinds follow
// their formulas, occluder kinds cover the expected share of the view, config errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "core/sim/presets.h"
#include "core/sim/renderer.h"
#include "core/sim/simulate.h"
#include "core/util/error.h"
#include "sim_test_util.h"

using namespace spikems;
using namespace spikems::sim;

namespace {

Scene scene_for(const SimConfig& cfg, uint64_t seed) {
  std::mt19937_64 rng(seed);
  return make_random_scene(cfg, camera_from_config(cfg), rng);
}

// Indices of the static look-alikes: id-0 objects that are not background or occluders.
std::vector<size_t> look_alikes(const Scene& s) {
  std::vector<size_t> out;
  for (size_t i = 0; i < s.shapes.size(); ++i) {
    const Shape& sh = s.shapes[i];
    if (sh.id == 0 && sh.kind != ShapeKind::Room && sh.kind != ShapeKind::Net &&
        sh.label != "plane")
      out.push_back(i);
  }
  return out;
}

double angle_of(const Quat& q) {
  return 2 * std::acos(std::clamp(std::fabs(q.w), 0.0, 1.0));
}

}  // namespace

// Moving camera, three static look-alikes and no moving object: no event and no mask pixel
// carries an object id, yet the look-alikes make events where they are seen (their footprint
// at mid-sequence, +-20 ms); each is in view at mid-sequence.
TEST(SimSceneVariety, StaticLookAlikesAreBackground) {
  SimConfig cfg = test::clean_config(96, 72, 0.06);
  cfg.objects_min = cfg.objects_max = 0;
  cfg.static_min = cfg.static_max = 3;
  // Busy textures only: smooth (`gradient`) or coarse (`dead_leaves`) ones make few events on
  // a 125 px footprint by design.
  cfg.textures = {"noise", "checkers"};
  cfg.camera_speed = {1.0, 1.0};
  cfg.camera_angular_speed = {1.5, 1.5};
  const Camera cam = camera_from_config(cfg);
  for (uint64_t seed : {11u, 12u}) {
    Scene s = scene_for(cfg, seed);
    std::vector<size_t> la = look_alikes(s);
    ASSERT_EQ(la.size(), 3u);
    EXPECT_TRUE(s.moving_ids().empty());
    const double t_mid = 0.03;
    const Pose cp = s.camera.at(t_mid);
    const Mat3 Rt = cp.q.to_matrix().transposed();
    for (size_t i : la) {
      EXPECT_TRUE(s.shapes[i].motion.is_static());
      double u, v;
      cam.project(Rt * (s.shapes[i].motion.position - cp.t), u, v);
      EXPECT_GE(u, 0.1 * cam.width - 1e-6);
      EXPECT_LE(u, 0.9 * cam.width + 1e-6);
      EXPECT_GE(v, 0.1 * cam.height - 1e-6);
      EXPECT_LE(v, 0.9 * cam.height + 1e-6);
    }
    Recording rec = simulate_scene(s, cam, cfg, seed);
    ASSERT_GT(rec.events.size(), 1000u);
    for (uint16_t l : rec.events.label) ASSERT_EQ(l, 0);
    for (const auto& m : rec.masks)
      for (uint16_t id : m.ids) ASSERT_EQ(id, 0);
    // Footprint of the look-alikes at mid-sequence; events there within +-10 ms.
    Frame f;
    Renderer(s, cam, cfg.log_eps).render(t_mid, f);
    std::vector<uint8_t> foot(f.surface.size(), 0);
    size_t foot_px = 0;
    for (size_t k = 0; k < f.surface.size(); ++k)
      for (size_t i : la)
        if (f.surface[k] == i + 1) foot[k] = 1, ++foot_px;
    ASSERT_GT(foot_px, 20u) << "seed " << seed;
    size_t on_foot = 0;
    for (size_t e = 0; e < rec.events.size(); ++e)
      if (std::llabs(rec.events.t[e] - 30000) <= 20000 &&
          foot[size_t(rec.events.y[e]) * size_t(cam.width) + rec.events.x[e]])
        ++on_foot;
    EXPECT_GT(on_foot, 50u) << "seed " << seed << ", footprint " << foot_px << " px";
  }
  // With moving objects too: labels are only ever their ids.
  cfg.objects_min = cfg.objects_max = 2;
  Recording rec = simulate_sequence(cfg, 5);
  EXPECT_EQ(rec.moving_ids, (std::vector<uint16_t>{1, 2}));
  for (uint16_t l : rec.events.label) ASSERT_LE(l, 2);
}

// Nearest hit wins between a static look-alike (id 0) and a moving object (id 1): behind the
// look-alike the object vanishes from the mask; in front of it, its mask is the full disc.
TEST(SimSceneVariety, LookAlikesOccludeAndAreOccluded) {
  const int W = 96, H = 72;
  Camera cam{W, H, 100.0, 100.0, 47.5, 35.5};
  Scene s;
  test::flat_light(s);
  int tex = test::uniform_texture(s, 0.5);
  s.shapes.push_back(test::plane(s, 8.0, 50.0, tex));
  const double r = 0.3;
  Shape still;
  still.kind = ShapeKind::Ellipsoid;
  still.half = {r, r, r};
  still.texture = tex;
  still.motion.position = {0, 0, 2.0};
  s.shapes.push_back(still);
  Shape mover = still;
  mover.id = 1;
  mover.motion.position = {0, 0, 3.0};   // behind at t = 0
  mover.motion.velocity = {0, 0, -1.5};  // in front (z = 1.5) at t = 1 s
  s.shapes.push_back(mover);
  Renderer rd(s, cam, 0.01);
  Frame f;
  rd.render(0.0, f);
  // Projected radii: 100 * 0.3 / sqrt(9 - 0.09) = 10.1 px behind, 15.2 px for the look-alike.
  EXPECT_EQ(std::count(f.id.begin(), f.id.end(), 1), 0);
  EXPECT_GT(std::count(f.surface.begin(), f.surface.end(), 2), 600);
  rd.render(1.0, f);
  double area = double(std::count(f.id.begin(), f.id.end(), 1));
  double expect = M_PI * cam.fx * cam.fx * r * r / (1.5 * 1.5 - r * r);
  EXPECT_NEAR(area, expect, 0.03 * expect);
}

// Ballistic: poses follow p(t_ref) + v dt + g dt^2 / 2 with g = 9.81 m/s^2 along world +y
// (down); the rendered mask's centroid tracks the projected centre.
TEST(SimSceneVariety, BallisticFollowsParabola) {
  SimConfig cfg = test::clean_config(160, 120, 0.2);
  cfg.objects_min = cfg.objects_max = 1;
  cfg.shapes = {"sphere"};
  cfg.object_motion = {"ballistic"};
  cfg.object_depth = {2.0, 3.0};
  // Small against its depth: the projected disc's centroid is the projected centre +-0.4 px.
  cfg.object_size = {0.12, 0.15};
  cfg.camera_speed = {0, 0};
  cfg.camera_angular_speed = {0, 0};
  cfg.mask_period_us = 10000;
  const Camera cam = camera_from_config(cfg);
  Scene s = scene_for(cfg, 21);
  ASSERT_EQ(s.shapes.back().id, 1);
  const Trajectory& m = s.shapes.back().motion;
  EXPECT_EQ(s.shapes.back().motion_kind, "ballistic");
  const Vec3 p0 = m.at(m.t_ref).t;
  Recording rec = simulate_scene(s, cam, cfg, 21);
  int checked = 0;
  for (const auto& ps : rec.poses) {
    if (ps.id != 1) continue;
    double dt = ps.t_us * 1e-6 - m.t_ref;
    Vec3 want = p0 + m.velocity * dt + Vec3{0, 9.81, 0} * (0.5 * dt * dt);
    EXPECT_NEAR(ps.translation[0], want.x, 1e-9);
    EXPECT_NEAR(ps.translation[1], want.y, 1e-9);
    EXPECT_NEAR(ps.translation[2], want.z, 1e-9);
    ++checked;
  }
  EXPECT_EQ(checked, 21);
  // Second differences of the recorded y over 10 ms give g.
  std::vector<double> y;
  for (const auto& ps : rec.poses)
    if (ps.id == 1) y.push_back(ps.translation[1]);
  for (size_t k = 1; k + 1 < y.size(); ++k)
    EXPECT_NEAR((y[k + 1] - 2 * y[k] + y[k - 1]) / 1e-4, 9.81, 1e-6);
  // Mask centroids where the ball is wholly in view.
  int centroids = 0;
  for (const auto& mf : rec.masks) {
    double sx = 0, sy = 0, n = 0;
    bool edge = false;
    for (int yy = 0; yy < cam.height; ++yy)
      for (int xx = 0; xx < cam.width; ++xx)
        if (mf.ids[size_t(yy) * size_t(cam.width) + size_t(xx)] == 1) {
          sx += xx, sy += yy, n += 1;
          edge |= xx == 0 || yy == 0 || xx == cam.width - 1 || yy == cam.height - 1;
        }
    if (n < 20 || edge) continue;
    double u, v;
    cam.project(m.at(mf.t_us * 1e-6).t, u, v);  // camera at the origin, no rotation
    EXPECT_NEAR(sx / n, u, 1.0) << "t " << mf.t_us;
    EXPECT_NEAR(sy / n, v, 1.0) << "t " << mf.t_us;
    ++centroids;
  }
  EXPECT_GE(centroids, 10);
}

// Curved: constant speed, heading turning at 0.8-3 rad/s; spin: surface speed = speed, centre
// drifting at a tenth of it. Every kind is in view at mid-sequence.
TEST(SimSceneVariety, CurvedAndSpinMotions) {
  SimConfig cfg = test::clean_config(96, 72, 1.0);
  cfg.objects_min = cfg.objects_max = 4;
  cfg.object_speed = {1.0, 2.0};
  cfg.camera_speed = {0, 0};
  cfg.camera_angular_speed = {0, 0};
  const Camera cam = camera_from_config(cfg);
  auto vel = [](const Trajectory& m, double t) {
    return (m.at(t + 1e-5).t - m.at(t - 1e-5).t) * (1 / 2e-5);
  };
  for (const char* kind : {"curved", "spin", "linear", "ballistic"}) {
    cfg.object_motion = {kind};
    Scene s = scene_for(cfg, 8);
    for (const auto& sh : s.shapes) {
      if (sh.id == 0) continue;
      EXPECT_EQ(sh.motion_kind, kind);
      const Trajectory& m = sh.motion;
      if (std::string(kind) == "linear") continue;  // its sway offsets it (as before kinds)
      double u, v;
      Vec3 c = m.at(0.5).t;
      cam.project(c, u, v);
      EXPECT_GE(u, 0.1 * cam.width - 1e-6) << kind;
      EXPECT_LE(u, 0.9 * cam.width + 1e-6) << kind;
      EXPECT_GE(v, 0.1 * cam.height - 1e-6) << kind;
      EXPECT_LE(v, 0.9 * cam.height + 1e-6) << kind;
      if (std::string(kind) == "curved") {
        Vec3 v0 = vel(m, 0.5), v1 = vel(m, 0.6);
        EXPECT_NEAR(v0.norm(), v1.norm(), 1e-6 * v0.norm());
        EXPECT_GE(v0.norm(), 1.0 - 1e-6);
        EXPECT_LE(v0.norm(), 2.0 + 1e-6);
        double turn = std::acos(std::clamp(v0.dot(v1) / (v0.norm() * v1.norm()), -1.0, 1.0));
        EXPECT_GE(turn, 0.08 - 1e-6);
        EXPECT_LE(turn, 0.30 + 1e-6);
      } else if (std::string(kind) == "spin") {
        double r = sh.half.x;  // radius drawn for every shape kind
        double speed = m.spin.norm() * r;
        EXPECT_GE(speed, 1.0 - 1e-9);
        EXPECT_LE(speed, 2.0 + 1e-9);
        EXPECT_NEAR(vel(m, 0.3).norm(), 0.1 * speed, 1e-6);
      }
    }
  }
}

// Camera kinds: translate never rotates, rotate never translates, shake stays within
// 3-10 Hz with amplitudes bounded by the peak speeds.
TEST(SimSceneVariety, CameraMotionKinds) {
  SimConfig cfg = test::clean_config(64, 48, 2.0);
  cfg.objects_min = cfg.objects_max = 0;
  cfg.camera_speed = {0.5, 0.5};
  cfg.camera_angular_speed = {0.8, 0.8};
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    cfg.camera_motion = {"translate"};
    Scene s = scene_for(cfg, seed);
    EXPECT_EQ(s.camera_motion, "translate");
    double moved = 0;
    for (double t = 0; t <= 2.0; t += 0.05) {
      Pose p = s.camera.at(t);
      EXPECT_NEAR(angle_of(p.q), 0, 1e-12);
      moved = std::max(moved, (p.t - s.camera.at(0).t).norm());
    }
    EXPECT_GT(moved, 0.01);

    cfg.camera_motion = {"rotate"};
    s = scene_for(cfg, seed);
    double turned = 0;
    for (double t = 0; t <= 2.0; t += 0.05) {
      Pose p = s.camera.at(t);
      EXPECT_LT(p.t.norm(), 1e-12);
      Quat d = s.camera.at(0).q;
      d = {d.w, -d.x, -d.y, -d.z};
      turned = std::max(turned, angle_of(p.q * d));
    }
    EXPECT_GT(turned, 0.01);

    cfg.camera_motion = {"shake"};
    s = scene_for(cfg, seed);
    ASSERT_EQ(s.camera.wobble_translation.size(), 3u);
    ASSERT_EQ(s.camera.wobble_rotation.size(), 3u);
    auto check = [](const std::vector<Sinusoid>& w, double peak) {
      for (const auto& k : w) {
        EXPECT_GE(k.freq_hz, 3.0);
        EXPECT_LE(k.freq_hz, 10.0);
        double bound = 1.5 * peak / (2 * M_PI * k.freq_hz * std::sqrt(3.0));
        for (double a : {k.amplitude.x, k.amplitude.y, k.amplitude.z}) EXPECT_LE(a, bound + 1e-12);
      }
    };
    check(s.camera.wobble_translation, 0.5);
    check(s.camera.wobble_rotation, 0.8);

    cfg.camera_motion = {"handheld"};
    s = scene_for(cfg, seed);
    for (const auto& k : s.camera.wobble_translation) EXPECT_LE(k.freq_hz, 1.5);

    // Glide: constant velocity of norm `speed` in the image plane, no rotation.
    cfg.camera_motion = {"glide"};
    s = scene_for(cfg, seed);
    for (double t = 0; t <= 2.0; t += 0.25) {
      Pose p = s.camera.at(t);
      EXPECT_NEAR(angle_of(p.q), 0, 1e-12);
      EXPECT_NEAR(p.t.norm(), 0.5 * t, 1e-9);
      EXPECT_NEAR(p.t.z, 0, 1e-12);
    }
  }
}

// Bars cover bar/spacing of the view, a net 1 - (1 - bar/spacing)^2, foliage its leaf cover;
// occluder pixels are background and a moving object shows through the holes.
TEST(SimSceneVariety, OccluderKindsCoverage) {
  SimConfig cfg = test::clean_config(160, 120, 0.1);
  cfg.background = "planes";
  cfg.planes = 1;
  cfg.plane_depth = {6, 8};  // behind the object
  cfg.objects_min = cfg.objects_max = 1;
  cfg.shapes = {"sphere"};
  cfg.object_size = {0.3, 0.35};
  cfg.camera_speed = {0, 0};
  cfg.camera_angular_speed = {0, 0};
  cfg.leaf_size = {0.02, 0.02};
  cfg.leaf_cover = {0.5, 0.5};
  const Camera cam = camera_from_config(cfg);
  for (const char* kind : {"bars", "net", "foliage"}) {
    cfg.occluder_kinds = {kind};
    for (uint64_t seed = 1; seed <= 3; ++seed) {
      Scene s = scene_for(cfg, seed);
      size_t occ = s.shapes.size();
      for (size_t i = 0; i < s.shapes.size(); ++i)
        if (s.shapes[i].kind == ShapeKind::Net) occ = i;
      ASSERT_LT(occ, s.shapes.size()) << kind;
      const Shape& o = s.shapes[occ];
      EXPECT_EQ(o.id, 0);
      EXPECT_EQ(o.label, kind);
      Frame f;
      Renderer(s, cam, cfg.log_eps).render(0.05, f);
      size_t covered = 0, object = 0;
      for (size_t k = 0; k < f.surface.size(); ++k) {
        if (f.surface[k] == occ + 1) {
          ++covered;
          ASSERT_EQ(f.id[k], 0);
        }
        object += f.id[k] == 1;
      }
      double frac = double(covered) / double(f.surface.size());
      double b = o.net_bar / o.net_spacing;
      if (std::string(kind) == "bars") {
        EXPECT_NEAR(frac, b, 0.03) << "seed " << seed;
      } else if (std::string(kind) == "net") {
        EXPECT_NEAR(frac, 1 - (1 - b) * (1 - b), 0.04) << "seed " << seed;
      } else {
        EXPECT_NEAR(frac, 0.5, 0.1) << "seed " << seed;
      }
      EXPECT_GT(object, 10u) << kind << " seed " << seed;
    }
  }
  cfg.occluder_kinds = {"none"};
  for (const auto& sh : scene_for(cfg, 1).shapes) EXPECT_NE(sh.kind, ShapeKind::Net);
}

// The mod preset draws every kind (40 scenes) and 1-3 look-alikes per scene; presets that do
// not list the new keys draw none of them.
TEST(SimSceneVariety, ModPresetDrawsEveryKind) {
  SimConfig cfg = preset_config("mod");
  cfg.width = 32;
  cfg.height = 24;
  std::set<std::string> cams, objs, occs;
  for (uint64_t seed = 0; seed < 40; ++seed) {
    Scene s = scene_for(cfg, seed);
    cams.insert(s.camera_motion);
    size_t n = look_alikes(s).size();
    EXPECT_GE(n, 1u);
    EXPECT_LE(n, 3u);
    std::string occ = "none";
    for (const auto& sh : s.shapes) {
      if (sh.id != 0) objs.insert(sh.motion_kind);
      if (sh.kind == ShapeKind::Net) occ = sh.label;
    }
    occs.insert(occ);
  }
  EXPECT_EQ(cams, (std::set<std::string>{"handheld", "translate", "rotate", "shake", "glide"}));
  EXPECT_EQ(objs, (std::set<std::string>{"linear", "curved", "ballistic", "spin"}));
  EXPECT_EQ(occs, (std::set<std::string>{"none", "net", "bars", "foliage"}));
  SimConfig tiny = preset_config("tiny");
  for (uint64_t seed = 0; seed < 5; ++seed) {
    Scene s = scene_for(tiny, seed);
    EXPECT_EQ(s.camera_motion, "handheld");
    EXPECT_TRUE(look_alikes(s).empty());
    for (const auto& sh : s.shapes)
      if (sh.id != 0) {
        EXPECT_EQ(sh.motion_kind, "linear");
      }
  }
}

TEST(SimSceneVariety, ConfigKeysAndErrors) {
  SimConfig c = parse_sim_config(
      "[objects]\nmotion = [\"curved\", \"spin\"]\nstatic_min = 1\nstatic_max = 2\n"
      "[camera]\nmotion = [\"shake\"]\nshake_frequency_hz = [4, 8]\n"
      "[occluder]\nkind = [\"none\", \"foliage\"]\nleaf_size = [0.03, 0.05]\n"
      "leaf_cover = [0.3, 0.6]\n",
      "x");
  EXPECT_EQ(c.object_motion, (std::vector<std::string>{"curved", "spin"}));
  EXPECT_EQ(c.static_min, 1);
  EXPECT_EQ(c.static_max, 2);
  EXPECT_EQ(c.camera_motion, std::vector<std::string>{"shake"});
  EXPECT_DOUBLE_EQ(c.shake_frequency_hz.lo, 4);
  EXPECT_EQ(c.occluder_kinds, (std::vector<std::string>{"none", "foliage"}));
  EXPECT_DOUBLE_EQ(c.leaf_cover.hi, 0.6);
  // net = true is kind = ["net"].
  EXPECT_EQ(parse_sim_config("[occluder]\nnet = true\n", "x").occluder_kinds,
            std::vector<std::string>{"net"});
  auto error_names = [](const std::string& toml, const std::string& key) {
    try {
      parse_sim_config(toml, "x");
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
      return;
    }
    ADD_FAILURE() << "accepted: " << toml;
  };
  error_names("[objects]\nmotion = [\"zigzag\"]\n", "[objects] motion");
  error_names("[camera]\nmotion = [\"dolly\"]\n", "[camera] motion");
  error_names("[camera]\nmotion = \"shake\"\n", "[camera] motion");
  error_names("[occluder]\nkind = [\"fog\"]\n", "[occluder] kind");
  error_names("[occluder]\nnet = true\nkind = [\"bars\"]\n", "[occluder] net");
  error_names("[occluder]\nleaf_cover = [0.5, 1.0]\n", "[occluder] leaf_cover");
  error_names("[occluder]\nleaf_size = [0, 0.1]\n", "[occluder] leaf_size");
  error_names("[objects]\nstatic_min = 3\nstatic_max = 1\n", "[objects] static_min");
  error_names("[objects]\nstatic_max = 100\n", "[objects] static_min");
  error_names("[camera]\nshake_frequency_hz = [0, 5]\n", "[camera] shake_frequency_hz");
  error_names("[objects]\nstatick_max = 1\n", "statick_max");
}

// All the new kinds keep determinism: the mod preset (shrunk) with 1 and 2 render threads.
TEST(SimSceneVariety, DeterministicWithEveryKind) {
  SimConfig cfg = preset_config("mod");
  cfg.width = 64;
  cfg.height = 48;
  cfg.duration_us = 30000;
  cfg.occluder_kinds = {"foliage", "bars"};
  for (int i = 0; i < 3; ++i) {
    SimulateOptions one, two;
    two.render_threads = 2;
    Recording a = simulate_sequence(cfg, sequence_seed(9, i), one);
    Recording b = simulate_sequence(cfg, sequence_seed(9, i), two);
    ASSERT_GT(a.events.size(), 100u);
    EXPECT_EQ(a.events.t, b.events.t);
    EXPECT_EQ(a.events.x, b.events.x);
    EXPECT_EQ(a.events.label, b.events.label);
    ASSERT_EQ(a.masks.size(), b.masks.size());
    for (size_t k = 0; k < a.masks.size(); ++k) EXPECT_EQ(a.masks[k].ids, b.masks[k].ids);
    EXPECT_EQ(a.metadata_json, b.metadata_json);
  }
}
