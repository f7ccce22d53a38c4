#include "msspr_robot_interface/robot_fields.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace msspr::ros_bridge {
namespace {

double Component(const geometry_msgs::Vector3& v, const std::string& c) {
  return c == "x" ? v.x : c == "y" ? v.y : v.z;
}
double Component(const geometry_msgs::Point& v, const std::string& c) {
  return c == "x" ? v.x : c == "y" ? v.y : v.z;
}
double Component(const geometry_msgs::Quaternion& q, const std::string& c) {
  return c == "x" ? q.x : c == "y" ? q.y : c == "z" ? q.z : q.w;
}
void SetComponent(geometry_msgs::Vector3* v, const std::string& c, double x) {
  (c == "x" ? v->x : c == "y" ? v->y : v->z) = x;
}

// Splits "a.b.c" into ("a.b", "c").
std::pair<std::string, std::string> SplitLast(const std::string& path) {
  const size_t dot = path.rfind('.');
  return {path.substr(0, dot), path.substr(dot + 1)};
}

double PoseLeaf(const geometry_msgs::Pose& p, const std::string& group, const std::string& c) {
  return group == "position" ? Component(p.position, c) : Component(p.orientation, c);
}
double TwistLeaf(const geometry_msgs::Twist& t, const std::string& group, const std::string& c) {
  return group == "linear" ? Component(t.linear, c) : Component(t.angular, c);
}

// derive: yaw of the quaternion (x, y, z, w), or its cos and sin.
void Derive(const SpecField& f, std::vector<double>* v) {
  if (f.derive.empty()) return;
  const double x = (*v)[0], y = (*v)[1], z = (*v)[2], w = (*v)[3];
  const double yaw = std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
  if (f.derive == "yaw")
    *v = {yaw};
  else
    *v = {std::cos(yaw), std::sin(yaw)};
}

// Paths are checked at load time (ResolveFieldPaths); resolving again here is cheap.
std::vector<std::string> Paths(const SpecField& f) { return ResolveFieldPaths(f, "spec"); }

bool ByJointName(const std::vector<std::string>& names, const std::vector<double>& values,
                 const SpecField& f, const char* what, std::vector<double>* out, std::string* why) {
  out->clear();
  for (const auto& j : f.joints) {
    auto it = std::find(names.begin(), names.end(), j);
    if (it == names.end()) {
      *why = "field '" + f.name + "' (topic " + f.topic + ", " + f.field + "): joint '" + j +
             "' is not in the message";
      return false;
    }
    const size_t k = static_cast<size_t>(it - names.begin());
    if (k >= values.size()) {
      *why = "field '" + f.name + "' (topic " + f.topic + ", " + f.field + "): " + what + " has " +
             std::to_string(values.size()) + " values for " + std::to_string(names.size()) +
             " joints";
      return false;
    }
    out->push_back(values[k]);
  }
  return true;
}

bool AllFinite(const std::vector<double>& v) {
  for (double x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

template <class M>
bool ReadAny(const M& msg, const SpecField& f, std::vector<double>* out, std::string* why) {
  return ReadRaw(msg, f, out, why);
}

// Reads each of f's paths as leaf(group, component) into *out, then derives what f asks for.
template <class Leaf>
bool ReadLeaves(const SpecField& f, std::vector<double>* out, Leaf leaf) {
  out->clear();
  for (const auto& p : Paths(f)) {
    const auto [group, c] = SplitLast(p);
    out->push_back(leaf(group, c));
  }
  Derive(f, out);
  return true;
}

}  // namespace

bool ReadRaw(const nav_msgs::Odometry& msg, const SpecField& f, std::vector<double>* out,
             std::string*) {
  return ReadLeaves(f, out, [&](const std::string& group, const std::string& c) {
    if (group == "pose.pose.position") return Component(msg.pose.pose.position, c);
    if (group == "pose.pose.orientation") return Component(msg.pose.pose.orientation, c);
    if (group == "twist.twist.linear") return Component(msg.twist.twist.linear, c);
    return Component(msg.twist.twist.angular, c);
  });
}

bool ReadRaw(const geometry_msgs::PoseStamped& msg, const SpecField& f, std::vector<double>* out,
             std::string*) {
  return ReadLeaves(f, out, [&](const std::string& group, const std::string& c) {
    return PoseLeaf(msg.pose, group == "pose.position" ? "position" : "orientation", c);
  });
}

bool ReadRaw(const geometry_msgs::Twist& msg, const SpecField& f, std::vector<double>* out,
             std::string*) {
  return ReadLeaves(f, out, [&](const std::string& group, const std::string& c) {
    return TwistLeaf(msg, group, c);
  });
}

bool ReadRaw(const geometry_msgs::TwistStamped& msg, const SpecField& f, std::vector<double>* out,
             std::string*) {
  return ReadLeaves(f, out, [&](const std::string& group, const std::string& c) {
    return TwistLeaf(msg.twist, group == "twist.linear" ? "linear" : "angular", c);
  });
}

bool ReadRaw(const sensor_msgs::JointState& msg, const SpecField& f, std::vector<double>* out,
             std::string* why) {
  const auto& v = f.field == "position"   ? msg.position
                  : f.field == "velocity" ? msg.velocity
                                          : msg.effort;
  return ByJointName(msg.name, v, f, f.field.c_str(), out, why);
}

bool ReadRaw(const std_msgs::Float64MultiArray& msg, const SpecField& f, std::vector<double>* out,
             std::string* why) {
  out->clear();
  for (const auto& p : Paths(f)) {
    const size_t i = std::stoul(p.substr(5, p.size() - 6));
    if (i >= msg.data.size()) {
      *why = "field '" + f.name + "' (topic " + f.topic + ", " + f.field + "): data has " +
             std::to_string(msg.data.size()) + " values";
      return false;
    }
    out->push_back(msg.data[i]);
  }
  return true;
}

bool ReadRaw(const trajectory_msgs::JointTrajectory& msg, const SpecField& f,
             std::vector<double>* out, std::string* why) {
  if (msg.points.empty()) {
    *why = "field '" + f.name + "' (topic " + f.topic + "): the trajectory has no points";
    return false;
  }
  const auto& pt = msg.points[0];
  return ByJointName(msg.joint_names,
                     f.field == "points[0].positions" ? pt.positions : pt.velocities, f,
                     f.field.c_str(), out, why);
}

bool ReadRaw(const geometry_msgs::TransformStamped& msg, const SpecField& f,
             std::vector<double>* out, std::string*) {
  return ReadLeaves(f, out, [&](const std::string& group, const std::string& c) {
    return group == "translation" ? Component(msg.transform.translation, c)
                                  : Component(msg.transform.rotation, c);
  });
}

ros::Time HeaderStamp(const geometry_msgs::TransformStamped& m) { return m.header.stamp; }
ros::Time HeaderStamp(const nav_msgs::Odometry& m) { return m.header.stamp; }
ros::Time HeaderStamp(const geometry_msgs::PoseStamped& m) { return m.header.stamp; }
ros::Time HeaderStamp(const geometry_msgs::Twist&) { return ros::Time(); }
ros::Time HeaderStamp(const geometry_msgs::TwistStamped& m) { return m.header.stamp; }
ros::Time HeaderStamp(const sensor_msgs::JointState& m) { return m.header.stamp; }
ros::Time HeaderStamp(const std_msgs::Float64MultiArray&) { return ros::Time(); }
ros::Time HeaderStamp(const trajectory_msgs::JointTrajectory& m) { return m.header.stamp; }

void ScaleObservation(const SpecField& f, std::vector<double>* values) {
  for (size_t i = 0; i < values->size(); ++i) {
    (*values)[i] =
        f.ScaleAt(static_cast<int>(i)) * ((*values)[i] - f.OffsetAt(static_cast<int>(i)));
    if (f.has_clip) (*values)[i] = std::clamp((*values)[i], f.clip[0], f.clip[1]);
  }
}

void UnscaleAction(const SpecField& f, std::vector<double>* values) {
  for (size_t i = 0; i < values->size(); ++i) {
    const double a =
        ((*values)[i] - f.OffsetAt(static_cast<int>(i))) / f.ScaleAt(static_cast<int>(i));
    (*values)[i] = std::clamp(a, f.clip[0], f.clip[1]);
  }
}

SpecLayout::SpecLayout(const RobotSpec& spec) {
  int obs_at = 0;
  for (int i = 0; i < static_cast<int>(spec.observation.size()); ++i) {
    const SpecField& f = spec.observation[i];
    auto it = std::find_if(topics.begin(), topics.end(),
                           [&](const Topic& t) { return t.name == f.topic; });
    if (it == topics.end()) {
      topics.push_back(Topic{});
      it = topics.end() - 1;
      it->name = f.topic;
      it->type = f.type;
      it->use_receipt = f.stamp == "receipt";
    }
    if (it->type != f.type)
      throw RobotSpecError(spec.source + ": observation field '" + f.name + "' (topic " + f.topic +
                           "): type " + f.type + ", but an earlier field reads the topic as " +
                           it->type);
    it->fields.push_back(i);
    it->field_offset.push_back(it->size);
    it->obs_offset.push_back(obs_at);
    it->size += f.size();
    obs_at += f.size();
  }
}

template <class M>
bool DecodeObservation(const RobotSpec& spec, const SpecLayout::Topic& t, const M& msg,
                       const ros::Time& receipt, TopicSample* out, std::string* why,
                       bool* nonfinite) {
  *nonfinite = false;
  out->values.clear();
  out->receipt = receipt;
  out->stamp = t.use_receipt ? receipt : HeaderStamp(msg);
  std::vector<double> v;
  for (int idx : t.fields) {
    const SpecField& f = spec.observation[idx];
    if (!ReadAny(msg, f, &v, why)) return false;
    if (!AllFinite(v)) {
      *nonfinite = true;
      *why = "field '" + f.name + "' (topic " + f.topic + ", " + f.field + "): NaN or Inf";
      return false;
    }
    ScaleObservation(f, &v);
    out->values.insert(out->values.end(), v.begin(), v.end());
  }
  return true;
}

template <class M>
bool DecodeAction(const RobotSpec& spec, const M& msg, const ros::Time& receipt, TopicSample* out,
                  std::string* why, bool* nonfinite, const std::string& topic) {
  *nonfinite = false;
  out->values.clear();
  out->receipt = receipt;
  const std::string& on = topic.empty() ? spec.action_topic : topic;
  out->stamp = receipt;
  for (const SpecField& f : spec.action)
    if (f.topic == on) {
      out->stamp = f.stamp == "receipt" ? receipt : HeaderStamp(msg);
      break;
    }
  std::vector<double> v;
  for (const SpecField& f : spec.action) {
    if (f.topic != on) continue;
    if (!ReadAny(msg, f, &v, why)) return false;
    if (!AllFinite(v)) {
      *nonfinite = true;
      *why = "action field '" + f.name + "' (topic " + f.topic + ", " + f.field + "): NaN or Inf";
      return false;
    }
    UnscaleAction(f, &v);
    out->values.insert(out->values.end(), v.begin(), v.end());
  }
  return true;
}

#define MSSPR_INSTANTIATE(M)                                                                \
  template bool DecodeObservation<M>(const RobotSpec&, const SpecLayout::Topic&, const M&,  \
                                     const ros::Time&, TopicSample*, std::string*, bool*);  \
  template bool DecodeAction<M>(const RobotSpec&, const M&, const ros::Time&, TopicSample*, \
                                std::string*, bool*, const std::string&);
MSSPR_INSTANTIATE(nav_msgs::Odometry)
MSSPR_INSTANTIATE(geometry_msgs::PoseStamped)
MSSPR_INSTANTIATE(geometry_msgs::Twist)
MSSPR_INSTANTIATE(geometry_msgs::TwistStamped)
MSSPR_INSTANTIATE(sensor_msgs::JointState)
MSSPR_INSTANTIATE(std_msgs::Float64MultiArray)
MSSPR_INSTANTIATE(trajectory_msgs::JointTrajectory)
MSSPR_INSTANTIATE(geometry_msgs::TransformStamped)
#undef MSSPR_INSTANTIATE

bool DecodeTf(const RobotSpec& spec, const SpecLayout::Topic& t, const tf2::BufferCore& buffer,
              const ros::Time& receipt, TopicSample* out, std::string* why, bool* nonfinite) {
  *nonfinite = false;
  out->values.clear();
  out->receipt = receipt;
  out->stamp = ros::TIME_MAX;
  std::vector<double> v;
  for (int idx : t.fields) {
    const SpecField& f = spec.observation[idx];
    geometry_msgs::TransformStamped tf;
    try {
      tf = buffer.lookupTransform(f.frames[0], f.frames[1], ros::Time(0));
    } catch (const tf2::TransformException& e) {
      *why = "field '" + f.name + "' (tf2 " + f.frames[0] + " -> " + f.frames[1] + "): " + e.what();
      return false;
    }
    ReadRaw(tf, f, &v, why);
    if (!AllFinite(v)) {
      *nonfinite = true;
      *why = "field '" + f.name + "' (tf2 " + f.frames[0] + " -> " + f.frames[1] + "): NaN or Inf";
      return false;
    }
    ScaleObservation(f, &v);
    out->values.insert(out->values.end(), v.begin(), v.end());
    out->stamp = std::min(out->stamp, tf.header.stamp);
  }
  return true;
}

bool DecodeGoal(const RobotSpec& spec, const geometry_msgs::PoseStamped& msg,
                std::vector<double>* goal, std::string* why) {
  goal->assign(spec.obs_dim(), 0.0);
  std::vector<double> v;
  for (const auto& part : spec.goal.parts) {
    if (!ReadRaw(msg, part.field, &v, why)) return false;
    int at = 0;
    for (const auto& f : spec.observation) {
      if (f.name == part.observation) {
        ScaleObservation(f, &v);
        std::copy(v.begin(), v.end(), goal->begin() + at);
        break;
      }
      at += f.size();
    }
  }
  if (!AllFinite(*goal)) {
    *why = "goal (topic " + spec.goal.topic + "): NaN or Inf";
    return false;
  }
  return true;
}

bool DecodeGoal(const RobotSpec& spec, const std_msgs::Float64MultiArray& msg,
                std::vector<double>* goal, std::string* why) {
  if (static_cast<int>(msg.data.size()) != spec.obs_dim()) {
    *why = "goal (topic " + spec.goal.topic + "): " + std::to_string(msg.data.size()) +
           " values, the observation has " + std::to_string(spec.obs_dim());
    return false;
  }
  *goal = msg.data;
  if (!AllFinite(*goal)) {
    *why = "goal (topic " + spec.goal.topic + "): NaN or Inf";
    return false;
  }
  return true;
}

namespace {

// Each action field's command values: offset + scale * clip(a).
std::vector<std::vector<double>> CommandValues(const RobotSpec& spec,
                                               const std::vector<double>& a) {
  std::vector<std::vector<double>> out;
  size_t at = 0;
  for (const auto& f : spec.action) {
    std::vector<double> v;
    for (int i = 0; i < f.size(); ++i, ++at) {
      const double x = at < a.size() ? std::clamp(a[at], f.clip[0], f.clip[1]) : 0.0;
      v.push_back(f.OffsetAt(i) + f.ScaleAt(i) * x);
    }
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace

geometry_msgs::Twist MakeTwist(const RobotSpec& spec, const std::vector<double>& a,
                               const std::string& topic) {
  geometry_msgs::Twist t;
  const auto values = CommandValues(spec, a);
  const std::string& on = topic.empty() ? spec.action_topic : topic;
  for (size_t k = 0; k < spec.action.size(); ++k) {
    if (spec.action[k].topic != on) continue;
    const auto paths = ResolveFieldPaths(spec.action[k], spec.source);
    for (size_t i = 0; i < paths.size(); ++i) {
      auto [group, c] = SplitLast(paths[i]);
      if (group.rfind("twist.", 0) == 0) group = group.substr(6);  // TwistStamped paths
      SetComponent(group == "linear" ? &t.linear : &t.angular, c, values[k][i]);
    }
  }
  return t;
}

std_msgs::Float64MultiArray MakeFloat64MultiArray(const RobotSpec& spec,
                                                  const std::vector<double>& a,
                                                  const std::string& topic) {
  std_msgs::Float64MultiArray m;
  const auto values = CommandValues(spec, a);
  const std::string& on = topic.empty() ? spec.action_topic : topic;
  for (size_t k = 0; k < spec.action.size(); ++k) {
    if (spec.action[k].topic != on) continue;
    const auto paths = ResolveFieldPaths(spec.action[k], spec.source);
    for (size_t i = 0; i < paths.size(); ++i) {
      const size_t idx = std::stoul(paths[i].substr(5, paths[i].size() - 6));
      if (m.data.size() <= idx) m.data.resize(idx + 1, 0.0);
      m.data[idx] = values[k][i];
    }
  }
  return m;
}

trajectory_msgs::JointTrajectory MakeJointTrajectory(const RobotSpec& spec,
                                                     const std::vector<double>& a,
                                                     const std::string& topic) {
  trajectory_msgs::JointTrajectory m;
  trajectory_msgs::JointTrajectoryPoint pt;
  const auto values = CommandValues(spec, a);
  const std::string& on = topic.empty() ? spec.action_topic : topic;
  for (size_t k = 0; k < spec.action.size(); ++k) {
    const auto& f = spec.action[k];
    if (f.topic != on) continue;
    for (size_t i = 0; i < f.joints.size(); ++i) {
      m.joint_names.push_back(f.joints[i]);
      (f.field == "points[0].positions" ? pt.positions : pt.velocities).push_back(values[k][i]);
    }
  }
  pt.time_from_start = ros::Duration(1.0 / spec.control_rate);
  m.points.push_back(pt);
  return m;
}

bool TopicHistory::Add(TopicSample s) {
  if (!samples_.empty() && s.stamp < samples_.back().stamp) return false;
  samples_.push_back(std::move(s));
  return true;
}

const TopicSample* TopicHistory::LatestAtOrBefore(const ros::Time& t) const {
  auto it = std::upper_bound(samples_.begin(), samples_.end(), t,
                             [](const ros::Time& x, const TopicSample& s) { return x < s.stamp; });
  return it == samples_.begin() ? nullptr : &*std::prev(it);
}

const TopicSample* TopicHistory::LatestBefore(const ros::Time& t) const {
  auto it = std::lower_bound(samples_.begin(), samples_.end(), t,
                             [](const TopicSample& s, const ros::Time& x) { return s.stamp < x; });
  return it == samples_.begin() ? nullptr : &*std::prev(it);
}

std::string SampleImage(const RobotSpec& spec, const SpecImage& im, const TopicHistory& images,
                        const ros::Time& t, const ros::Time& not_before, const TopicSample** out) {
  const ros::Duration tol(spec.tolerance), stale(spec.stale_after);
  const TopicSample* s = images.LatestAtOrBefore(t + tol);
  if (s == nullptr || s->stamp < Before(not_before, tol))
    return "topic " + im.topic + " (image '" + im.name + "'): no image yet";
  if (s->stamp < Before(t, stale))
    return "topic " + im.topic + " (image '" + im.name + "'): newest image is " +
           std::to_string((t - s->stamp).toSec()) + " s old (stale_after " +
           std::to_string(spec.stale_after) + " s)";
  *out = s;
  return "";
}

std::string SampleObservation(const RobotSpec& spec, const SpecLayout& layout,
                              const std::vector<TopicHistory>& histories, const ros::Time& t,
                              const ros::Time& not_before, std::vector<float>* obs,
                              std::vector<int>* stale_topics) {
  obs->assign(spec.obs_dim(), 0.f);
  std::string why;
  const ros::Duration tol(spec.tolerance), stale(spec.stale_after);
  for (size_t k = 0; k < layout.topics.size(); ++k) {
    const auto& topic = layout.topics[k];
    const TopicSample* s = histories[k].LatestAtOrBefore(t + tol);
    const bool missing = s == nullptr || s->stamp < Before(not_before, tol);
    const bool old = !missing && s->stamp < Before(t, stale);
    if (missing || old) {
      if (stale_topics) stale_topics->push_back(static_cast<int>(k));
      if (why.empty()) {
        const SpecField& f = spec.observation[topic.fields[0]];
        why = "topic " + topic.name + " (field '" + f.name + "'): " +
              (missing ? std::string("no message yet")
                       : "newest message is " + std::to_string((t - s->stamp).toSec()) +
                             " s old (stale_after " + std::to_string(spec.stale_after) + " s)");
      }
      continue;
    }
    for (size_t j = 0; j < topic.fields.size(); ++j) {
      const int n = spec.observation[topic.fields[j]].size();
      for (int i = 0; i < n; ++i)
        (*obs)[topic.obs_offset[j] + i] = static_cast<float>(s->values[topic.field_offset[j] + i]);
    }
  }
  return why;
}

std::string NewestCommand(const RobotSpec& spec, const std::string& topic,
                          const TopicHistory& commands, const ros::Time& t,
                          const ros::Time& not_before, const TopicSample** out) {
  const ros::Duration tol(spec.tolerance), stale(spec.stale_after), period(1.0 / spec.control_rate);
  const TopicSample* s = commands.LatestBefore(t + period - tol);
  if (s == nullptr || s->stamp < Before(not_before, tol))
    return "topic " + topic + ": no command yet";
  if (s->stamp < Before(t, stale))
    return "topic " + topic + ": newest command is " + std::to_string((t - s->stamp).toSec()) +
           " s old (stale_after " + std::to_string(spec.stale_after) + " s)";
  *out = s;
  return "";
}

std::string SampleAction(const RobotSpec& spec, const TopicHistory& commands, const ros::Time& t,
                         const ros::Time& not_before, std::vector<float>* a) {
  const TopicSample* s = nullptr;
  const std::string why = NewestCommand(spec, spec.action_topic, commands, t, not_before, &s);
  if (!why.empty()) return why;
  a->assign(s->values.begin(), s->values.end());
  return "";
}

std::string SampleCommands(const RobotSpec& spec,
                           const std::vector<RobotSpec::CommandTopic>& topics,
                           const std::vector<TopicHistory>& commands, const ros::Time& t,
                           const ros::Time& not_before, std::vector<float>* a) {
  a->assign(spec.action_dim(), 0.f);
  for (size_t k = 0; k < topics.size(); ++k) {
    const TopicSample* s = nullptr;
    const std::string why = NewestCommand(spec, topics[k].topic, commands[k], t, not_before, &s);
    if (!why.empty()) return why;
    PutCommand(spec, topics[k], *s, a);
  }
  return "";
}

void PutCommand(const RobotSpec& spec, const RobotSpec::CommandTopic& topic, const TopicSample& s,
                std::vector<float>* a) {
  int at = 0;
  for (size_t j = 0; j < topic.fields.size(); ++j) {
    const int n = spec.action[topic.fields[j]].size();
    for (int i = 0; i < n; ++i)
      (*a)[topic.action_offset[j] + i] = static_cast<float>(s.values[at + i]);
    at += n;
  }
}

}  // namespace msspr::ros_bridge
