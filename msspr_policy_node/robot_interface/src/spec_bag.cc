#include "msspr_robot_interface/spec_bag.h"

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "msspr_bags/dataset_bag_validator.h"
#include "msspr_robot_interface/robot_fields.h"
#include "msspr_robot_interface/topic_names.h"
#include "spec_bag_recording.h"

namespace msspr::ros_bridge {

using spec_bag_internal::Stamp;

namespace {

// The bag topics of `names` (a spec's topics), resolved under `ns` (topic_names.h).
// Throws BagError naming the bag, what of the spec reads the topics found under no
// namespace (`whos`), the spec and the bag's topics when one is missing.
TopicResolution ResolveInBag(const std::vector<std::string>& names,
                             const std::vector<std::string>& whos,
                             const std::map<std::string, std::string>& bag_topics,
                             const std::string& ns, const std::string& path,
                             const std::string& spec_source) {
  std::set<std::string> topics;
  for (const auto& [t, type] : bag_topics) topics.insert(t);
  try {
    return ResolveSpecTopics(names, topics, ns);
  } catch (const std::invalid_argument& e) {
    std::string readers;
    for (size_t i = 0; i < names.size(); ++i) {
      const std::string suffix = NormalizeNamespace(names[i]);
      const bool anywhere = std::any_of(topics.begin(), topics.end(), [&](const std::string& t) {
        return t.size() >= suffix.size() &&
               t.compare(t.size() - suffix.size(), suffix.size(), suffix) == 0;
      });
      if (!anywhere) readers += (readers.empty() ? "" : ", ") + whos[i];
    }
    std::string have;
    for (const auto& t : topics) have += (have.empty() ? "" : ", ") + t;
    throw BagError(path + ": " + e.what() + " (" + (readers.empty() ? "" : readers + " of ") +
                   spec_source + "); the bag has " + (have.empty() ? "no topics" : have));
  }
}

// Decodes a bag message of type M with `decode`; false when it does not deserialize as M.
template <class M, class F>
bool With(const rosbag::MessageInstance& m, F&& decode) {
  auto msg = m.instantiate<M>();
  if (!msg) return false;
  decode(*msg);
  return true;
}

template <class F>
bool Dispatch(const std::string& type, const rosbag::MessageInstance& m, F&& decode) {
  if (type == kOdometryType) return With<nav_msgs::Odometry>(m, decode);
  if (type == kPoseStampedType) return With<geometry_msgs::PoseStamped>(m, decode);
  if (type == kTwistType) return With<geometry_msgs::Twist>(m, decode);
  if (type == kTwistStampedType) return With<geometry_msgs::TwistStamped>(m, decode);
  if (type == kJointStateType) return With<sensor_msgs::JointState>(m, decode);
  if (type == kFloat64MultiArrayType) return With<std_msgs::Float64MultiArray>(m, decode);
  if (type == kJointTrajectoryType) return With<trajectory_msgs::JointTrajectory>(m, decode);
  return false;
}

}  // namespace

SpecBagReader::~SpecBagReader() = default;

SpecBagReader::SpecBagReader(RobotSpec spec, std::vector<std::string> bags)
    : spec_(std::move(spec)), bags_(std::move(bags)), ns_(spec_.ns) {}

uint64_t SpecBagReader::CountObservations() const {
  uint64_t n = 0;
  for (const auto& path : bags_) {
    try {
      rosbag::Bag bag(path, rosbag::bagmode::Read);
      std::map<std::string, std::string> topics;
      rosbag::View all(bag);
      for (const auto* c : all.getConnections()) topics[c->topic] = c->datatype;
      const std::string& first = spec_.observation[0].topic;
      if (spec_.observation[0].type == kTf2Type) continue;
      std::set<std::string> names;
      for (const auto& [t, type] : topics) names.insert(t);
      try {
        const std::string t = ResolveSpecTopics({first}, names, ns_).topics[0];
        n += rosbag::View(bag, rosbag::TopicQuery(t)).size();
      } catch (const std::invalid_argument&) {
        // (no such topic: ReadBag reports it)
      }
    } catch (const rosbag::BagException& e) {
      throw BagError(path + ": cannot open as a rosbag: " + e.what());
    }
  }
  return n;
}

namespace {

// The serialized bytes of a bag message.
std::vector<uint8_t> MessageBytes(const rosbag::MessageInstance& m) {
  std::vector<uint8_t> buf(m.size());
  ros::serialization::OStream out(buf.data(), static_cast<uint32_t>(buf.size()));
  m.write(out);
  return buf;
}

}  // namespace

void SpecBagReader::ForEachEpisode(const std::function<void(BagEpisode&&)>& fn) {
  report_ = SpecBagReport{};
  for (const auto& f : spec_.observation) {
    SpecFieldReport r;
    r.name = f.name;
    r.topic = f.topic;
    r.type = f.type;
    report_.fields.push_back(r);
  }
  for (const auto& im : spec_.images) {
    SpecFieldReport r;
    r.name = im.name;
    r.topic = im.topic;
    r.type = im.type;
    r.image = true;
    report_.fields.push_back(r);
  }
  const auto commands = spec_.CommandTopics();
  for (const auto& c : commands) {
    SpecFieldReport cmd;
    cmd.name = commands.size() == 1 ? "action" : "action:" + c.topic;
    cmd.topic = c.topic;
    cmd.type = c.type;
    cmd.aligned = c.stamp == "receipt";
    report_.fields.push_back(cmd);
  }
  // The bags in time order (by their first message), whatever order they were given in.
  std::vector<Recording::Bag> all;
  for (const auto& path : bags_) {
    CheckBagStructure(path);
    try {
      rosbag::Bag bag(path, rosbag::bagmode::Read);
      rosbag::View view(bag);
      all.push_back({path, view.getBeginTime(), view.getEndTime()});
    } catch (const rosbag::BagException& e) {
      throw BagError(path + ": cannot open as a rosbag: " + e.what());
    }
  }
  std::stable_sort(all.begin(), all.end(), [](const Recording::Bag& a, const Recording::Bag& b) {
    return a.begin < b.begin;
  });
  // Recordings: a bag continues the recording that ended last before it began (the
  // files of `rosbag record --split` follow each other); a bag that overlaps every
  // recording so far in time is another recording.
  std::vector<std::vector<Recording::Bag>> recordings;
  for (const auto& b : all) {
    int best = -1;
    for (size_t g = 0; g < recordings.size(); ++g) {
      const ros::Time end = recordings[g].back().end;
      if (end <= b.begin && (best < 0 || recordings[best].back().end < end))
        best = static_cast<int>(g);
    }
    if (best < 0) {
      recordings.push_back({b});
    } else {
      recordings[best].push_back(b);
    }
  }
  report_.bags = all.size();
  uint64_t next_id = 0;
  for (const auto& bags : recordings) {
    Recording rec(spec_);
    rec.bags = bags;
    rec.label = bags[0].path;
    if (bags.size() > 1)
      rec.label += " (+" + std::to_string(bags.size() - 1) + " bag" + (bags.size() > 2 ? "s" : "") +
                   " of the same recording)";
    for (size_t i = 0; i < bags.size(); ++i) ReadMessages(bags[i].path, i == 0, &rec);
    EmitEpisodes(&rec, &next_id, fn);
  }
  for (auto& r : report_.fields)
    r.rate_hz = r.messages > 1 && r.last > r.first ? (r.messages - 1) / (r.last - r.first) : 0.0;
}

SpecBagReader::BagTopics SpecBagReader::ResolveTopics(
    const std::string& path, const std::map<std::string, std::string>& bag_topics,
    const Recording& rec) const {
  const RobotSpec& spec = spec_;
  const SpecLayout& layout = rec.layout;
  const auto& cmd_topics = rec.cmd_topics;
  // Every topic of the spec must be in the bag (resolved under the namespace) with the
  // spec's type: the observation topics (not tf2), the commands, the cameras, the episodes'.
  std::vector<std::string> names;
  std::vector<std::string> whos;
  std::vector<std::string> types;
  auto want = [&](const std::string& topic, const std::string& type, const std::string& who) {
    names.push_back(topic);
    types.push_back(type);
    whos.push_back(who);
  };
  for (const auto& topic : layout.topics)
    if (topic.type != kTf2Type)
      want(topic.name, topic.type, "field '" + spec.observation[topic.fields[0]].name + "'");
  for (const auto& c : cmd_topics)
    want(c.topic, c.type, cmd_topics.size() == 1 ? "the action" : "the action on " + c.topic);
  for (const auto& im : spec.images) want(im.topic, im.type, "image '" + im.name + "'");
  if (spec.episodes.split_by == "topic") want(spec.episodes.topic, "", "the episodes");
  const TopicResolution resolution = ResolveInBag(names, whos, bag_topics, ns_, path, spec.source);
  const std::vector<std::string>& resolved = resolution.topics;
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string& t = resolved[i];
    if (!types[i].empty() && bag_topics.at(t) != types[i])
      throw BagError(path + ": topic " + t + " (" + whos[i] + " of " + spec.source + ") holds " +
                     bag_topics.at(t) + ", the spec reads " + types[i]);
  }
  size_t next_resolved = 0;  // the resolved topics, taken in the order they were wanted
  auto resolve = [&]() { return resolved[next_resolved++]; };
  // tf2 fields read /tf (and /tf_static when the bag has it) into a tf2 buffer.
  BagTopics out;
  std::vector<std::string>& obs_topics = out.obs;
  for (const auto& topic : layout.topics) {
    if (topic.type != kTf2Type) {
      obs_topics.push_back(resolve());
      continue;
    }
    const std::string who = "field '" + spec.observation[topic.fields[0]].name + "'";
    for (const char* t : {"/tf", "/tf_static"}) {
      auto it = bag_topics.find(t);
      if (it == bag_topics.end()) {
        if (std::string(t) == "/tf")
          throw BagError(path + ": no topic /tf (" + who + " of " + spec.source + ")");
        continue;
      }
      if (it->second != "tf2_msgs/TFMessage")
        throw BagError(path + ": topic " + t + " (" + who + " of " + spec.source + ") holds " +
                       it->second + ", the spec reads tf2_msgs/TFMessage");
      (std::string(t) == "/tf" ? out.tf : out.tf_static) = t;
    }
    obs_topics.push_back("");  // sampled from the buffer after each /tf message
  }
  for (size_t c = 0; c < cmd_topics.size(); ++c) out.commands.push_back(resolve());
  for (size_t c = 0; c < spec.images.size(); ++c) out.images.push_back(resolve());
  if (spec.episodes.split_by == "topic") {
    out.episode = resolve();
    out.episode_type = bag_topics.at(out.episode);
  }
  // A vector goal is read where the bag holds its topic (under the same namespace).
  if (spec.goal.source != "image") {
    const std::string goal = ResolveTopicName(resolution.ns, spec.goal.topic);
    const auto it = bag_topics.find(goal);
    if (it != bag_topics.end() && it->second == spec.goal.type) out.goal = goal;
  }
  return out;
}

