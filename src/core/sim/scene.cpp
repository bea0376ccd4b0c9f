#include "core/sim/scene.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/sim/image_texture.h"

namespace spikems::sim {

namespace {

constexpr double kPi = 3.141592653589793;
constexpr double kGravity = 9.81;  // m/s^2, along world +y (down)

double draw(std::mt19937_64& rng, const Range& r) {
  std::uniform_real_distribution<double> U(0, 1);
  return r.lo + (r.hi - r.lo) * U(rng);
}

int draw_int(std::mt19937_64& rng, int lo, int hi) {
  std::uniform_int_distribution<int> U(lo, hi);
  return U(rng);
}

// Uniformly random rotation (Shoemake).
Quat random_rotation(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(0, 1);
  double u1 = U(rng), u2 = U(rng), u3 = U(rng);
  double a = std::sqrt(1 - u1), b = std::sqrt(u1);
  return Quat{b * std::cos(2 * kPi * u3), a * std::sin(2 * kPi * u2), a * std::cos(2 * kPi * u2),
              b * std::sin(2 * kPi * u3)};
}

// background: a wall or plane, which gets the config's flat patches.
int add_texture(Scene& s, const SimConfig& c, std::mt19937_64& rng, double mean_lo, double mean_hi,
                bool background = false) {
  TextureParams p;
  const std::string& entry = c.textures[size_t(draw_int(rng, 0, int(c.textures.size()) - 1))];
  const bool is_dir = entry.rfind(kTextureDirPrefix, 0) == 0;
  p.kind = is_dir ? TextureKind::Image : texture_kind_from_name(entry);
  p.seed = rng();
  p.frequency = int(std::lround(draw(rng, c.texture_frequency)));
  p.mean = draw(rng, {mean_lo, mean_hi});
  p.log_contrast = draw(rng, c.log_contrast);
  p.angle = draw(rng, {0, kPi});
  if (background && c.flat_patches.hi > 0) {  // from the texture's seed: the scene's draws stay
    std::mt19937_64 own(p.seed ^ 0x5bd1e9955bd1e995ull);
    p.flat_fraction = draw(own, c.flat_patches);
  }
  if (is_dir) {  // one image of the folder, drawn last so other draws keep their order
    const auto& files = image_texture_files(entry.substr(std::string(kTextureDirPrefix).size()));
    p.image_path = files[size_t(draw_int(rng, 0, int(files.size()) - 1))];
    p.image = image_texture_tile(p.image_path);
  }
  s.textures.emplace_back(p);
  return int(s.textures.size()) - 1;
}

// One element of a list; no draw when there is only one, so that configs that leave a list at
// its single default draw exactly the numbers they drew before the list existed.
const std::string& pick(std::mt19937_64& rng, const std::vector<std::string>& list) {
  return list.size() == 1 ? list[0] : list[size_t(draw_int(rng, 0, int(list.size()) - 1))];
}

// Shape kind and extents of an object (moving or static look-alike); returns the radius.
double draw_object_shape(Shape& o, const SimConfig& c, std::mt19937_64& rng) {
  const std::string& kind = c.shapes[size_t(draw_int(rng, 0, int(c.shapes.size()) - 1))];
  o.label = kind;
  double r = draw(rng, c.object_size);
  if (kind == "sphere") {
    o.kind = ShapeKind::Ellipsoid;
    o.half = {r, r, r};
  } else if (kind == "ellipsoid") {
    o.kind = ShapeKind::Ellipsoid;
    o.half = {r, r * draw(rng, {0.4, 1}), r * draw(rng, {0.4, 1})};
  } else if (kind == "box") {
    o.kind = ShapeKind::Box;
    o.half = {r, r * draw(rng, {0.4, 1}), r * draw(rng, {0.4, 1})};
  } else {
    o.kind = ShapeKind::Quad;
    o.outline = kind == "disc" ? Outline::Disc : kind == "star" ? Outline::Star : Outline::Rect;
    o.half = {r, kind == "rect" ? r * draw(rng, {0.4, 1}) : r, 0};
  }
  return r;
}

// Foliage: two octaves of periodic value noise (lattices of 16 and 32 cells per period, smooth
// interpolation), thresholded at the quantile that leaves `cover` of the plane solid. The
// coarse lattice spacing is `leaf` metres, the size of a leaf cluster.
void make_leaf_field(Shape& n, std::mt19937_64& rng, double leaf, double cover) {
  constexpr int N = Shape::kLeafN;
  std::uniform_real_distribution<float> U(0, 1);
  std::vector<float> f(size_t(N) * N, 0.f);
  for (int oct = 0; oct < 2; ++oct) {
    const int L = 16 << oct, step = N / L;
    const float w = oct == 0 ? 1.f : 0.45f;
    std::vector<float> g(size_t(L) * L);
    for (auto& v : g) v = U(rng);
    auto at = [&](int i, int j) { return g[size_t((j % L) * L + (i % L))]; };
    auto smooth = [](float a) { return a * a * (3 - 2 * a); };
    for (int y = 0; y < N; ++y)
      for (int x = 0; x < N; ++x) {
        int i = x / step, j = y / step;
        float a = smooth(float(x % step) / step), b = smooth(float(y % step) / step);
        float top = at(i, j) * (1 - a) + at(i + 1, j) * a;
        float bot = at(i, j + 1) * (1 - a) + at(i + 1, j + 1) * a;
        f[size_t(y) * N + x] += w * (top * (1 - b) + bot * b);
      }
  }
  std::vector<float> sorted = f;
  size_t k = std::min(sorted.size() - 1, size_t((1 - cover) * double(sorted.size())));
  std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(k), sorted.end());
  n.leaf_threshold = sorted[k];
  n.leaf_field = std::move(f);
  n.leaf_cell_m = leaf * 16 / N;
}

// A static occluder plane of `kind` (net, bars, foliage) in front of the camera, covering the
// view under any camera motion; background (id 0).
Shape make_occluder(const SimConfig& c, const std::string& kind, double tan_x, double tan_y,
                    std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(0, 1);
  Shape n;
  n.kind = ShapeKind::Net;
  n.label = kind;
  double z = draw(rng, c.net_depth);
  n.half = {3 * tan_x * z + 1, 3 * tan_y * z + 1, 0};
  n.motion.position = {0, 0, z};
  // A net is near-axis-aligned; bars and leaves take any angle.
  Range angle = kind == "net" ? Range{-0.3, 0.3} : Range{0, kPi};
  n.motion.orientation = Quat::from_rotvec({0, 0, draw(rng, angle)});
  if (kind == "foliage") {
    n.net_pattern = NetPattern::Foliage;
    double leaf = draw(rng, c.leaf_size), cover = draw(rng, c.leaf_cover);
    make_leaf_field(n, rng, leaf, cover);
  } else {
    n.net_pattern = kind == "bars" ? NetPattern::Bars : NetPattern::Grid;
    n.net_spacing = draw(rng, c.net_spacing);
    n.net_bar = std::min(draw(rng, c.net_bar), 0.5 * n.net_spacing);
  }
  n.albedo_scale = U(rng) < 0.5 ? draw(rng, {0.05, 0.15}) : draw(rng, {0.7, 0.95});
  return n;
}

// Turns a linear object motion (drift `dir` x `speed` with sway) into another kind. World
// frame: y is down (the world is the initial camera frame, and the light comes from -y).
void shape_motion(Trajectory& m, const std::string& kind, const Vec3& dir, double speed, double r,
                  std::mt19937_64& rng) {
  std::uniform_real_distribution<double> U(0, 1);
  m.wobble_translation.clear();
  if (kind == "ballistic") {
    // A throw: velocity dir x speed at t_ref, then free fall (no sway, no drag).
    m.acceleration = {0, kGravity, 0};
  } else if (kind == "curved") {
    // A circular arc of radius speed / w at turn rate w: heading changes by w rad/s. The circle
    // p(t) = R (e1 sin th + s e2 (1 - cos th)), th = w (t - t_ref), in the plane of `dir` and
    // its in-image perpendicular e2 (s = +-1: turning either way), velocity speed x e1 at
    // t_ref. Per axis, R (e1 sin th - s e2 cos th) = R A sin(th + phi) with A cos phi = e1,
    // A sin phi = -s e2: one Sinusoid.
    double w = draw(rng, {0.8, 3.0}), side = U(rng) < 0.5 ? -1 : 1;
    Vec3 e2 = Vec3{-dir.y, dir.x, 0}.normalized() * side;
    double R = speed / w;
    Sinusoid arc;
    arc.freq_hz = w / (2 * kPi);
    const double e1k[3] = {dir.x, dir.y, dir.z}, e2k[3] = {e2.x, e2.y, e2.z};
    double amp[3], ph[3];
    for (int k = 0; k < 3; ++k) {
      amp[k] = R * std::hypot(e1k[k], e2k[k]);
      ph[k] = std::atan2(-e2k[k], e1k[k]) - w * m.t_ref;
    }
    arc.amplitude = {amp[0], amp[1], amp[2]};
    arc.phase = {ph[0], ph[1], ph[2]};
    m.wobble_translation.push_back(arc);
    m.velocity = {};
  } else if (kind == "spin") {
    // Spinning in place: the surface moves at `speed` (w = speed / r), the centre drifts at a
    // tenth of it.
    Vec3 axis = m.spin.norm() > 0 ? m.spin.normalized()
                                  : Vec3{U(rng) - 0.5, U(rng) - 0.5, U(rng) - 0.5}.normalized();
    m.spin = axis * (speed / r);
    m.velocity = m.velocity * 0.1;
  }
}

}  // namespace

