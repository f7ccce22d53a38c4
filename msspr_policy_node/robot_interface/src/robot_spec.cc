#include "msspr_robot_interface/robot_spec.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>

#include "robot_spec_internal.h"

namespace msspr::ros_bridge {
namespace {

// Numeric groups of the geometry types, by the path prefix that holds them.
const std::vector<std::string> kXyz = {"x", "y", "z"};
const std::vector<std::string> kXyzw = {"x", "y", "z", "w"};

// The groups (path -> component names) a message type has; empty for the
// types read by joint name or array index.
const std::map<std::string, std::vector<std::string>>& Groups(const std::string& type) {
  static const std::map<std::string, std::map<std::string, std::vector<std::string>>> kGroups = {
      {kOdometryType,
       {{"pose.pose.position", kXyz},
        {"pose.pose.orientation", kXyzw},
        {"twist.twist.linear", kXyz},
        {"twist.twist.angular", kXyz}}},
      {kPoseStampedType, {{"pose.position", kXyz}, {"pose.orientation", kXyzw}}},
      {kTwistType, {{"linear", kXyz}, {"angular", kXyz}}},
      {kTwistStampedType, {{"twist.linear", kXyz}, {"twist.angular", kXyz}}},
      {kTf2Type, {{"translation", kXyz}, {"rotation", kXyzw}}},
  };
  static const std::map<std::string, std::vector<std::string>> kNone;
  auto it = kGroups.find(type);
  return it == kGroups.end() ? kNone : it->second;
}

// Parses "data[3]" or "data[0:6]" into [begin, end); false when it is not one.
bool ParseArrayRange(const std::string& field, int* begin, int* end) {
  if (field.rfind("data[", 0) != 0 || field.back() != ']') return false;
  const std::string inner = field.substr(5, field.size() - 6);
  const size_t colon = inner.find(':');
  try {
    size_t used = 0;
    if (colon == std::string::npos) {
      *begin = std::stoi(inner, &used);
      if (used != inner.size()) return false;
      *end = *begin + 1;
    } else {
      const std::string a = inner.substr(0, colon), b = inner.substr(colon + 1);
      *begin = std::stoi(a, &used);
      if (used != a.size()) return false;
      *end = std::stoi(b, &used);
      if (used != b.size()) return false;
    }
  } catch (const std::exception&) {
    return false;
  }
  return *begin >= 0 && *end > *begin && *end <= 100000;
}

std::string Fmt(const std::vector<double>& v) {
  std::ostringstream s;
  s.precision(17);
  s << "[";
  for (size_t i = 0; i < v.size(); ++i) s << (i ? ", " : "") << v[i];
  s << "]";
  return s.str();
}

std::string Fmt(const std::vector<std::string>& v) {
  std::string s = "[";
  for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
  return s + "]";
}

}  // namespace

namespace spec_internal {

// "SPEC: observation field 'position' (topic odom, pose.pose.position): "
std::string Where(const std::string& source, const std::string& kind, const SpecField& f) {
  std::string s = source + ": " + kind + (kind.empty() ? "field" : " field");
  if (!f.name.empty()) s += " '" + f.name + "'";
  if (!f.topic.empty())
    s += " (topic " + f.topic + (f.field.empty() ? "" : ", " + f.field) + ")";
  else if (!f.field.empty())
    s += " (" + f.field + ")";
  return s + ": ";
}

}  // namespace spec_internal

using spec_internal::Where;

int SpecField::size() const {
  if (derive == "yaw") return 1;
  if (derive == "yaw_cos_sin") return 2;
  if (type == kJointStateType || type == kJointTrajectoryType)
    return static_cast<int>(joints.size());
  int b = 0, e = 0;
  if (type == kFloat64MultiArrayType && ParseArrayRange(field, &b, &e)) return e - b;
  if (!components.empty()) return static_cast<int>(components.size());
  const auto& groups = Groups(type);
  auto it = groups.find(field);
  return it == groups.end() ? 1 : static_cast<int>(it->second.size());
}

std::vector<std::string> ResolveFieldPaths(const SpecField& f, const std::string& source) {
  const std::string where = Where(source, "", f);
  std::vector<std::string> out;
  if (f.type == kJointStateType || f.type == kJointTrajectoryType) {
    const bool js = f.type == kJointStateType;
    const std::set<std::string> ok =
        js ? std::set<std::string>{"position", "velocity", "effort"}
           : std::set<std::string>{"points[0].positions", "points[0].velocities"};
    if (!ok.count(f.field))
      throw RobotSpecError(
          where + f.type + " has no field '" + f.field + "' (it has " +
          (js ? "position, velocity, effort" : "points[0].positions, points[0].velocities") + ")");
    if (f.joints.empty())
      throw RobotSpecError(where + "no joints: " + f.type + " is read by joint name");
    std::set<std::string> seen;
    for (const auto& j : f.joints) {
      if (j.empty() || !seen.insert(j).second)
        throw RobotSpecError(where + "joint '" + j + "' is empty or named twice");
      out.push_back(f.field);
    }
    if (!f.components.empty()) throw RobotSpecError(where + "components do not apply to " + f.type);
    return out;
  }
  if (!f.joints.empty())
    throw RobotSpecError(where + "joints apply to JointState and JointTrajectory only");
  if (!f.frames.empty() && f.type != kTf2Type)
    throw RobotSpecError(where + "frames apply to tf2 fields only");
  if (f.type == kFloat64MultiArrayType) {
    int b = 0, e = 0;
    if (!ParseArrayRange(f.field, &b, &e))
      throw RobotSpecError(where +
                           "std_msgs/Float64MultiArray is read as data[i] or data[a:b], got '" +
                           f.field + "'");
    for (int i = b; i < e; ++i) out.push_back("data[" + std::to_string(i) + "]");
    return out;
  }
  const auto& groups = Groups(f.type);
  auto it = groups.find(f.field);
  if (it == groups.end()) {
    // A single number: GROUP.c
    const size_t dot = f.field.rfind('.');
    if (dot != std::string::npos) {
      auto g = groups.find(f.field.substr(0, dot));
      const std::string c = f.field.substr(dot + 1);
      if (g != groups.end() &&
          std::find(g->second.begin(), g->second.end(), c) != g->second.end()) {
        if (!f.components.empty())
          throw RobotSpecError(where + "components apply to a group such as " + g->first +
                               ", not to one number");
        return {f.field};
      }
    }
    std::string have;
    for (const auto& [path, comps] : groups) have += (have.empty() ? "" : ", ") + path + Fmt(comps);
    throw RobotSpecError(where + f.type + " has no field '" + f.field + "' (it has " + have + ")");
  }
  if (f.components.empty()) {
    for (const auto& c : it->second) out.push_back(f.field + "." + c);
    return out;
  }
  for (const auto& c : f.components) {
    if (std::find(it->second.begin(), it->second.end(), c) == it->second.end())
      throw RobotSpecError(where + f.field + " has no component '" + c + "' (it has " +
                           Fmt(it->second) + ")");
    out.push_back(f.field + "." + c);
  }
  return out;
}

int RobotSpec::obs_dim() const {
  int n = 0;
  for (const auto& f : observation) n += f.size();
  return n;
}

int RobotSpec::action_dim() const {
  int n = 0;
  for (const auto& f : action) n += f.size();
  return n;
}

std::vector<RobotSpec::CommandTopic> RobotSpec::CommandTopics() const {
  std::vector<CommandTopic> out;
  int at = 0;
  for (int i = 0; i < static_cast<int>(action.size()); ++i) {
    const SpecField& f = action[i];
    auto it = std::find_if(out.begin(), out.end(),
                           [&](const CommandTopic& c) { return c.topic == f.topic; });
    if (it == out.end()) {
      out.push_back(CommandTopic{f.topic, f.type, f.stamp, {}, {}, 0});
      it = out.end() - 1;
    }
    it->fields.push_back(i);
    it->action_offset.push_back(at);
    it->size += f.size();
    at += f.size();
  }
  return out;
}

std::vector<std::string> RobotSpec::ObservationTopics() const {
  std::vector<std::string> out;
  for (const auto& f : observation)
    if (std::find(out.begin(), out.end(), f.topic) == out.end()) out.push_back(f.topic);
  return out;
}

std::string CompareRobotSpecs(const RobotSpec& a, const RobotSpec& b) {
  std::ostringstream s;
  s.precision(17);
  if (a.control_rate != b.control_rate) {
    s << "control_rate " << a.control_rate << " vs " << b.control_rate;
    return s.str();
  }
  auto fields = [&](const char* kind, const std::vector<SpecField>& x,
                    const std::vector<SpecField>& y) -> std::string {
    if (x.size() != y.size())
      return std::string(kind) + ": " + std::to_string(x.size()) + " fields vs " +
             std::to_string(y.size());
    for (size_t i = 0; i < x.size(); ++i) {
      const SpecField& f = x[i];
      const SpecField& g = y[i];
      const std::string who = std::string(kind) + " field " + std::to_string(i) + " '" + f.name +
                              "' (topic " + f.topic + ", " + f.field + "): ";
      if (f.topic != g.topic) return who + "topic " + f.topic + " vs " + g.topic;
      if (f.type != g.type) return who + "type " + f.type + " vs " + g.type;
      if (f.field != g.field) return who + "field " + f.field + " vs " + g.field;
      if (f.components != g.components)
        return who + "components " + Fmt(f.components) + " vs " + Fmt(g.components);
      if (f.joints != g.joints) return who + "joints " + Fmt(f.joints) + " vs " + Fmt(g.joints);
      if (f.frames != g.frames) return who + "frames " + Fmt(f.frames) + " vs " + Fmt(g.frames);
      if (f.has_clip != g.has_clip)
        return who + std::string("clip ") + (f.has_clip ? "set" : "none") + " vs " +
               (g.has_clip ? "set" : "none");
      if (f.derive != g.derive) return who + "derive '" + f.derive + "' vs '" + g.derive + "'";
      if (f.scale != g.scale) return who + "scale " + Fmt(f.scale) + " vs " + Fmt(g.scale);
      if (f.offset != g.offset) return who + "offset " + Fmt(f.offset) + " vs " + Fmt(g.offset);
      if (f.clip != g.clip) return who + "clip " + Fmt(f.clip) + " vs " + Fmt(g.clip);
    }
    return "";
  };
  std::string d = fields("observation", a.observation, b.observation);
  if (!d.empty()) return d;
  if (a.action_type != b.action_type)
    return "action type " + a.action_type + " vs " + b.action_type;
  d = fields("action", a.action, b.action);
  if (!d.empty()) return d;
  if (a.images.size() != b.images.size())
    return "images: " + std::to_string(a.images.size()) + " cameras vs " +
           std::to_string(b.images.size());
  for (size_t i = 0; i < a.images.size(); ++i) {
    const SpecImage& p = a.images[i];
    const SpecImage& q = b.images[i];
    const std::string who =
        "image " + std::to_string(i) + " '" + p.name + "' (topic " + p.topic + "): ";
    if (p.topic != q.topic) return who + "topic " + p.topic + " vs " + q.topic;
    if (p.type != q.type) return who + "type " + p.type + " vs " + q.type;
    if (p.size != q.size)
      return who + "size " + std::to_string(p.size) + " vs " + std::to_string(q.size);
  }
  if (a.goal.source != b.goal.source)
    return "goal source '" + a.goal.source + "' vs '" + b.goal.source + "'";
  if (a.goal.source == "image" && a.goal.type != b.goal.type)
    return "goal (topic " + a.goal.topic + "): type " + a.goal.type + " vs " + b.goal.type;
  if (a.goal.parts.size() != b.goal.parts.size()) return "goal: different number of fields";
  for (size_t i = 0; i < a.goal.parts.size(); ++i) {
    const auto& p = a.goal.parts[i];
    const auto& q = b.goal.parts[i];
    if (p.observation != q.observation || p.field.field != q.field.field ||
        p.field.components != q.field.components)
      return "goal field " + std::to_string(i) + " (" + p.field.field + " -> " + p.observation +
             ") vs (" + q.field.field + " -> " + q.observation + ")";
  }
  return "";
}

}  // namespace msspr::ros_bridge