void SpecBagReader::AddFieldProblems(const std::string& path,
                                     const std::vector<SpecFieldReport>& before) {
  // Problems per field (this bag's: the counts since `before`), named by bag, topic and field.
  for (size_t i = 0; i < report_.fields.size(); ++i) {
    SpecFieldReport r = report_.fields[i];
    r.out_of_order -= before[i].out_of_order;
    r.nonfinite -= before[i].nonfinite;
    r.unreadable -= before[i].unreadable;
    r.bad_images -= before[i].bad_images;
    const std::string who =
        path + ": topic " + r.topic + (r.image ? " (image '" : " (field '") + r.name + "'): ";
    if (r.out_of_order)
      report_.problems.push_back(
          who + std::to_string(r.out_of_order) +
          " messages stamped before the one received before them, dropped (first: " +
          r.first_problem + ")");
    if (r.nonfinite)
      report_.problems.push_back(who + std::to_string(r.nonfinite) +
                                 " messages with NaN or Inf rejected");
    if (r.unreadable)
      report_.problems.push_back(who + std::to_string(r.unreadable) +
                                 " messages unreadable (first: " + r.first_problem + ")");
    if (r.bad_images)
      report_.problems.push_back(who + std::to_string(r.bad_images) +
                                 " bad images rejected (first: " + r.first_problem + ")");
  }
}

