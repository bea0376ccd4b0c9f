#include "core/sim/scene.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/sim/image_texture.h"

namespace spikems::sim {

namespace {

constexpr double kPi = 3.141592653589793;

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

int add_texture(Scene& s, const SimConfig& c, std::mt19937_64& rng, double mean_lo,
                double mean_hi) {
  TextureParams p;
  const std::string& entry = c.textures[size_t(draw_int(rng, 0, int(c.textures.size()) - 1))];
  const bool is_dir = entry.rfind(kTextureDirPrefix, 0) == 0;
  p.kind = is_dir ? TextureKind::Image : texture_kind_from_name(entry);
  p.seed = rng();
  p.frequency = int(std::lround(draw(rng, c.texture_frequency)));
  p.mean = draw(rng, {mean_lo, mean_hi});
  p.log_contrast = draw(rng, c.log_contrast);
  p.angle = draw(rng, {0, kPi});
  if (is_dir) {  // one image of the folder, drawn last so other draws keep their order
    const auto& files = image_texture_files(entry.substr(std::string(kTextureDirPrefix).size()));
    p.image_path = files[size_t(draw_int(rng, 0, int(files.size()) - 1))];
    p.image = image_texture_tile(p.image_path);
  }
  s.textures.emplace_back(p);
  return int(s.textures.size()) - 1;
}

}  // namespace

std::vector<uint16_t> Scene::moving_ids() const {
  std::vector<uint16_t> ids;
  for (const auto& sh : shapes)
    if (sh.id != 0) ids.push_back(sh.id);
  return ids;
}

std::string Scene::describe_json() const {
  std::string out = "[";
  for (const auto& sh : shapes) {
    char buf[256];
    Pose p = sh.motion.at(sh.motion.t_ref);
    std::snprintf(buf, sizeof buf,
                  "%s{\"id\":%u,\"shape\":\"%s\",\"half\":[%.4f,%.4f,%.4f],"
                  "\"position_at_t_ref\":[%.4f,%.4f,%.4f],\"speed\":%.4f,\"texture\":\"%s\"}",
                  out.size() > 1 ? "," : "", unsigned(sh.id), sh.label.c_str(), sh.half.x,
                  sh.half.y, sh.half.z, p.t.x, p.t.y, p.t.z, sh.motion.velocity.norm(),
                  sh.kind == ShapeKind::Net
                      ? "none"
                      : texture_kind_name(textures[size_t(sh.texture)].params().kind));
    out += buf;
  }
  return out + "]";
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
    room.texture = add_texture(s, c, rng, 0.3, 0.8);
    add_texture(s, c, rng, 0.3, 0.8);
    add_texture(s, c, rng, 0.3, 0.8);
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
      q.texture = add_texture(s, c, rng, 0.25, 0.85);
      q.tile_m = draw(rng, c.texture_tile_m);
      s.shapes.push_back(q);
    }
  }

  // Static occluder: a net in front of the camera.
  if (c.net) {
    Shape n;
    n.kind = ShapeKind::Net;
    n.label = "net";
    double z = draw(rng, c.net_depth);
    n.half = {3 * tan_x * z + 1, 3 * tan_y * z + 1, 0};
    n.motion.position = {0, 0, z};
    n.motion.orientation = Quat::from_rotvec({0, 0, draw(rng, {-0.3, 0.3})});
    n.net_spacing = draw(rng, c.net_spacing);
    n.net_bar = std::min(draw(rng, c.net_bar), 0.5 * n.net_spacing);
    n.albedo_scale = U(rng) < 0.5 ? draw(rng, {0.05, 0.15}) : draw(rng, {0.7, 0.95});
    s.shapes.push_back(n);
  }

  // Moving objects: at mid-sequence each is somewhere in view; its velocity carries it
  // across, so objects enter and leave the view.
  const double t_mid = c.duration_us * 0.5e-6;
  int count = draw_int(rng, c.objects_min, c.objects_max);
  for (int i = 0; i < count; ++i) {
    Shape o;
    o.id = uint16_t(i + 1);
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
    double z = draw(rng, c.object_depth);
    double u = draw(rng, {0.1, 0.9}) * cam.width, v = draw(rng, {0.1, 0.9}) * cam.height;
    o.motion.position = {(u - cam.cx) / cam.fx * z, (v - cam.cy) / cam.fy * z, z};
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
    s.shapes.push_back(o);
  }

  s.light_dir = Vec3{draw(rng, {-1, 1}), -draw(rng, {0.3, 1}), -draw(rng, {0, 1})}.normalized();
  s.ambient = draw(rng, c.ambient);
  s.illumination = draw(rng, c.illumination);
  s.camera =
      random_camera_trajectory(rng, draw(rng, c.camera_speed), draw(rng, c.camera_angular_speed),
                               c.camera_frequency_hz.lo, c.camera_frequency_hz.hi);
  return s;
}

}  // namespace spikems::sim