std::vector<uint16_t> Scene::moving_ids() const {
  std::vector<uint16_t> ids;
  for (const auto& sh : shapes)
    if (sh.id != 0) ids.push_back(sh.id);
  return ids;
}

nlohmann::json Scene::describe() const {
  // Built as JSON, not printed: nlohmann writes every double in full and a non-finite one as
  // null, so the metadata stays valid whatever the scene holds.
  nlohmann::json out = nlohmann::json::array();
  auto r4 = [](double v) { return std::isfinite(v) ? std::round(v * 1e4) / 1e4 : v; };
  for (const auto& sh : shapes) {
    const double t0 = sh.motion.t_ref;
    Pose p = sh.motion.at(t0);
    // Speed at t_ref (central difference: includes sway, arcs and gravity).
    double speed = (sh.motion.at(t0 + 1e-4).t - sh.motion.at(t0 - 1e-4).t).norm() / 2e-4;
    out.push_back(
        {{"id", unsigned(sh.id)},
         {"shape", sh.label},
         {"half", {r4(sh.half.x), r4(sh.half.y), r4(sh.half.z)}},
         {"position_at_t_ref", {r4(p.t.x), r4(p.t.y), r4(p.t.z)}},
         {"speed", r4(speed)},
         {"motion", sh.motion_kind},
         {"texture", sh.kind == ShapeKind::Net
                         ? "none"
                         : texture_kind_name(textures[size_t(sh.texture)].params().kind)}});
  }
  return out;
}

