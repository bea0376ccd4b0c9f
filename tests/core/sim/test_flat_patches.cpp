// Flat patches on background textures ([scene] flat_patches): coverage, the contrast law inside
// and outside a patch, determinism, wrapping, the config key, and scenes otherwise unchanged.
#include <gtest/gtest.h>

#include <cmath>

#include "core/sim/presets.h"
#include "core/sim/scene.h"
#include "core/sim/simulate.h"
#include "core/sim/texture.h"
#include "core/util/error.h"

using namespace spikems;
using namespace spikems::sim;

namespace {

constexpr int kN = Texture::kTile;

std::vector<float> constant_tile(float v) {
  return std::vector<float>(size_t(kN) * kN, v);
}

Scene scene_for(const SimConfig& cfg, uint64_t seed) {
  std::mt19937_64 rng(seed);
  return make_random_scene(cfg, camera_from_config(cfg), rng);
}

}  // namespace

// On a tile of full contrast (every value 1) each texel either keeps 1 (outside) or is pulled
// to 1/2 + factor/2 with factor <= 0.3 (inside); the covered share is what the function
// returns, at least the asked fraction, and at most one largest patch (0.6 x 0.6 tile) above.
TEST(FlatPatches, CoverageAndContrastLaw) {
  for (double f : {0.1, 0.3, 0.5, 0.8}) {
    for (uint64_t seed = 1; seed <= 5; ++seed) {
      auto v = constant_tile(1.0f);
      const double got = apply_flat_patches(v, f, seed);
      size_t covered = 0;
      for (float x : v) {
        if (x == 1.0f) continue;
        ++covered;
        ASSERT_GE(x, 0.5f);
        ASSERT_LE(x, 0.5f + 0.15f + 1e-6f);
      }
      const double share = double(covered) / double(v.size());
      EXPECT_DOUBLE_EQ(got, share) << f << " " << seed;
      EXPECT_GE(share, f) << seed;
      EXPECT_LE(share, f + 0.36) << seed;
    }
  }
}

// Values below 1/2 are pulled up towards it just as values above are pulled down: the patch
// scales the deviation from 1/2, so the albedo map sends a flat patch to the texture's mean.
TEST(FlatPatches, ScalesTheDeviationFromOneHalf) {
  auto hi = constant_tile(1.0f), lo = constant_tile(0.0f);
  apply_flat_patches(hi, 0.5, 7);
  apply_flat_patches(lo, 0.5, 7);
  for (size_t i = 0; i < hi.size(); ++i) ASSERT_NEAR(hi[i] - 0.5f, 0.5f - lo[i], 1e-6f) << i;
}

TEST(FlatPatches, ZeroFractionAndDeterminism) {
  auto v = constant_tile(0.9f);
  EXPECT_EQ(apply_flat_patches(v, 0.0, 3), 0.0);
  for (float x : v) ASSERT_EQ(x, 0.9f);
  auto a = constant_tile(1.0f), b = constant_tile(1.0f), c = constant_tile(1.0f);
  apply_flat_patches(a, 0.4, 11);
  apply_flat_patches(b, 0.4, 11);
  apply_flat_patches(c, 0.4, 12);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
}

// Patches wrap across the tile's border (the tile is periodic): over a few seeds some patch
// covers texels in the first and the last column of the same row as one run.
TEST(FlatPatches, PatchesWrapAcrossTheBorder) {
  int wrapped = 0;
  for (uint64_t seed = 1; seed <= 20; ++seed) {
    auto v = constant_tile(1.0f);
    apply_flat_patches(v, 0.5, seed);
    for (int y = 0; y < kN; ++y)
      if (v[size_t(y) * kN] != 1.0f && v[size_t(y) * kN] == v[size_t(y) * kN + kN - 1]) {
        ++wrapped;
        break;
      }
  }
  EXPECT_GT(wrapped, 0);
}

TEST(FlatPatches, BadInput) {
  auto v = constant_tile(1.0f);
  EXPECT_THROW(apply_flat_patches(v, 1.5, 1), Error);
  EXPECT_THROW(apply_flat_patches(v, -0.1, 1), Error);
  std::vector<float> small(10, 1.0f);
  EXPECT_THROW(apply_flat_patches(small, 0.5, 1), Error);
  for (const char* bad :
       {"[scene]\nflat_patches = [0.5, 0.95]\n", "[scene]\nflat_patches = [-0.1, 0.2]\n",
        "[scene]\nflat_patches = \"many\"\n"}) {
    try {
      (void)parse_sim_config(bad, "x.toml");
      ADD_FAILURE() << bad;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("flat_patches"), std::string::npos) << e.what();
    }
  }
}

// The key gives every wall (room) or plane a flat share drawn in its range, leaves objects and
// look-alikes alone, and changes nothing else in the scene: same shapes, poses and textures'
// other parameters as without it, for the same seed.
TEST(FlatPatches, BackgroundsOnlyAndSceneOtherwiseUnchanged) {
  for (const char* preset : {"mod", "poster"}) {
    SimConfig off = preset_config(preset);
    SimConfig on = off;
    on.flat_patches = {0.3, 0.6};
    for (uint64_t seed = 1; seed <= 4; ++seed) {
      const Scene a = scene_for(off, seed), b = scene_for(on, seed);
      ASSERT_EQ(a.shapes.size(), b.shapes.size());
      ASSERT_EQ(a.textures.size(), b.textures.size());
      std::vector<bool> background(b.textures.size(), false);
      for (size_t i = 0; i < a.shapes.size(); ++i) {
        EXPECT_EQ(a.shapes[i].label, b.shapes[i].label);
        EXPECT_EQ(a.shapes[i].half.x, b.shapes[i].half.x);
        EXPECT_EQ(a.shapes[i].motion.position.z, b.shapes[i].motion.position.z);
        const Shape& sh = b.shapes[i];
        if (sh.kind == ShapeKind::Room) {  // the room's three textures follow each other
          for (int k = 0; k < 3; ++k) background[size_t(sh.texture + k)] = true;
        } else if (sh.label == "plane") {
          background[size_t(sh.texture)] = true;
        }
      }
      int walls = 0;
      for (size_t t = 0; t < b.textures.size(); ++t) {
        const auto &pa = a.textures[t].params(), &pb = b.textures[t].params();
        EXPECT_EQ(pa.seed, pb.seed);
        EXPECT_EQ(pa.mean, pb.mean);
        EXPECT_EQ(pa.flat_fraction, 0.0);
        if (background[t]) {
          ++walls;
          EXPECT_GE(pb.flat_fraction, 0.3) << preset << " " << seed << " " << t;
          EXPECT_LE(pb.flat_fraction, 0.6);
        } else {
          EXPECT_EQ(pb.flat_fraction, 0.0) << preset << " texture " << t;
        }
      }
      EXPECT_GT(walls, 0);
    }
  }
}
