// The `poster` preset against the real recording it was calibrated on
// (../shared/data/formats/poster_translation.npz: a DAVIS of a textured poster under camera
// translation): over a window as long as the real one, every statistic of docs/simulator.md's
// side-by-side table is within 25% of the real recording's.
#include <gtest/gtest.h>

#include <cmath>

#include "common/test_paths.h"
#include "core/events/io.h"
#include "core/sim/event_stats.h"
#include "core/sim/presets.h"
#include "core/sim/simulate.h"

using namespace spikems;
using namespace spikems::sim;

TEST(PosterCalibration, StatisticsWithin25PercentOfRealRecording) {
  SPIKEMS_REQUIRE_SHARED(path, "data/formats/poster_translation.npz");
  ReadOptions ro;
  ro.sort = true;
  const EventStats real = compute_event_stats(read_events(path, ro));
  ASSERT_GT(real.events, 50000);

  SimConfig cfg = preset_config("poster");
  cfg.duration_us = int64_t(std::lround(real.duration_s * 1e3)) * 1000;  // 73 ms
  SimulateOptions so;
  so.keep_masks = false;
  // Three sequences: the preset's ranges (depth, speed, direction, sensor draws), not one seed.
  for (int k = 0; k < 3; ++k) {
    SCOPED_TRACE("sequence " + std::to_string(k));
    const EventStats sim =
        compute_event_stats(simulate_sequence(cfg, sequence_seed(1, k), so).events);
    std::printf("%s", stats_table({{"real", real}, {"poster", sim}}).c_str());

    struct Check {
      const char* name;
      double real, sim;
    };
    const Check checks[] = {
        {"events per active pixel per second", real.rate_per_active_pixel_hz,
         sim.rate_per_active_pixel_hz},
        {"inter-event interval p10", real.isi_p10_ms, sim.isi_p10_ms},
        {"inter-event interval median", real.isi_median_ms, sim.isi_median_ms},
        {"inter-event interval p90", real.isi_p90_ms, sim.isi_p90_ms},
        {"ON share", real.on_fraction, sim.on_fraction},
        {"same polarity as previous", real.same_polarity_fraction, sim.same_polarity_fraction},
        {"edge width", real.edge_width, sim.edge_width},
    };
    for (const auto& c : checks)
      EXPECT_NEAR(c.sim, c.real, 0.25 * c.real)
          << c.name << ": real " << c.real << ", poster " << c.sim;
  }
}
