#include "shading/animation.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "shading/scene.hpp"

namespace hdrd::shading {
namespace {

using Value = std::array<double, 4>;

std::size_t key_stride(const Track& t) {
  return static_cast<std::size_t>(t.components) * (t.interpolation == Interpolation::cubic_spline ? 3 : 1);
}

// Component c of key k's in-tangent (part 0), value (1) or out-tangent (2) (glTF Appendix C).
double part(const Track& t, std::size_t k, int which, int c) {
  return t.values[k * key_stride(t) + static_cast<std::size_t>(which * t.components + c)];
}

bool held(const Track& t, std::size_t k) {
  return std::find(t.cut_keys.begin(), t.cut_keys.end(), k) != t.cut_keys.end();
}

Value normalized(Value q) {
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  if (!(n > 0)) return {0, 0, 0, 1};
  for (double& x : q) x /= n;
  return q;
}

// Shortest-path spherical interpolation of unit quaternions (Shoemake 1985).
Value slerp(Value a, Value b, double u) {
  double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
  if (d < 0) {  // q and -q are the same rotation: take the shorter arc
    for (double& x : b) x = -x;
    d = -d;
  }
  Value r{};
  if (d > 0.9995) {  // nearly parallel: sin(theta) -> 0, lerp is exact to 1e-7
    for (int c = 0; c < 4; ++c) r[c] = a[c] + (b[c] - a[c]) * u;
    return normalized(r);
  }
  const double theta = std::acos(d), s = std::sin(theta);
  const double wa = std::sin((1 - u) * theta) / s, wb = std::sin(u * theta) / s;
  for (int c = 0; c < 4; ++c) r[c] = wa * a[c] + wb * b[c];
  return normalized(r);
}

// "smooth": slope at key k, the mean of the neighbouring segments' slopes; zero at the
// ends and beside a cut (the spline eases into and out of it).
double smooth_slope(const Track& t, std::size_t k, int c) {
  const std::size_t n = t.times_s.size();
  if (k == 0 || k + 1 >= n || held(t, k) || held(t, k + 1)) return 0;
  const double left = (part(t, k, 0, c) - part(t, k - 1, 0, c)) / (t.times_s[k] - t.times_s[k - 1]);
  const double right = (part(t, k + 1, 0, c) - part(t, k, 0, c)) / (t.times_s[k + 1] - t.times_s[k]);
  return 0.5 * (left + right);
}

}  // namespace

std::string_view to_string(Interpolation i) {
  switch (i) {
    case Interpolation::linear: return "linear";
    case Interpolation::step: return "step";
    case Interpolation::cubic_spline: return "cubicspline";
    case Interpolation::smooth: return "smooth";
  }
  return "linear";
}

Value Track::value(std::size_t key) const {
  Value v{};
  const int which = interpolation == Interpolation::cubic_spline ? 1 : 0;
  for (int c = 0; c < components; ++c) v[c] = part(*this, key, which, c);
  return v;
}

Result<void> validate_track(const Track& t, const std::string& what, std::string_view code) {
  const auto bad = [&](std::string msg) { return make_error(std::string(code), fmt::format("{}: {}", what, msg), what); };
  if (t.components < 1 || t.components > 4 || (t.rotation && t.components != 4))
    return bad(fmt::format("{} components per key is not supported", t.components));
  if (t.times_s.empty()) return bad("has no keyframes");
  for (std::size_t k = 0; k < t.times_s.size(); ++k) {
    const double x = t.times_s[k];
    if (!std::isfinite(x) || x < 0) return bad(fmt::format("key time {} is {}: times are finite seconds >= 0", k, x));
    if (k > 0 && !(x > t.times_s[k - 1]))
      return bad(fmt::format("key times must be strictly increasing (key {} at {} s follows {} s)", k, x,
                             t.times_s[k - 1]));
  }
  const std::size_t expect = t.times_s.size() * key_stride(t);
  if (t.values.size() != expect)
    return bad(fmt::format("{} values for {} keys: expected {}{}", t.values.size(), t.times_s.size(), expect,
                           t.interpolation == Interpolation::cubic_spline ? " (in-tangent, value, out-tangent per key)" : ""));
  for (std::size_t i = 0; i < t.values.size(); ++i)
    if (!std::isfinite(t.values[i])) return bad(fmt::format("value {} is not finite", i));
  for (std::size_t k : t.cut_keys)
    if (k == 0 || k >= t.times_s.size()) return bad(fmt::format("cut at key {} is out of range", k));
  return {};
}

Value sample(const Track& t, double time_s) {
  const std::size_t n = t.times_s.size();
  if (n == 0) return t.rotation ? Value{0, 0, 0, 1} : Value{};
  const auto finish = [&](Value v) { return t.rotation ? normalized(v) : v; };
  if (!(time_s > t.times_s.front())) return finish(t.value(0));  // NaN too: the first key
  if (time_s >= t.times_s.back()) return finish(t.value(n - 1));
  const auto it = std::upper_bound(t.times_s.begin(), t.times_s.end(), time_s);
  const std::size_t k = static_cast<std::size_t>(it - t.times_s.begin()) - 1;  // t_k <= time < t_k+1
  if (held(t, k + 1) || t.interpolation == Interpolation::step) return finish(t.value(k));
  const double td = t.times_s[k + 1] - t.times_s[k], u = (time_s - t.times_s[k]) / td;
  const Value a = t.value(k), b = t.value(k + 1);
  if (t.interpolation == Interpolation::linear) {
    if (t.rotation) return slerp(a, b, u);
    Value r{};
    for (int c = 0; c < t.components; ++c) r[c] = a[c] + (b[c] - a[c]) * u;
    return r;
  }
  // Cubic Hermite basis (glTF 2.0 Appendix C): p(u) = h00 v_k + h10 td m_k + h01 v_k+1 + h11 td m_k+1.
  const double u2 = u * u, u3 = u2 * u;
  const double h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u, h01 = -2 * u3 + 3 * u2, h11 = u3 - u2;
  Value r{};
  for (int c = 0; c < t.components; ++c) {
    const bool spline = t.interpolation == Interpolation::cubic_spline;
    const double m0 = spline ? part(t, k, 2, c) : smooth_slope(t, k, c);        // b_k: out-tangent of k
    const double m1 = spline ? part(t, k + 1, 0, c) : smooth_slope(t, k + 1, c);  // a_k+1: in-tangent of k+1
    r[c] = h00 * a[c] + h10 * td * m0 + h01 * b[c] + h11 * td * m1;
  }
  return finish(r);
}

double SceneAnimation::duration_s() const {
  double d = 0;
  const auto add = [&](const std::optional<Track>& t) { if (t) d = std::max(d, t->end_s()); };
  for (const auto& c : channels) d = std::max(d, c.track.end_s());
  if (camera) {
    for (const auto* t : {&camera->position, &camera->target, &camera->yfov_deg, &camera->yaw_pitch_deg}) add(*t);
    for (double c : camera->cut_times_s) d = std::max(d, c);
  }
  for (const auto& l : lights)
    for (const auto* t : {&l.amount, &l.color, &l.position}) add(*t);
  add(exposure_ev100);
  add(exposure_compensation_ev);
  return d;
}

bool SceneAnimation::empty() const {
  return channels.empty() && !camera && lights.empty() && !exposure_ev100 && !exposure_compensation_ev;
}

namespace {

Vec3 v3(const Value& v) { return {v[0], v[1], v[2]}; }

Error scene_mismatch(const std::string& what) {
  return make_error("animation.scene", "the animation does not fit its scene: " + what);
}

Result<void> pose_nodes(Scene& s, const SceneAnimation& a, double time_s) {
  if (a.nodes.empty()) return {};
  std::vector<Vec3> translation(a.nodes.size()), scaling(a.nodes.size());
  std::vector<Value> rotation(a.nodes.size());
  for (std::size_t i = 0; i < a.nodes.size(); ++i) {
    translation[i] = a.nodes[i].translation;
    rotation[i] = a.nodes[i].rotation;
    scaling[i] = a.nodes[i].scale;
  }
  for (const NodeChannel& ch : a.channels) {
    if (ch.node < 0 || static_cast<std::size_t>(ch.node) >= a.nodes.size()) return scene_mismatch("channel node");
    const Value v = sample(ch.track, time_s);
    const auto n = static_cast<std::size_t>(ch.node);
    if (ch.path == NodePath::translation) translation[n] = v3(v);
    else if (ch.path == NodePath::rotation) rotation[n] = v;
    else scaling[n] = v3(v);
  }
  std::vector<Mat4> world(a.nodes.size());
  for (std::size_t i = 0; i < a.nodes.size(); ++i) {
    const AnimatedNode& node = a.nodes[i];
    // glTF §3.5.3: local = T * R * S.
    const Mat4 local = node.matrix ? *node.matrix
                                   : translate(translation[i]) *
                                         from_quaternion(rotation[i][0], rotation[i][1], rotation[i][2], rotation[i][3]) *
                                         scale(scaling[i]);
    if (node.parent >= static_cast<int>(i)) return scene_mismatch("a parent after its child");
    world[i] = node.parent >= 0 ? world[static_cast<std::size_t>(node.parent)] * local : local;
    if (!is_finite(world[i]))
      return make_error("animation.invalid", fmt::format("node {} has a non-finite transform at t = {} s", node.gltf_node, time_s));
    if (node.first_instance < 0 || node.first_instance + node.instance_count > static_cast<int>(s.instances.size()))
      return scene_mismatch("instances");
    for (int k = 0; k < node.instance_count; ++k) s.instances[static_cast<std::size_t>(node.first_instance + k)].transform = world[i];
    if (node.camera) {
      if (!s.camera) return scene_mismatch("camera");
      s.camera->position = world[i].transform_point({0, 0, 0});
      s.camera->target = world[i].transform_point({0, 0, -1});  // glTF cameras look down -Z
      s.camera->up = normalize(world[i].transform_dir({0, 1, 0}));
    }
    for (int l : node.lights) {
      if (l < 0 || l >= static_cast<int>(s.lights.size())) return scene_mismatch("lights");
      s.lights[static_cast<std::size_t>(l)].position = world[i].transform_point({0, 0, 0});
      s.lights[static_cast<std::size_t>(l)].direction = normalize(world[i].transform_dir({0, 0, -1}));
    }
  }
  return {};
}

void pose_camera(Scene& s, const CameraAnimation& a, double time_s) {
  Camera c = s.camera.value_or(Camera{});
  if (a.position) c.position = v3(sample(*a.position, time_s));
  if (a.target) c.target = v3(sample(*a.target, time_s));
  if (a.yaw_pitch_deg) {
    const Value yp = sample(*a.yaw_pitch_deg, time_s);
    const double yaw = yp[0] * kPi / 180, pitch = yp[1] * kPi / 180;
    c.target = c.position + Vec3{std::sin(yaw) * std::cos(pitch), std::sin(pitch), -std::cos(yaw) * std::cos(pitch)};
  }
  if (a.yfov_deg) c.yfov_rad = std::clamp(sample(*a.yfov_deg, time_s)[0], 0.01, 179.9) * kPi / 180;
  s.camera = c;
}

Result<void> pose_lights(Scene& s, const std::vector<LightAnimation>& lights, double time_s) {
  for (const LightAnimation& la : lights) {
    if (la.light < 0 || la.light >= static_cast<int>(s.lights.size())) return scene_mismatch("keyframed light");
    Light& l = s.lights[static_cast<std::size_t>(la.light)];
    // Splines may overshoot below zero between keys: light does not go negative.
    if (la.amount) {
      const double x = std::max(0.0, sample(*la.amount, time_s)[0]);
      (l.type == LightType::directional ? l.illuminance_lux : l.intensity_cd) = x;
    }
    if (la.color) l.color = vmax(v3(sample(*la.color, time_s)), Vec3{0, 0, 0});
    if (la.position) l.position = v3(sample(*la.position, time_s));
  }
  return {};
}

}  // namespace

Result<AnimatedFrame> animate(Scene& s, const SceneAnimation& a, double time_s, std::optional<double> previous_time_s) {
  if (!std::isfinite(time_s))
    return make_error("animation.time", fmt::format("time {} s is not finite", time_s), "time_s");
  if (auto r = pose_nodes(s, a, time_s); !r) return r.error();
  AnimatedFrame f;
  if (a.camera) {
    pose_camera(s, *a.camera, time_s);
    for (double c : a.camera->cut_times_s) {
      const bool in = previous_time_s ? (*previous_time_s < c && c <= time_s) : (c <= time_s && c > time_s - 1e-6);
      f.scene_cut = f.scene_cut || in;
    }
  }
  if (auto r = pose_lights(s, a.lights, time_s); !r) return r.error();
  if (a.exposure_ev100) f.exposure_ev100 = sample(*a.exposure_ev100, time_s)[0];
  if (a.exposure_compensation_ev) f.exposure_compensation_ev = sample(*a.exposure_compensation_ev, time_s)[0];
  return f;
}

}  // namespace hdrd::shading
