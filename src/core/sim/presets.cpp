// The preset TOML texts, identical to configs/sim/*.toml (test_sim checks it). To change a
// preset, edit configs/sim/<name>.toml and paste it here.
#include "core/sim/presets.h"

#include <map>

#include "core/util/error.h"

namespace spikems::sim {

namespace {

const std::map<std::string, std::string>& table() {
  static const std::map<std::string, std::string> t = {
      {"mod",
       R"TOML(# MOD-like (EVDodgeNet "Moving Object Dataset"): a room with randomly textured walls, 1-3
# objects flying through it, a camera moving with 6 DoF. Every key is documented in
# docs/simulator.md; ranges [low, high] are drawn per sequence.
[preset]
name = "mod"

[sensor]
width = 346
height = 260

[time]
duration_s = 2.0
dt_min_us = 500
dt_max_us = 1000
max_dlog_fraction = 0.3333
max_displacement_px = 0.5
mask_period_us = 1000

[events]
noise = "noisy"
threshold = 0.2
threshold_sigma = 0.03
refractory_us = 500
leak_hz = 0.01
shot_hz = 0.001
hot_pixel_fraction = 0.0
hot_pixel_hz = 50.0
log_eps = 0.01
photoreceptor_cutoff_hz = 300.0

[scene]
background = "room"
room_width = [4.0, 8.0]
room_height = [2.5, 4.0]
room_depth = [5.0, 10.0]
textures = ["noise", "stripes", "checkers", "grid", "blobs", "natural"]
texture_frequency = [2.0, 10.0]
log_contrast = [0.5, 1.8]
texture_tile_m = [0.5, 2.0]
illumination = [0.4, 1.0]
ambient = [0.3, 0.7]

[objects]
min = 1
max = 3
shapes = ["sphere", "ellipsoid", "box", "disc", "rect", "star"]
size = [0.1, 0.35]
depth = [1.0, 3.5]
speed = [0.5, 2.5]
spin = [0.0, 3.0]

[occluder]
net = false

[camera]
speed = [0.0, 0.8]
angular_speed = [0.0, 1.2]
frequency_hz = [0.2, 1.5]

[output]
val_fraction = 0.1
test_fraction = 0.1
)TOML"},
      {"evimo",
       R"TOML(# EV-IMO-like lab scenes: a smaller room, several box-like and round objects moved by hand
# (slower), a hand-held camera. Every key is documented in docs/simulator.md.
[preset]
name = "evimo"

[sensor]
width = 346
height = 260

[time]
duration_s = 2.0
dt_min_us = 500
dt_max_us = 1000
max_dlog_fraction = 0.3333
max_displacement_px = 0.5
mask_period_us = 1000

[events]
noise = "noisy"
threshold = 0.2
threshold_sigma = 0.03
refractory_us = 500
leak_hz = 0.01
shot_hz = 0.001
hot_pixel_fraction = 0.0001
hot_pixel_hz = 20.0
log_eps = 0.01
photoreceptor_cutoff_hz = 300.0

[scene]
background = "room"
room_width = [3.0, 5.0]
room_height = [2.5, 3.5]
room_depth = [3.5, 6.0]
textures = ["noise", "natural", "blobs", "stripes", "grid"]
texture_frequency = [3.0, 12.0]
log_contrast = [0.4, 1.5]
texture_tile_m = [0.3, 1.2]
illumination = [0.3, 0.9]
ambient = [0.3, 0.6]

[objects]
min = 2
max = 4
shapes = ["box", "box", "ellipsoid", "sphere", "rect"]
size = [0.08, 0.25]
depth = [0.8, 2.5]
speed = [0.2, 1.2]
spin = [0.0, 2.0]

[occluder]
net = false

[camera]
speed = [0.05, 0.5]
angular_speed = [0.1, 1.0]
frequency_hz = [0.3, 1.5]

[output]
val_fraction = 0.1
test_fraction = 0.1
)TOML"},
      {"eed-net",
       R"TOML(# EED-like "ball behind a net": textured planes at several depths, a static net close to the
# camera, one fast round object behind it, a fast-moving camera. See docs/simulator.md.
[preset]
name = "eed-net"

[sensor]
width = 346
height = 260

[time]
duration_s = 1.0
dt_min_us = 200
dt_max_us = 1000
max_dlog_fraction = 0.3333
max_displacement_px = 0.5
mask_period_us = 1000

[events]
noise = "noisy"
threshold = 0.2
threshold_sigma = 0.03
refractory_us = 500
leak_hz = 0.01
shot_hz = 0.001
hot_pixel_fraction = 0.0
hot_pixel_hz = 50.0
log_eps = 0.01
photoreceptor_cutoff_hz = 300.0

[scene]
background = "planes"
planes = 3
plane_depth = [3.0, 10.0]
textures = ["noise", "natural", "checkers", "stripes", "blobs"]
texture_frequency = [2.0, 10.0]
log_contrast = [0.5, 1.8]
texture_tile_m = [0.5, 2.0]
illumination = [0.4, 1.0]
ambient = [0.3, 0.7]

[objects]
min = 1
max = 1
shapes = ["sphere"]
size = [0.06, 0.15]
depth = [1.2, 2.5]
speed = [1.5, 5.0]
spin = [0.0, 6.0]

[occluder]
net = true
depth = [0.4, 0.8]
spacing = [0.04, 0.08]
bar = [0.003, 0.008]

[camera]
speed = [0.1, 0.5]
angular_speed = [0.3, 1.2]
frequency_hz = [0.5, 2.5]

[output]
val_fraction = 0.1
test_fraction = 0.1
)TOML"},
      {"tiny", R"TOML(# A small, short, fast scene for tests and smoke runs: 64 x 48 pixels, 0.2 s.
[preset]
name = "tiny"

[sensor]
width = 64
height = 48

[time]
duration_s = 0.2
dt_min_us = 100
dt_max_us = 1000
max_dlog_fraction = 0.3333
max_displacement_px = 0.5
mask_period_us = 1000

[events]
noise = "noisy"
threshold = 0.2
threshold_sigma = 0.03
refractory_us = 500
leak_hz = 0.01
shot_hz = 0.001
hot_pixel_fraction = 0.0
hot_pixel_hz = 50.0
log_eps = 0.01
photoreceptor_cutoff_hz = 300.0

[scene]
background = "room"
room_width = [4.0, 6.0]
room_height = [2.5, 3.5]
room_depth = [5.0, 8.0]
textures = ["noise", "stripes", "checkers", "blobs"]
texture_frequency = [2.0, 6.0]
log_contrast = [1.0, 2.0]
texture_tile_m = [0.5, 1.5]
illumination = [0.5, 1.0]
ambient = [0.3, 0.6]

[objects]
min = 1
max = 2
shapes = ["sphere", "box", "disc"]
size = [0.15, 0.3]
depth = [1.0, 2.0]
speed = [1.0, 2.0]
spin = [0.0, 2.0]

[occluder]
net = false

[camera]
speed = [0.2, 0.6]
angular_speed = [0.2, 1.0]
frequency_hz = [0.5, 2.0]

[output]
val_fraction = 0.2
test_fraction = 0.2
)TOML"},
  };
  return t;
}

}  // namespace

std::vector<std::string> preset_names() {
  return {"mod", "evimo", "eed-net", "tiny"};
}

const std::string& preset_toml(const std::string& name) {
  auto it = table().find(name);
  if (it == table().end())
    fail("--preset", "", "unknown preset '" + name + "' (use mod, evimo, eed-net or tiny)");
  return it->second;
}

SimConfig preset_config(const std::string& name) {
  return parse_sim_config(preset_toml(name), "preset " + name);
}

}  // namespace spikems::sim