// One bag's messages, each decoded into the recording and counted in the report's rows
// (observation fields, then cameras, then commands).
class SpecBagReader::MessagePass {
 public:
  MessagePass(const RobotSpec& spec, const BagTopics& topics, SpecBagReport& report, Recording& rec,
              bool first_bag)
      : spec_(spec),
        topics_(topics),
        report_(report),
        rec_(rec),
        first_bag_(first_bag),
        image_row_(static_cast<int>(spec.observation.size())),
        cmd_row_(static_cast<int>(report.fields.size() - rec.cmd_topics.size())) {}

  // The topics to read, in the bag's order.
  std::vector<std::string> Query() const {
    std::vector<std::string> q;
    for (const auto& t : topics_.obs)
      if (!t.empty()) q.push_back(t);
    q.insert(q.end(), topics_.commands.begin(), topics_.commands.end());
    q.insert(q.end(), topics_.images.begin(), topics_.images.end());
    for (const std::string* t : {&topics_.tf, &topics_.tf_static, &topics_.episode, &topics_.goal})
      if (!t->empty()) q.push_back(*t);
    return q;
  }

  void Read(const rosbag::MessageInstance& m) {
    const std::string& topic = m.getTopic();
    const ros::Time receipt = m.getTime();
    if (topic == topics_.goal) {
      Goal(m, receipt);
      if (topic != topics_.episode) return;
    }
    if (topic == topics_.episode) {
      Episode(m, receipt);
      if (!IsObservationOrCommand(topic)) return;
    }
    if (topic == topics_.tf || topic == topics_.tf_static) {
      Tf(m, receipt, topic == topics_.tf_static);
      return;
    }
    for (size_t c = 0; c < topics_.images.size(); ++c)
      if (topic == topics_.images[c]) Image(c, m, receipt);
    for (size_t c = 0; c < topics_.commands.size(); ++c)
      if (topic == topics_.commands[c]) Command(c, m, receipt);
    for (size_t k = 0; k < topics_.obs.size(); ++k)
      if (!topics_.obs[k].empty() && topic == topics_.obs[k]) Observation(k, m, receipt);
  }

