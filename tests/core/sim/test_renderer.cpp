// Renderer (row-vectorised) against ReferenceRenderer (the first, per-pixel implementation):
// both evaluate the same expressions per pixel, so on random scenes of every preset the
// outputs must be identical bit for bit: log intensity, depth, id and surface.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <set>

#include "core/sim/presets.h"
#include "core/sim/reference_renderer.h"
#include "core/sim/renderer.h"
#include "core/sim/simulate.h"

using namespace spikems::sim;

namespace {

struct Diff {
  size_t L = 0, depth = 0, id = 0, surface = 0;
  double max_dL = 0;
};

Diff compare(const Frame& a, const Frame& b) {
  Diff d;
  for (size_t i = 0; i < a.log_intensity.size(); ++i) {
    if (std::memcmp(&a.log_intensity[i], &b.log_intensity[i], 4) != 0) ++d.L;
    if (std::memcmp(&a.depth[i], &b.depth[i], 4) != 0) ++d.depth;
    d.id += a.id[i] != b.id[i];
    d.surface += a.surface[i] != b.surface[i];
    d.max_dL = std::max(d.max_dL, double(std::fabs(a.log_intensity[i] - b.log_intensity[i])));
  }
  return d;
}

}  // namespace

TEST(SimRenderer, MatchesReferenceBitForBitOnPresetScenes) {
  std::set<int> kinds_seen;
  std::set<int> outlines_seen;
  size_t object_pixels = 0;
  for (const char* preset : {"mod", "mod-translate", "evimo", "eed-net", "tiny"}) {
    const SimConfig cfg = preset_config(preset);
    for (int seq = 0; seq < 4; ++seq) {
      std::mt19937_64 rng(sequence_seed(77, seq));
      const Camera cam = camera_from_config(cfg);
      const Scene scene = make_random_scene(cfg, cam, rng);
      for (const auto& s : scene.shapes) {
        kinds_seen.insert(int(s.kind));
        if (s.kind == ShapeKind::Quad && s.id != 0) outlines_seen.insert(int(s.outline));
      }
      const Renderer fast(scene, cam, cfg.log_eps);
      const ReferenceRenderer ref(scene, cam, cfg.log_eps);
      for (double t : {0.0, 0.0415, 0.1375, 0.29}) {
        Frame a, b, c;
        ref.render(t, a, 1);
        fast.render(t, b, 1);
        fast.render(t, c, 2);
        const Diff d = compare(a, b);
        SCOPED_TRACE(std::string(preset) + " seq " + std::to_string(seq) +
                     " t=" + std::to_string(t));
        EXPECT_EQ(d.L, 0u) << "max |dL| " << d.max_dL;
        EXPECT_EQ(d.depth, 0u);
        EXPECT_EQ(d.id, 0u);
        EXPECT_EQ(d.surface, 0u);
        const Diff dt = compare(b, c);  // thread count changes nothing
        EXPECT_EQ(dt.L + dt.depth + dt.id + dt.surface, 0u);
        for (uint16_t id : b.id) object_pixels += id != 0;
      }
    }
  }
  // The scenes exercised every kind of shape and every cut-out outline, with objects on screen.
  EXPECT_EQ(kinds_seen.size(), 5u);
  EXPECT_EQ(outlines_seen.size(), 3u);
  EXPECT_GT(object_pixels, 10000u);
}

// Rays at grazing angles and shapes at the near plane: the edge cases of the branch-free tests
// (a box face parallel to central rays, a star cut-out at a grazing angle, a net, the camera
// inside an object).
TEST(SimRenderer, MatchesReferenceOnDegenerateViews) {
  SimConfig cfg = preset_config("tiny");
  const Camera cam = camera_from_config(cfg);
  Scene scene;
  TextureParams tp;
  tp.kind = TextureKind::Checkers;
  scene.textures.emplace_back(tp);
  scene.textures.emplace_back(tp);
  scene.textures.emplace_back(tp);
  Shape room;
  room.kind = ShapeKind::Room;
  room.half = {3, 2, 5};
  scene.shapes.push_back(room);
  Shape box;  // axis-aligned, centred on the optical axis: faces parallel to central rays
  box.kind = ShapeKind::Box;
  box.id = 1;
  box.half = {0.3, 0.2, 0.4};
  box.motion.position = {0, 0, 2};
  scene.shapes.push_back(box);
  Shape edge;  // a star cut-out at a grazing angle
  edge.kind = ShapeKind::Quad;
  edge.outline = Outline::Star;
  edge.id = 2;
  edge.half = {0.5, 0.5, 0};
  edge.motion.position = {0.5, 0, 1.5};
  edge.motion.orientation = Quat::from_rotvec({0, 1.5707963267948966, 0});
  scene.shapes.push_back(edge);
  Shape net;
  net.kind = ShapeKind::Net;
  net.half = {1, 1, 0};
  net.motion.position = {0, 0, 1};
  scene.shapes.push_back(net);
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1) {  // camera inside a sphere: only its far side is hit, everywhere
      Shape inside;
      inside.kind = ShapeKind::Ellipsoid;
      inside.id = 3;
      inside.half = {0.05, 0.05, 0.05};
      scene.shapes.push_back(inside);
    }
    const Renderer fast(scene, cam, cfg.log_eps);
    const ReferenceRenderer ref(scene, cam, cfg.log_eps);
    Frame a, b;
    ref.render(0, a);
    fast.render(0, b);
    const Diff d = compare(a, b);
    EXPECT_EQ(d.L, 0u) << "max |dL| " << d.max_dL;
    EXPECT_EQ(d.depth + d.id + d.surface, 0u);
    std::set<uint16_t> ids(b.id.begin(), b.id.end());
    if (pass == 0)
      EXPECT_EQ(ids, (std::set<uint16_t>{0, 1, 2}));
    else
      EXPECT_EQ(ids, std::set<uint16_t>{3});
  }
}
