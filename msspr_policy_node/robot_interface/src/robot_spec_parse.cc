// Reading a robot interface spec from YAML (ParseRobotSpec, LoadRobotSpec): every key
// checked, every error naming the file, the section and the field.
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "msspr_robot_interface/robot_spec.h"
#include "robot_spec_internal.h"

namespace msspr::ros_bridge {

using spec_internal::Where;

namespace {

bool HasHeader(const std::string& type) {
  return type != kTwistType && type != kFloat64MultiArrayType;
}

bool IsCommandType(const std::string& type) {
  return type == kTwistType || type == kTwistStampedType || type == kFloat64MultiArrayType ||
         type == kJointTrajectoryType;
}

bool KnownType(const std::string& type) {
  return type == kTf2Type || type == kOdometryType || type == kPoseStampedType ||
         type == kTwistType || type == kTwistStampedType || type == kJointStateType ||
         type == kFloat64MultiArrayType || type == kJointTrajectoryType;
}

// Reads the keys of a YAML map into typed values; rejects the keys it never read.
class MapReader {
 public:
  MapReader(const YAML::Node& node, std::string where) : node_(node), where_(std::move(where)) {
    if (!node_.IsMap()) throw RobotSpecError(where_ + "must be a map");
  }
  template <class T>
  bool Get(const char* key, T* value) {
    seen_.insert(key);
    const YAML::Node child = node_[key];
    if (!child) return false;
    try {
      *value = child.as<T>();
    } catch (const YAML::Exception& e) {
      throw RobotSpecError(where_ + "bad value for '" + key + "': " + e.what());
    }
    return true;
  }
  // A number or a list of numbers.
  bool GetNumbers(const char* key, std::vector<double>* value) {
    seen_.insert(key);
    const YAML::Node child = node_[key];
    if (!child) return false;
    try {
      *value = child.IsSequence() ? child.as<std::vector<double>>()
                                  : std::vector<double>{child.as<double>()};
    } catch (const YAML::Exception& e) {
      throw RobotSpecError(where_ + "bad value for '" + key +
                           "' (a number or a list of numbers): " + e.what());
    }
    for (double v : *value)
      if (!std::isfinite(v)) throw RobotSpecError(where_ + "'" + key + "' must be finite");
    return true;
  }
  YAML::Node Child(const char* key) {
    seen_.insert(key);
    return node_[key];
  }
  void CheckNoUnknownKeys() const {
    for (const auto& kv : node_) {
      const std::string key = kv.first.as<std::string>();
      if (!seen_.count(key)) throw RobotSpecError(where_ + "unknown key '" + key + "'");
    }
  }

