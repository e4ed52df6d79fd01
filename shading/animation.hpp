// Scene animation: keyframe tracks and their sampling (glTF 2.0 §3.11 and Appendix C),
// the glTF node graph they drive, and the keyframes of JSON scenes (camera, lights,
// exposure). A Scene carries its animation; animate() poses the scene at a time.
// Sampling is a pure function of the time: the same time gives the same pose.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "encode/result.hpp"
#include "shading/math.hpp"

namespace hdrd::shading {

struct Scene;

// linear: lerp (rotations: shortest-path slerp). step: the previous key's value.
// cubic_spline: glTF's Hermite spline with in/out tangents per key (Appendix C).
// smooth: a Hermite spline through the keys with Catmull-Rom tangents for uneven spacing
// (the mean of the neighbouring slopes), zero at the first and last key: it eases in and out.
enum class Interpolation { linear, step, cubic_spline, smooth };
std::string_view to_string(Interpolation i);

struct Track {
  Interpolation interpolation = Interpolation::linear;
  int components = 1;     // 1..4
  bool rotation = false;  // unit quaternion (x, y, z, w): slerp, normalised after sampling
  std::vector<double> times_s;  // strictly increasing, finite
  // components per key; cubic_spline: 3 x components per key (in-tangent, value, out-tangent).
  std::vector<double> values;
  // Key indices k where the segment ending at key k is held at key k-1's value (a hard cut at t_k).
  std::vector<std::size_t> cut_keys;

  double end_s() const { return times_s.empty() ? 0.0 : times_s.back(); }
  std::array<double, 4> value(std::size_t key) const;  // the key's value (not its tangents)
};

// Checks a track built from a file: times finite and strictly increasing, value count
// matching, values finite. `what` names the track in the error ("animations[0].samplers[1]").
Result<void> validate_track(const Track& t, const std::string& what, std::string_view code = "animation.invalid");

// The track at time t (seconds); before the first key the first value, after the last
// the last (glTF §3.11.3: clamped to the input range).
std::array<double, 4> sample(const Track& t, double time_s);

// ---- glTF node graph ------------------------------------------------------------------------
enum class NodePath { translation, rotation, scale };

// One visited glTF node, in visiting order (a parent comes before its children).
struct AnimatedNode {
  int gltf_node = -1;
  int parent = -1;  // index into SceneAnimation::nodes; -1: a root
  Vec3 translation{0, 0, 0};
  std::array<double, 4> rotation{0, 0, 0, 1};
  Vec3 scale{1, 1, 1};
  std::optional<Mat4> matrix;  // a node given by a matrix (it cannot be animated)
  int first_instance = 0, instance_count = 0;  // the Scene instances of its mesh
  bool camera = false;                         // the scene's camera hangs here
  std::vector<int> lights;                     // Scene light indices of its KHR_lights_punctual light
};

struct NodeChannel {
  int node = 0;  // index into SceneAnimation::nodes
  NodePath path = NodePath::translation;
  Track track;
};

// ---- JSON keyframes ----------------------------------------------------------------------------
struct CameraAnimation {
  std::optional<Track> position, target, yfov_deg;
  std::optional<Track> yaw_pitch_deg;  // instead of target: yaw about +Y (0 looks down -Z, +90 down +X), pitch up
  std::vector<double> cut_times_s;    // keys marked "cut": true
};

struct LightAnimation {
  int light = 0;                  // Scene light index
  std::optional<Track> amount;    // illuminance_lux (directional) or intensity_cd (point, spot)
  std::optional<Track> color, position;
};

struct SceneAnimation {
  std::vector<AnimatedNode> nodes;
  std::vector<NodeChannel> channels;
  std::optional<CameraAnimation> camera;
  std::vector<LightAnimation> lights;
  std::optional<Track> exposure_ev100, exposure_compensation_ev;

  // The largest key time of any track: the animation's length (0: a still scene).
  double duration_s() const;
  bool empty() const;
};

// What a posed frame reports beside the pose.
struct AnimatedFrame {
  std::optional<double> exposure_ev100, exposure_compensation_ev;
  bool scene_cut = false;
};

// Poses `s` (instances, camera, lights) at time_s from its animation; the scene must be
// the one the animation was built for, in its rest state. previous_time_s: the frame
// before (a cut in (previous, time] marks this frame); none: a cut exactly at time_s.
Result<AnimatedFrame> animate(Scene& s, const SceneAnimation& a, double time_s,
                              std::optional<double> previous_time_s = std::nullopt);

}  // namespace hdrd::shading