 private:
  bool IsObservationOrCommand(const std::string& topic) const {
    const auto& c = topics_.commands;
    const auto& o = topics_.obs;
    return std::find(c.begin(), c.end(), topic) != c.end() ||
           std::find(o.begin(), o.end(), topic) != o.end();
  }

  // A vector goal, for the episodes' goal rows; a goal that does not decode is skipped.
  void Goal(const rosbag::MessageInstance& m, const ros::Time& receipt) {
    std::vector<double> goal;
    std::string why;
    ros::Time stamp = receipt;
    Dispatch(spec_.goal.type, m, [&](const auto& msg) {
      using M = std::decay_t<decltype(msg)>;
      if constexpr (std::is_same_v<M, geometry_msgs::PoseStamped> ||
                    std::is_same_v<M, std_msgs::Float64MultiArray>) {
        const ros::Time h = HeaderStamp(msg);
        if (!h.isZero()) stamp = h;
        if (!DecodeGoal(spec_, msg, &goal, &why)) goal.clear();
      }
    });
    if (!goal.empty()) rec_.goals.push_back({stamp, std::vector<float>(goal.begin(), goal.end())});
  }

  // An episode boundary. `rosbag record --split --repeat-latched` opens each file with the
  // latched messages again: the previous file's last episode message, repeated, starts no
  // episode.
  void Episode(const rosbag::MessageInstance& m, const ros::Time& receipt) {
    ros::Time stamp = receipt;
    Dispatch(topics_.episode_type, m, [&](const auto& msg) {
      const ros::Time h = HeaderStamp(msg);
      if (!h.isZero()) stamp = h;
    });
    std::vector<uint8_t> bytes = MessageBytes(m);
    const bool repeat = first_episode_message_ && !first_bag_ && bytes == rec_.last_episode_message;
    first_episode_message_ = false;
    rec_.last_episode_message = std::move(bytes);
    if (repeat)
      ++report_.latched_repeats;
    else
      rec_.boundaries.push_back(stamp);
  }

  // tf2 fields read /tf (and /tf_static) into the buffer, sampled after each message (a
  // static transform can complete a chain too).
  void Tf(const rosbag::MessageInstance& m, const ros::Time& receipt, bool is_static) {
    auto tfm = m.instantiate<tf2_msgs::TFMessage>();
    if (!tfm) return;
    for (const auto& t : tfm->transforms) {
      try {
        rec_.tf_buffer.setTransform(t, "bag", is_static);
      } catch (const std::exception&) {
      }
    }
    const SpecLayout& layout = rec_.layout;
    for (size_t k = 0; k < layout.topics.size(); ++k) {
      if (layout.topics[k].type != kTf2Type) continue;
      TopicSample s;
      std::string why;
      bool nonfinite = false;
      const bool ok =
          DecodeTf(spec_, layout.topics[k], rec_.tf_buffer, receipt, &s, &why, &nonfinite);
      if (!ok && !nonfinite) continue;  // the frames are not connected (yet)
      auto& history = rec_.histories[k];
      if (ok && !history.samples().empty() && s.stamp == history.samples().back().stamp) continue;
      const bool in_order = ok ? history.Add(s) : true;
      Account(layout.topics[k].fields, s, ok, nonfinite, why, in_order);
    }
  }