 private:
  YAML::Node node_;
  std::string where_;
  std::set<std::string> seen_;
};

// Reads one field entry. `kind`: "observation", "action" or "goal".
SpecField ReadField(const YAML::Node& node, const std::string& source, const std::string& kind,
                    int index, const std::string& default_topic, const std::string& default_type) {
  SpecField f;
  if (!node.IsMap())
    throw RobotSpecError(source + ": " + kind + " field " + std::to_string(index) +
                         ": must be a map");
  // Name and topic first, so that every later error names them.
  if (node["name"]) f.name = node["name"].as<std::string>("");
  if (kind != "observation") f.topic = default_topic;
  if ((kind == "observation" || kind == "action") && node["topic"])
    f.topic = node["topic"].as<std::string>("");
  if (kind == "observation" && !node["topic"] && node["type"] &&
      node["type"].as<std::string>("") == kTf2Type)
    f.topic = kTf2Topic;
  if (node["field"]) f.field = node["field"].as<std::string>("");
  const std::string where = Where(source, kind, f);
  MapReader r(node, where);
  r.Get("name", &f.name);
  if (kind == "goal") {
    std::string obs;
    r.Get("observation", &obs);  // read by the caller
  }
  if (kind == "observation") {
    r.Get("type", &f.type);
    if (f.type == kTf2Type) {
      // tf2 fields are read from /tf and /tf_static; `topic`, when given, must say so.
      if (r.Get("topic", &f.topic) && f.topic != kTf2Topic && f.topic != "/tf")
        throw RobotSpecError(
            where + "a tf2 field is read from /tf and /tf_static: leave out topic (or say tf)");
      f.topic = kTf2Topic;
      if (!r.Get("frames", &f.frames) || f.frames.size() != 2 || f.frames[0].empty() ||
          f.frames[1].empty() || f.frames[0] == f.frames[1])
        throw RobotSpecError(where +
                             "a tf2 field needs frames: [parent, child] (two different frames)");
      for (const auto& fr : f.frames)
        if (fr[0] == '/')
          throw RobotSpecError(where + "tf2 frame '" + fr + "' must not start with '/'");
    } else {
      if (!r.Get("topic", &f.topic) || f.topic.empty()) throw RobotSpecError(where + "no topic");
      if (f.type.empty()) throw RobotSpecError(where + "no type");
    }
  } else if (kind == "action") {
    // A field may name its own command topic and type (default: the action's).
    f.type = default_type;
    const bool own_topic = r.Get("topic", &f.topic);
    if (own_topic && f.topic.empty()) throw RobotSpecError(where + "empty topic");
    if (!own_topic) f.topic = default_topic;
    if (r.Get("type", &f.type) && !own_topic)
      throw RobotSpecError(where + "a field with its own type needs its own topic");
    if (own_topic && f.topic != default_topic && !node["type"])
      throw RobotSpecError(where + "a field on its own topic needs its type");
    if (!IsCommandType(f.type))
      throw RobotSpecError(where + "unsupported command type '" + f.type +
                           "' (supported: geometry_msgs/Twist, geometry_msgs/TwistStamped, "
                           "std_msgs/Float64MultiArray, trajectory_msgs/JointTrajectory)");
  } else {
    f.topic = default_topic;
    f.type = default_type;
  }
  if (f.type == kImageType || f.type == kCompressedImageType)
    throw RobotSpecError(where + "images (" + f.type +
                         ") are not observation fields: name the camera in the images: section");
  if (!KnownType(f.type))
    throw RobotSpecError(
        where + "unsupported message type '" + f.type +
        "' (supported: nav_msgs/Odometry, geometry_msgs/PoseStamped, tf2, geometry_msgs/Twist, "
        "geometry_msgs/TwistStamped, sensor_msgs/JointState, std_msgs/Float64MultiArray, "
        "trajectory_msgs/JointTrajectory)");
  if (!r.Get("field", &f.field) || f.field.empty()) throw RobotSpecError(where + "no field");
  r.Get("components", &f.components);
  r.Get("joints", &f.joints);
  r.Get("derive", &f.derive);
  r.GetNumbers("scale", &f.scale);
  r.GetNumbers("offset", &f.offset);
  if (kind == "action") r.GetNumbers("clip", &f.clip);
  if (kind == "observation") f.has_clip = r.GetNumbers("clip", &f.clip);
  if (kind == "observation") r.Get("stamp", &f.stamp);
  r.CheckNoUnknownKeys();
  if (f.stamp.empty()) f.stamp = HasHeader(f.type) ? "header" : "receipt";
  if (f.stamp != "header" && f.stamp != "receipt")
    throw RobotSpecError(where + "stamp must be header or receipt, got '" + f.stamp + "'");
  if (f.stamp == "header" && !HasHeader(f.type))
    throw RobotSpecError(where + f.type + " has no header: stamp must be receipt");
  if (f.derive != "" && f.derive != "yaw" && f.derive != "yaw_cos_sin")
    throw RobotSpecError(where + "derive must be yaw or yaw_cos_sin, got '" + f.derive + "'");
  if (kind == "action" && !f.derive.empty())
    throw RobotSpecError(where + "an action field cannot derive");
  // Resolving the paths checks field, components and joints against the type.
  const int n = static_cast<int>(ResolveFieldPaths(f, source).size());
  if (!f.derive.empty() && n != 4)
    throw RobotSpecError(where + "derive " + f.derive + " needs a quaternion (x, y, z, w), got " +
                         std::to_string(n) + " numbers");
  const int size = f.size();
  for (auto* v : {&f.scale, &f.offset}) {
    if (v->size() != 1 && static_cast<int>(v->size()) != size)
      throw RobotSpecError(where + "scale and offset must be one number or " +
                           std::to_string(size) + " (one per value), got " +
                           std::to_string(v->size()));
  }
  for (size_t i = 0; i < f.scale.size(); ++i)
    if (f.scale[i] == 0.0) throw RobotSpecError(where + "scale must not be 0");
  if (f.clip.size() != 2 || !(f.clip[0] < f.clip[1]))
    throw RobotSpecError(where + "clip must be [low, high] with low < high");
  return f;
}

// Reads one camera of the images: section.
SpecImage ReadImage(const YAML::Node& node, const std::string& source, int index) {
  SpecImage im;
  if (!node.IsMap())
    throw RobotSpecError(source + ": image " + std::to_string(index) + ": must be a map");
  if (node["topic"]) im.topic = node["topic"].as<std::string>("");
  if (node["name"]) im.name = node["name"].as<std::string>("");
  if (im.name.empty()) im.name = im.topic;
  const std::string where = source + ": image '" + im.name + "'" +
                            (im.topic.empty() ? "" : " (topic " + im.topic + ")") + ": ";
  MapReader r(node, where);
  r.Get("name", &im.name);
  if (im.name.empty()) im.name = im.topic;
  if (!r.Get("topic", &im.topic) || im.topic.empty()) throw RobotSpecError(where + "no topic");
  if (!r.Get("type", &im.type) || im.type.empty()) throw RobotSpecError(where + "no type");
  if (im.type != kImageType && im.type != kCompressedImageType)
    throw RobotSpecError(where + "unsupported image type '" + im.type +
                         "' (supported: " + kImageType + " with encoding rgb8, bgr8 or mono8; " +
                         kCompressedImageType + " with jpeg or png)");
  if (!r.Get("size", &im.size))
    throw RobotSpecError(where + "no size (the network's image side, e.g. 64)");
  if (im.size < 8 || im.size > 1024) throw RobotSpecError(where + "size must be in 8..1024 pixels");
  r.CheckNoUnknownKeys();
  return im;
}

}  // namespace

namespace {

// control_rate, alignment and episodes.
void ReadTiming(MapReader& top, const std::string& source, RobotSpec* s) {
  top.Get("control_rate", &s->control_rate);
  if (!(s->control_rate > 0 && std::isfinite(s->control_rate)))
    throw RobotSpecError(source + ": control_rate must be > 0 (Hz)");
  if (YAML::Node a = top.Child("alignment")) {
    MapReader r(a, source + ": alignment: ");
    r.Get("tolerance", &s->tolerance);
    r.Get("stale_after", &s->stale_after);
    r.CheckNoUnknownKeys();
  }
  const double dt = 1.0 / s->control_rate;
  if (!(s->tolerance >= 0 && s->tolerance < dt / 2))
    throw RobotSpecError(source + ": alignment: tolerance must be in [0, half a control period)");
  if (!(s->stale_after > 0 && std::isfinite(s->stale_after)))
    throw RobotSpecError(source + ": alignment: stale_after must be > 0 (s)");
  if (YAML::Node e = top.Child("episodes")) {
    MapReader r(e, source + ": episodes: ");
    r.Get("split_by", &s->episodes.split_by);
    r.Get("gap", &s->episodes.gap);
    r.Get("topic", &s->episodes.topic);
    r.CheckNoUnknownKeys();
  }
  const auto& ep = s->episodes;
  if (ep.split_by != "gap" && ep.split_by != "topic" && ep.split_by != "bag")
    throw RobotSpecError(source + ": episodes: split_by must be gap, topic or bag, got '" +
                         ep.split_by + "'");
  if (ep.split_by == "topic" && ep.topic.empty())
    throw RobotSpecError(source + ": episodes: split_by topic needs a topic");
  if (!(ep.gap > 0)) throw RobotSpecError(source + ": episodes: gap must be > 0 (s)");
}

// The images: section (one camera at most).
void ReadImages(MapReader& top, const std::string& source, RobotSpec* s) {
  if (const YAML::Node imgs = top.Child("images")) {
    if (!imgs.IsSequence() || imgs.size() == 0)
      throw RobotSpecError(source + ": images must be a non-empty list of cameras");
    if (imgs.size() > 1)
      throw RobotSpecError(source + ": images: " + std::to_string(imgs.size()) +
                           " cameras, a pixels policy takes one");
    for (size_t i = 0; i < imgs.size(); ++i)
      s->images.push_back(ReadImage(imgs[i], source, static_cast<int>(i)));
  }
}

// The observation fields, each named once.
void ReadObservation(MapReader& top, const std::string& source, RobotSpec* s) {
  const YAML::Node obs = top.Child("observation");
  if (!obs || !obs.IsSequence() || obs.size() == 0)
    throw RobotSpecError(source + ": observation must be a non-empty list of fields");
  std::set<std::string> names;
  for (size_t i = 0; i < obs.size(); ++i) {
    SpecField f = ReadField(obs[i], source, "observation", static_cast<int>(i), "", "");
    if (f.name.empty()) f.name = f.topic + ":" + f.field;
    if (!names.insert(f.name).second)
      throw RobotSpecError(source + ": observation field '" + f.name + "' is named twice");
    s->observation.push_back(std::move(f));
  }
}

// The command: its topic, type, stamp and fields (on one or more topics).
void ReadAction(MapReader& top, const std::string& source, RobotSpec* s) {
  const YAML::Node act = top.Child("action");
  if (!act) throw RobotSpecError(source + ": no action");
  {
    MapReader r(act, source + ": action: ");
    if (!r.Get("topic", &s->action_topic) || s->action_topic.empty())
      throw RobotSpecError(source + ": action: no topic");
    if (!r.Get("type", &s->action_type) || s->action_type.empty())
      throw RobotSpecError(source + ": action (topic " + s->action_topic + "): no type");
    if (s->action_type != kTwistType && s->action_type != kTwistStampedType &&
        s->action_type != kFloat64MultiArrayType && s->action_type != kJointTrajectoryType)
      throw RobotSpecError(source + ": action (topic " + s->action_topic +
                           "): unsupported command type '" + s->action_type +
                           "' (supported: geometry_msgs/Twist, geometry_msgs/TwistStamped, "
                           "std_msgs/Float64MultiArray, trajectory_msgs/JointTrajectory)");
    r.Get("stamp", &s->action_stamp);
    const YAML::Node fields = r.Child("fields");
    r.CheckNoUnknownKeys();
    if (s->action_stamp.empty()) s->action_stamp = HasHeader(s->action_type) ? "header" : "receipt";
    if (s->action_stamp != "header" && s->action_stamp != "receipt")
      throw RobotSpecError(source + ": action (topic " + s->action_topic +
                           "): stamp must be header or receipt");
    if (s->action_stamp == "header" && !HasHeader(s->action_type))
      throw RobotSpecError(source + ": action (topic " + s->action_topic + "): " + s->action_type +
                           " has no header: stamp must be receipt");
    if (!fields || !fields.IsSequence() || fields.size() == 0)
      throw RobotSpecError(source + ": action (topic " + s->action_topic +
                           "): fields must be a non-empty list");
    std::set<std::string> anames;
    for (size_t i = 0; i < fields.size(); ++i) {
      SpecField f = ReadField(fields[i], source, "action", static_cast<int>(i), s->action_topic,
                              s->action_type);
      f.stamp =
          f.topic == s->action_topic ? s->action_stamp : (HasHeader(f.type) ? "header" : "receipt");
      for (const auto& g : s->action)
        if (g.topic == f.topic && g.type != f.type)
          throw RobotSpecError(source + ": action field '" + f.name + "' (topic " + f.topic +
                               "): type " + f.type + ", but field '" + g.name + "' publishes " +
                               g.type + " on that topic");
      if (f.name.empty()) f.name = f.field;
      if (!anames.insert(f.name).second)
        throw RobotSpecError(source + ": action field '" + f.name + "' is named twice");
      s->action.push_back(std::move(f));
    }
  }
}

// The goal: a pose filling observation fields, a full observation or an image; none
// (goals from ~set_goal only) without a goal section.
void ReadGoal(MapReader& top, const std::string& source, RobotSpec* s) {
  if (YAML::Node g = top.Child("goal")) {
    MapReader r(g, source + ": goal: ");
    r.Get("source", &s->goal.source);
    r.Get("topic", &s->goal.topic);
    r.Get("type", &s->goal.type);
    const YAML::Node fields = r.Child("fields");
    r.CheckNoUnknownKeys();
    if (!s->images.empty() && s->goal.source != "image")
      throw RobotSpecError(
          source +
          ": goal: a spec with images serves pixels policies, whose goal is an image: "
          "source image, got '" +
          s->goal.source + "'");
    if (s->goal.source == "image") {
      if (!g["type"]) s->goal.type = kImageType;
      if (!g["topic"]) s->goal.topic = "goal_image";
      if (s->goal.type != kImageType && s->goal.type != kCompressedImageType)
        throw RobotSpecError(source + ": goal (topic " + s->goal.topic + "): source image takes " +
                             kImageType + " or " + kCompressedImageType + ", got '" + s->goal.type +
                             "'");
      if (fields)
        throw RobotSpecError(source + ": goal (topic " + s->goal.topic +
                             "): source image has no fields");
      if (s->images.empty())
        throw RobotSpecError(source + ": goal (topic " + s->goal.topic +
                             "): source image needs a camera in the images: section (its size)");
    } else if (s->goal.source == "observation") {
      if (!g["type"]) s->goal.type = kFloat64MultiArrayType;
      if (s->goal.type != kFloat64MultiArrayType)
        throw RobotSpecError(
            source + ": goal (topic " + s->goal.topic +
            "): source observation takes std_msgs/Float64MultiArray (the full observation)");
      if (fields)
        throw RobotSpecError(source + ": goal (topic " + s->goal.topic +
                             "): source observation has no fields");
    } else if (s->goal.source == "pose") {
      if (s->goal.type != kPoseStampedType)
        throw RobotSpecError(source + ": goal (topic " + s->goal.topic +
                             "): source pose takes geometry_msgs/PoseStamped");
      if (!fields || !fields.IsSequence() || fields.size() == 0)
        throw RobotSpecError(source + ": goal (topic " + s->goal.topic +
                             "): fields must be a non-empty list");
      for (size_t i = 0; i < fields.size(); ++i) {
        SpecGoal::Part p;
        if (!fields[i].IsMap() || !fields[i]["observation"])
          throw RobotSpecError(source + ": goal (topic " + s->goal.topic + ") field " +
                               std::to_string(i) +
                               ": no 'observation' (the observation field it fills)");
        p.observation = fields[i]["observation"].as<std::string>();
        p.field =
            ReadField(fields[i], source, "goal", static_cast<int>(i), s->goal.topic, s->goal.type);
        if (p.field.name.empty()) p.field.name = p.observation;
        const SpecField* target = nullptr;
        for (const auto& f : s->observation)
          if (f.name == p.observation) target = &f;
        if (!target)
          throw RobotSpecError(source + ": goal (topic " + s->goal.topic + ", " + p.field.field +
                               "): no observation field named '" + p.observation + "'");
        if (target->size() != p.field.size())
          throw RobotSpecError(source + ": goal (topic " + s->goal.topic + ", " + p.field.field +
                               ") gives " + std::to_string(p.field.size()) +
                               " numbers, observation field '" + p.observation + "' has " +
                               std::to_string(target->size()));
        s->goal.parts.push_back(std::move(p));
      }
    } else {
      throw RobotSpecError(source + ": goal: source must be pose, observation or image, got '" +
                           s->goal.source + "'");
    }
    if (s->goal.topic.empty()) throw RobotSpecError(source + ": goal: no topic");
  } else {
    if (!s->images.empty())
      throw RobotSpecError(
          source + ": a spec with images needs a goal (source image: the goal camera topic)");
    s->goal.source = "";  // no goal topic: goals come from ~set_goal only
    s->goal.topic = "";
  }
}

}  // namespace

RobotSpec ParseRobotSpec(const std::string& yaml, const std::string& source) {
  RobotSpec s;
  s.source = source;
  s.text = yaml;
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    throw RobotSpecError(source + ": YAML parse error: " + e.what());
  }
  if (!root.IsMap()) throw RobotSpecError(source + ": top level must be a map");
  try {
    MapReader top(root, source + ": ");
    top.Get("name", &s.name);
    top.Get("namespace", &s.ns);
    ReadTiming(top, source, &s);
    ReadImages(top, source, &s);
    ReadObservation(top, source, &s);
    ReadAction(top, source, &s);
    ReadGoal(top, source, &s);
    top.CheckNoUnknownKeys();
  } catch (const YAML::Exception& e) {
    throw RobotSpecError(source + ": " + e.what());
  }
  return s;
}

RobotSpec LoadRobotSpec(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw RobotSpecError(path + ": cannot open robot spec");
  std::stringstream ss;
  ss << in.rdbuf();
  return ParseRobotSpec(ss.str(), path);
}

}  // namespace msspr::ros_bridge