Scene make_random_scene(const SimConfig& c, const Camera& cam, std::mt19937_64& rng) {
  Scene s;
  std::uniform_real_distribution<double> U(0, 1);
  const double tan_x = (cam.width * 0.5) / cam.fx, tan_y = (cam.height * 0.5) / cam.fy;

  // Background.
  if (c.background == "room") {
    Shape room;
    room.kind = ShapeKind::Room;
    room.label = "room";
    double W = draw(rng, c.room_width), H = draw(rng, c.room_height), D = draw(rng, c.room_depth);
    room.half = {W / 2, H / 2, D / 2};
    // The camera stands in the back third of the room, looking at the far wall.
    room.motion.position = {draw(rng, {-0.15 * W, 0.15 * W}), draw(rng, {-0.1 * H, 0.1 * H}),
                            D * draw(rng, {0.15, 0.3})};
    room.texture = add_texture(s, c, rng, 0.3, 0.8, true);
    add_texture(s, c, rng, 0.3, 0.8, true);
    add_texture(s, c, rng, 0.3, 0.8, true);
    room.tile_m = draw(rng, c.texture_tile_m);
    s.shapes.push_back(room);
  } else {
    std::vector<double> depths;
    for (int i = 0; i < c.planes; ++i) depths.push_back(draw(rng, c.plane_depth));
    std::sort(depths.begin(), depths.end());
    for (int i = 0; i < c.planes; ++i) {
      Shape q;
      q.kind = ShapeKind::Quad;
      q.outline = Outline::Rect;
      q.label = "plane";
      double z = depths[size_t(i)];
      bool last = i + 1 == c.planes;
      // The farthest plane fills any view; nearer ones cover part of it (parallax edges).
      double sx = last ? 4 * tan_x * z + 2 : z * tan_x * draw(rng, {0.3, 0.8});
      double sy = last ? 4 * tan_y * z + 2 : z * tan_y * draw(rng, {0.3, 0.9});
      q.half = {sx, sy, 0};
      q.motion.position = {last ? 0 : z * tan_x * draw(rng, {-0.8, 0.8}),
                           last ? 0 : z * tan_y * draw(rng, {-0.6, 0.6}), z};
      q.motion.orientation =
          last ? Quat{} : Quat::from_rotvec({draw(rng, {-0.3, 0.3}), draw(rng, {-0.4, 0.4}), 0});
      q.texture = add_texture(s, c, rng, 0.25, 0.85, true);
      q.tile_m = draw(rng, c.texture_tile_m);
      s.shapes.push_back(q);
    }
  }

  // Static occluder (net = true: always a net).
  static const std::vector<std::string> kNetOnly{"net"};
  const std::string& occ = pick(rng, c.net ? kNetOnly : c.occluder_kinds);
  if (occ != "none") s.shapes.push_back(make_occluder(c, occ, tan_x, tan_y, rng));

  // Moving objects: at mid-sequence each is somewhere in view; its velocity carries it
  // across, so objects enter and leave the view.
  const double t_mid = c.duration_us * 0.5e-6;
  int count = draw_int(rng, c.objects_min, c.objects_max);
  for (int i = 0; i < count; ++i) {
    Shape o;
    o.id = uint16_t(i + 1);
    double r = draw_object_shape(o, c, rng);
    double z = draw(rng, c.object_depth);
    double u = draw(rng, {0.1, 0.9}) * cam.width, v = draw(rng, {0.1, 0.9}) * cam.height;
    const Vec3 p_mid{(u - cam.cx) / cam.fx * z, (v - cam.cy) / cam.fy * z, z};
    o.motion_kind = pick(rng, c.object_motion);
    o.motion.position = p_mid;
    o.motion.t_ref = t_mid;
    double speed = draw(rng, c.object_speed), ang = draw(rng, {0, 2 * kPi});
    Vec3 dir = Vec3{std::cos(ang), std::sin(ang), draw(rng, {-0.3, 0.3})}.normalized();
    o.motion.velocity = dir * speed;
    o.motion.orientation = random_rotation(rng);
    Vec3 axis = Vec3{U(rng) - 0.5, U(rng) - 0.5, U(rng) - 0.5}.normalized();
    o.motion.spin = axis * draw(rng, c.object_spin);
    // A gentle sway so paths are not all straight lines.
    Sinusoid sw;
    sw.freq_hz = draw(rng, {0.3, 1.5});
    double a = 0.3 * speed / (2 * kPi * sw.freq_hz);
    sw.amplitude = {a * U(rng), a * U(rng), a * U(rng)};
    sw.phase = {2 * kPi * U(rng), 2 * kPi * U(rng), 2 * kPi * U(rng)};
    o.motion.wobble_translation.push_back(sw);
    o.texture = add_texture(s, c, rng, 0.15, 0.9);
    o.tile_m = r * draw(rng, {0.5, 2.0});
    if (o.motion_kind != "linear") {
      shape_motion(o.motion, o.motion_kind, dir, speed, r, rng);
      // In view at mid-sequence whatever the sinusoids add there.
      o.motion.position = o.motion.position + (p_mid - o.motion.at(t_mid).t);
    }
    s.shapes.push_back(o);
  }

  s.light_dir = Vec3{draw(rng, {-1, 1}), -draw(rng, {0.3, 1}), -draw(rng, {0, 1})}.normalized();
  s.ambient = draw(rng, c.ambient);
  s.illumination = draw(rng, c.illumination);
  s.camera_motion = pick(rng, c.camera_motion);
  if (s.camera_motion == "glide") {
    // Constant velocity in the image plane, no rotation: a slider, a dolly, a robot driving
    // past; the image speed is the same all sequence (the `poster` calibration relies on it).
    const double v = draw(rng, c.camera_speed), a = draw(rng, {0, 2 * std::numbers::pi});
    s.camera = Trajectory{};
    s.camera.velocity = Vec3{v * std::cos(a), v * std::sin(a), 0};
  } else if (s.camera_motion == "handheld") {
    s.camera =
        random_camera_trajectory(rng, draw(rng, c.camera_speed), draw(rng, c.camera_angular_speed),
                                 c.camera_frequency_hz.lo, c.camera_frequency_hz.hi);
  } else {
    double v = draw(rng, c.camera_speed), w = draw(rng, c.camera_angular_speed);
    // Shake: the same peak speeds at 3-10 Hz, so amplitudes are ~10x smaller than handheld.
    const Range& f = s.camera_motion == "shake" ? c.shake_frequency_hz : c.camera_frequency_hz;
    s.camera = random_camera_trajectory(rng, v, w, f.lo, f.hi);
    if (s.camera_motion == "translate") s.camera.wobble_rotation.clear();
    if (s.camera_motion == "rotate") s.camera.wobble_translation.clear();
  }

  // Static look-alikes: drawn like the moving objects, placed in view of the camera at
  // mid-sequence, fixed in the world, background (id 0).
  if (c.static_max > 0) {
    const Pose cam_mid = s.camera.at(t_mid);
    int n_static = draw_int(rng, c.static_min, c.static_max);
    for (int i = 0; i < n_static; ++i) {
      Shape o;
      double r = draw_object_shape(o, c, rng);
      double z = draw(rng, c.object_depth);
      double u = draw(rng, {0.1, 0.9}) * cam.width, v = draw(rng, {0.1, 0.9}) * cam.height;
      o.motion.position = cam_mid.apply({(u - cam.cx) / cam.fx * z, (v - cam.cy) / cam.fy * z, z});
      o.motion.orientation = random_rotation(rng);
      o.motion.t_ref = t_mid;
      o.texture = add_texture(s, c, rng, 0.15, 0.9);
      o.tile_m = r * draw(rng, {0.5, 2.0});
      s.shapes.push_back(o);
    }
  }
  return s;
}

}  // namespace spikems::sim