  void Image(size_t c, const rosbag::MessageInstance& m, const ros::Time& receipt) {
    TopicSample s;
    std::string why;
    bool ok = false;
    const SpecImage& im = spec_.images[c];
    if (im.type == kImageType) {
      if (auto msg = m.instantiate<sensor_msgs::Image>())
        ok = DecodeImageSample(im, *msg, receipt, &s, &why);
    } else if (auto msg = m.instantiate<sensor_msgs::CompressedImage>()) {
      ok = DecodeImageSample(im, *msg, receipt, &s, &why);
    }
    s.receipt = receipt;
    TopicSample head;  // the stamps, for the statistics (the pixels move into the history)
    head.stamp = s.stamp;
    head.receipt = s.receipt;
    const bool in_order = ok ? rec_.images[c].Add(std::move(s)) : true;
    Account({image_row_ + static_cast<int>(c)}, head, ok, false, why, in_order);
  }

  void Command(size_t c, const rosbag::MessageInstance& m, const ros::Time& receipt) {
    TopicSample s;
    std::string why;
    bool ok = false, nonfinite = false;
    const auto& cmd = rec_.cmd_topics[c];
    Dispatch(cmd.type, m, [&](const auto& msg) {
      ok = DecodeAction(spec_, msg, receipt, &s, &why, &nonfinite, cmd.topic);
    });
    s.receipt = receipt;
    const bool in_order = ok ? rec_.commands[c].Add(s) : true;
    Account({cmd_row_ + static_cast<int>(c)}, s, ok, nonfinite, why, in_order);
  }

  void Observation(size_t k, const rosbag::MessageInstance& m, const ros::Time& receipt) {
    const auto& topic = rec_.layout.topics[k];
    TopicSample s;
    std::string why;
    bool ok = false, nonfinite = false;
    Dispatch(topic.type, m, [&](const auto& msg) {
      ok = DecodeObservation(spec_, topic, msg, receipt, &s, &why, &nonfinite);
    });
    s.receipt = receipt;
    const bool in_order = ok ? rec_.histories[k].Add(s) : true;
    Account(topic.fields, s, ok, nonfinite, why, in_order);
  }

  // Per-field statistics of one decoded (or rejected) message.
  void Account(const std::vector<int>& rows, const TopicSample& s, bool ok, bool nonfinite,
               const std::string& why, bool in_order) {
    for (int idx : rows) {
      SpecFieldReport& r = report_.fields[idx];
      if (!ok) {
        (nonfinite ? r.nonfinite : r.image ? r.bad_images : r.unreadable)++;
        if (r.first_problem.empty()) r.first_problem = why + " at " + Stamp(s.receipt);
        continue;
      }
      if (!in_order) {
        ++r.out_of_order;
        if (r.first_problem.empty())
          r.first_problem = "stamp " + Stamp(s.stamp) +
                            " before the previous message's (received " + Stamp(s.receipt) + ")";
        continue;
      }
      if (r.messages > 0) {
        const double gap = s.stamp.toSec() - r.last;
        if (gap > spec_.stale_after) ++r.gaps;
        r.max_gap_s = std::max(r.max_gap_s, gap);
      } else {
        r.first = s.stamp.toSec();
      }
      r.last = s.stamp.toSec();
      ++r.messages;
      if (!s.stamp.isZero() && s.receipt - s.stamp > ros::Duration(spec_.stale_after)) ++r.late;
    }
  }

  const RobotSpec& spec_;
  const BagTopics& topics_;
  SpecBagReport& report_;
  Recording& rec_;
  const bool first_bag_;
  const int image_row_, cmd_row_;  // the report's first camera and first command rows
  bool first_episode_message_ = true;
};

void SpecBagReader::ReadMessages(const std::string& path, bool first_bag, Recording* rec) {
  rosbag::Bag bag;
  try {
    bag.open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw BagError(path + ": cannot open as a rosbag: " + e.what());
  }
  std::map<std::string, std::string> bag_topics;  // topic -> type
  {
    rosbag::View all(bag);
    for (const auto* c : all.getConnections()) bag_topics[c->topic] = c->datatype;
  }
  const BagTopics topics = ResolveTopics(path, bag_topics, *rec);
  const std::vector<SpecFieldReport> before = report_.fields;
  MessagePass pass(spec_, topics, report_, *rec, first_bag);
  try {
    rosbag::View view(bag, rosbag::TopicQuery(pass.Query()));
    for (const rosbag::MessageInstance& m : view) pass.Read(m);
  } catch (const rosbag::BagException& e) {
    throw BagError(path + ": truncated or corrupt: " + e.what());
  } catch (const ros::Exception& e) {
    throw BagError(path + ": a message does not deserialize: " + e.what());
  }
  AddFieldProblems(path, before);
}

}  // namespace msspr::ros_bridge
