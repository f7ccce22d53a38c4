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
#include "msspr_robot_interface/command_alignment.h"
#include "msspr_robot_interface/robot_fields.h"
#include "msspr_robot_interface/topic_names.h"

namespace msspr::ros_bridge {
namespace {

// The bag topics of `names` (a spec's topics), resolved under `ns` (topic_names.h).
// Throws BagError naming the bag, what of the spec reads the topics found under no
// namespace (`whos`), the spec and the bag's topics when one is missing.
std::vector<std::string> ResolveInBag(const std::vector<std::string>& names,
                                      const std::vector<std::string>& whos,
                                      const std::map<std::string, std::string>& bag_topics,
                                      const std::string& ns, const std::string& path,
                                      const std::string& spec_source) {
  std::set<std::string> topics;
  for (const auto& [t, type] : bag_topics) topics.insert(t);
  try {
    return ResolveSpecTopics(names, topics, ns).topics;
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

std::string Stamp(const ros::Time& t) {
  std::ostringstream s;
  s.precision(3);
  s << std::fixed << t.toSec();
  return s.str();
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

// The decoded messages of a recording: every bag of the reader, in time order,
// as `rosbag play a.bag b.bag` plays them.
struct SpecBagReader::Recording {
  explicit Recording(const RobotSpec& spec)
      : layout(spec),
        cmd_topics(spec.CommandTopics()),
        histories(layout.topics.size()),
        commands(cmd_topics.size()),
        images(spec.images.size()),
        tf_buffer(ros::Duration(60.0)) {}
  SpecLayout layout;
  std::vector<RobotSpec::CommandTopic> cmd_topics;
  std::vector<TopicHistory> histories, commands, images;  // per observation topic, command, camera
  std::vector<ros::Time> boundaries;                      // episode-topic messages
  std::vector<uint8_t> last_episode_message;              // its bytes (latched repeats)
  tf2::BufferCore tf_buffer;
  struct Bag {
    std::string path;
    ros::Time begin, end;  // the bag's first and last message
  };
  std::vector<Bag> bags;  // in time order
  std::string label;      // names the recording in episode problems
};

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
    for (auto& r : report_.fields)
      r.rate_hz = r.messages > 1 && r.last > r.first ? (r.messages - 1) / (r.last - r.first) : 0.0;
    EmitEpisodes(&rec, &next_id, fn);
  }
}

void SpecBagReader::ReadMessages(const std::string& path, bool first_bag, Recording* rec) {
  const RobotSpec& spec = spec_;
  const SpecLayout& layout = rec->layout;
  const auto& cmd_topics = rec->cmd_topics;
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
  const std::vector<std::string> resolved =
      ResolveInBag(names, whos, bag_topics, ns_, path, spec.source);
  for (size_t i = 0; i < names.size(); ++i) {
    const std::string& t = resolved[i];
    if (!types[i].empty() && bag_topics[t] != types[i])
      throw BagError(path + ": topic " + t + " (" + whos[i] + " of " + spec.source + ") holds " +
                     bag_topics[t] + ", the spec reads " + types[i]);
  }
  size_t next_resolved = 0;  // the resolved topics, taken in the order they were wanted
  auto resolve = [&]() { return resolved[next_resolved++]; };
  // tf2 fields read /tf (and /tf_static when the bag has it) into a tf2 buffer.
  std::string tf_topic, tf_static_topic;
  std::vector<std::string> obs_topics;
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
      (std::string(t) == "/tf" ? tf_topic : tf_static_topic) = t;
    }
    obs_topics.push_back("");  // sampled from the buffer after each /tf message
  }
  std::vector<std::string> cmd_bag_topics;
  for (size_t c = 0; c < cmd_topics.size(); ++c) cmd_bag_topics.push_back(resolve());
  std::vector<std::string> image_bag_topics;
  for (size_t c = 0; c < spec.images.size(); ++c) image_bag_topics.push_back(resolve());
  std::string episode_topic, episode_type;
  if (spec.episodes.split_by == "topic") {
    episode_topic = resolve();
    episode_type = bag_topics[episode_topic];
  }

  const std::vector<SpecFieldReport> before = report_.fields;
  std::vector<TopicHistory>& histories = rec->histories;
  std::vector<TopicHistory>& commands = rec->commands;
  std::vector<TopicHistory>& images = rec->images;
  const int image_index = static_cast<int>(spec.observation.size());  // the first camera row
  const ros::Duration stale(spec.stale_after);
  const int cmd_index =
      static_cast<int>(report_.fields.size() - cmd_topics.size());  // the first command row
  tf2::BufferCore& tf_buffer = rec->tf_buffer;
  bool first_episode_message = true;
  // Per-field statistics of one decoded (or rejected) message.
  auto account = [&](const std::vector<int>& report_fields, const TopicSample& s, bool ok,
                     bool nonfinite, const std::string& why, bool in_order) {
    for (int idx : report_fields) {
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
        if (gap > spec.stale_after) ++r.gaps;
        r.max_gap_s = std::max(r.max_gap_s, gap);
      } else {
        r.first = s.stamp.toSec();
      }
      r.last = s.stamp.toSec();
      ++r.messages;
      if (!s.stamp.isZero() && s.receipt - s.stamp > stale) ++r.late;
    }
  };
  std::vector<std::string> query;
  for (const auto& t : obs_topics)
    if (!t.empty()) query.push_back(t);
  for (const auto& t : cmd_bag_topics) query.push_back(t);
  for (const auto& t : image_bag_topics) query.push_back(t);
  if (!tf_topic.empty()) query.push_back(tf_topic);
  if (!tf_static_topic.empty()) query.push_back(tf_static_topic);
  if (!episode_topic.empty()) query.push_back(episode_topic);
  try {
    rosbag::View view(bag, rosbag::TopicQuery(query));
    for (const rosbag::MessageInstance& m : view) {
      const std::string& topic = m.getTopic();
      const ros::Time receipt = m.getTime();
      if (topic == episode_topic) {
        ros::Time stamp = receipt;
        Dispatch(episode_type, m, [&](const auto& msg) {
          const ros::Time h = HeaderStamp(msg);
          if (!h.isZero()) stamp = h;
        });
        // `rosbag record --split --repeat-latched` opens each file with the latched
        // messages again: the previous file's last episode message, repeated, starts
        // no episode.
        std::vector<uint8_t> bytes = MessageBytes(m);
        const bool repeat =
            first_episode_message && !first_bag && bytes == rec->last_episode_message;
        first_episode_message = false;
        rec->last_episode_message = std::move(bytes);
        if (repeat)
          ++report_.latched_repeats;
        else
          rec->boundaries.push_back(stamp);
        if (std::find(cmd_bag_topics.begin(), cmd_bag_topics.end(), topic) ==
                cmd_bag_topics.end() &&
            std::find(obs_topics.begin(), obs_topics.end(), topic) == obs_topics.end())
          continue;
      }
      if (topic == tf_topic || topic == tf_static_topic) {
        auto tfm = m.instantiate<tf2_msgs::TFMessage>();
        if (!tfm) continue;
        const bool is_static = topic == tf_static_topic;
        for (const auto& t : tfm->transforms) {
          try {
            tf_buffer.setTransform(t, "bag", is_static);
          } catch (const std::exception&) {
          }
        }
        // (A static transform can complete a chain too: sample after either.)
        for (size_t k = 0; k < layout.topics.size(); ++k) {
          if (layout.topics[k].type != kTf2Type) continue;
          TopicSample s;
          std::string why;
          bool nonfinite = false;
          const bool ok =
              DecodeTf(spec, layout.topics[k], tf_buffer, receipt, &s, &why, &nonfinite);
          if (!ok && !nonfinite) continue;  // the frames are not connected (yet)
          if (ok && !histories[k].samples().empty() &&
              s.stamp == histories[k].samples().back().stamp)
            continue;
          const bool in_order = ok ? histories[k].Add(s) : true;
          account(layout.topics[k].fields, s, ok, nonfinite, why, in_order);
        }
        continue;
      }
      for (size_t c = 0; c < image_bag_topics.size(); ++c) {
        if (topic != image_bag_topics[c]) continue;
        TopicSample s;
        std::string why;
        bool ok = false;
        const SpecImage& im = spec.images[c];
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
        const bool in_order = ok ? images[c].Add(std::move(s)) : true;
        account({image_index + static_cast<int>(c)}, head, ok, false, why, in_order);
      }
      for (size_t c = 0; c < cmd_bag_topics.size(); ++c) {
        if (topic != cmd_bag_topics[c]) continue;
        TopicSample s;
        std::string why;
        bool ok = false, nonfinite = false;
        Dispatch(cmd_topics[c].type, m, [&](const auto& msg) {
          ok = DecodeAction(spec, msg, receipt, &s, &why, &nonfinite, cmd_topics[c].topic);
        });
        s.receipt = receipt;
        const bool in_order = ok ? commands[c].Add(s) : true;
        account({cmd_index + static_cast<int>(c)}, s, ok, nonfinite, why, in_order);
      }
      for (size_t k = 0; k < obs_topics.size(); ++k) {
        if (obs_topics[k].empty() || topic != obs_topics[k]) continue;
        TopicSample s;
        std::string why;
        bool ok = false, nonfinite = false;
        Dispatch(layout.topics[k].type, m, [&](const auto& msg) {
          ok = DecodeObservation(spec, layout.topics[k], msg, receipt, &s, &why, &nonfinite);
        });
        s.receipt = receipt;
        const bool in_order = ok ? histories[k].Add(s) : true;
        account(layout.topics[k].fields, s, ok, nonfinite, why, in_order);
      }
    }
  } catch (const rosbag::BagException& e) {
    throw BagError(path + ": truncated or corrupt: " + e.what());
  } catch (const ros::Exception& e) {
    throw BagError(path + ": a message does not deserialize: " + e.what());
  }

  // Problems per field (this bag's), named by bag, topic and field.
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

std::vector<std::pair<ros::Time, ros::Time>> SpecBagReader::EpisodeSpans(Recording* rec) {
  const RobotSpec& spec = spec_;
  const ros::Duration tol(spec.tolerance);
  const auto& primary = rec->histories[0].samples();
  std::vector<std::pair<ros::Time, ros::Time>> episodes;  // [begin, last tick allowed]
  if (spec.episodes.split_by == "bag") {
    for (const auto& bag : rec->bags) {
      auto first =
          std::lower_bound(primary.begin(), primary.end(), bag.begin,
                           [](const TopicSample& s, const ros::Time& x) { return s.stamp < x; });
      auto end =
          std::upper_bound(primary.begin(), primary.end(), bag.end,
                           [](const ros::Time& x, const TopicSample& s) { return x < s.stamp; });
      if (first < end) episodes.emplace_back(first->stamp, std::prev(end)->stamp + tol);
    }
  } else if (spec.episodes.split_by == "gap") {
    ros::Time begin = primary.front().stamp;
    for (size_t i = 1; i < primary.size(); ++i) {
      if ((primary[i].stamp - primary[i - 1].stamp).toSec() > spec.episodes.gap) {
        episodes.emplace_back(begin, primary[i - 1].stamp + tol);
        begin = primary[i].stamp;
      }
    }
    episodes.emplace_back(begin, primary.back().stamp + tol);
  } else {
    auto& boundaries = rec->boundaries;
    std::sort(boundaries.begin(), boundaries.end());
    boundaries.erase(std::unique(boundaries.begin(), boundaries.end()), boundaries.end());
    if (boundaries.empty())
      throw BagError(rec->label + ": no message on " + spec.episodes.topic +
                     " (the episode topic of " + spec.source + ")");
    const uint64_t before = static_cast<uint64_t>(
        std::lower_bound(primary.begin(), primary.end(), Before(boundaries.front(), tol),
                         [](const TopicSample& s, const ros::Time& x) { return s.stamp < x; }) -
        primary.begin());
    if (before)
      report_.usage.push_back(rec->label + ": " + std::to_string(before) + " messages on " +
                              rec->layout.topics[0].name + " before the first message on " +
                              spec.episodes.topic + " (no episode yet): not used");
    const ros::Time inf = ros::TIME_MAX;
    for (size_t i = 0; i < boundaries.size(); ++i) {
      const ros::Time next = i + 1 < boundaries.size() ? boundaries[i + 1] : inf;
      // The newest primary stamp before the next boundary ends it.
      auto it =
          std::lower_bound(primary.begin(), primary.end(), Before(next, tol),
                           [](const TopicSample& s, const ros::Time& x) { return s.stamp < x; });
      if (it == primary.begin()) continue;
      const ros::Time last = std::prev(it)->stamp;
      if (last < Before(boundaries[i], tol)) continue;  // no data in this episode
      episodes.emplace_back(boundaries[i], last + tol);
    }
  }
  return episodes;
}

namespace {

// Per tick of an episode, the sample of one command topic: for a topic without
// stamps, the command AlignCommands counted for that tick (or, when none arrived
// for it, the one before while it is fresh); for a stamped topic, the newest
// command stamped before the next tick (NewestCommand).
class CommandTrack {
 public:
  CommandTrack(const RobotSpec& spec, const RobotSpec::CommandTopic& topic,
               const TopicHistory& history, const ros::Time& begin, int64_t ticks)
      : spec_(spec), topic_(topic), history_(history), begin_(begin) {
    if (topic.stamp != "receipt") return;
    aligned_ = true;
    const auto& s = history.samples();
    const double period = 1.0 / spec.control_rate;
    // The commands that may belong to the episode's ticks (AlignCommands picks its own window).
    auto lo =
        std::lower_bound(s.begin(), s.end(), Before(begin, ros::Duration(period)),
                         [](const TopicSample& x, const ros::Time& t) { return x.stamp < t; });
    const ros::Time end = begin + ros::Duration(period * static_cast<double>(ticks + 1));
    for (auto it = lo; it != s.end() && it->stamp < end; ++it) {
      samples_.push_back(&*it);
      receipts_.push_back((it->stamp - begin).toSec());
    }
    alignment_ = AlignCommands(receipts_, 0.0, period, ticks);
  }

  // The command of tick k (at time t), or why there is none.
  std::string At(int64_t k, const ros::Time& t, const TopicSample** out) const {
    if (!aligned_) return NewestCommand(spec_, topic_.topic, history_, t, begin_, out);
    for (int64_t j = k; j >= 0; --j) {
      const int64_t c = alignment_.command_of_tick[static_cast<size_t>(j)];
      if (c < 0) continue;
      const TopicSample* s = samples_[static_cast<size_t>(c)];
      if (j < k && s->stamp < Before(t, ros::Duration(spec_.stale_after)))
        return "topic " + topic_.topic + ": no command for this tick, the last is " +
               std::to_string((t - s->stamp).toSec()) + " s old (stale_after " +
               std::to_string(spec_.stale_after) + " s)";
      *out = s;
      return "";
    }
    return "topic " + topic_.topic + ": no command yet";
  }
  bool aligned() const { return aligned_; }
  const CommandAlignment& alignment() const { return alignment_; }

 private:
  const RobotSpec& spec_;
  const RobotSpec::CommandTopic& topic_;
  const TopicHistory& history_;
  ros::Time begin_;
  bool aligned_ = false;
  std::vector<const TopicSample*> samples_;
  std::vector<double> receipts_;
  CommandAlignment alignment_;
};

}  // namespace

void SpecBagReader::EmitEpisodes(Recording* rec, uint64_t* next_id,
                                 const std::function<void(BagEpisode&&)>& fn) {
  const RobotSpec& spec = spec_;
  const SpecLayout& layout = rec->layout;
  const auto& cmd_topics = rec->cmd_topics;
  const auto& histories = rec->histories;
  const auto& primary = histories[0].samples();
  if (primary.empty()) {
    report_.problems.push_back(rec->label + ": topic " + layout.topics[0].name +
                               ": no usable message");
    return;
  }
  const std::vector<std::pair<ros::Time, ros::Time>> episodes = EpisodeSpans(rec);
  const int image_index = static_cast<int>(spec.observation.size());  // the first camera row
  const int cmd_index = static_cast<int>(report_.fields.size() - cmd_topics.size());
  // Per bag (by the time of the tick): ticks, complete ones, and why the others are not.
  struct Usage {
    uint64_t ticks = 0, complete = 0, no_obs = 0, no_cmd = 0, no_image = 0;
  };
  std::vector<Usage> usage(rec->bags.size());
  auto bag_of = [&](const ros::Time& t) {
    size_t b = 0;
    while (b + 1 < rec->bags.size() && rec->bags[b + 1].begin <= t) ++b;
    return b;
  };

  // This recording's commands without stamps, and the ambiguous ones among them.
  std::vector<uint64_t> aligned(cmd_topics.size(), 0), ambiguous(cmd_topics.size(), 0);
  const double dt = 1.0 / spec.control_rate;
  const int obs_dim = spec.obs_dim(), act_dim = spec.action_dim();
  std::vector<float> obs, act(static_cast<size_t>(act_dim), 0.f);
  for (const auto& [begin, last] : episodes) {
    BagEpisode ep;
    ep.meta.episode_id = (*next_id)++;
    ep.meta.env = spec.name;
    ep.meta.split = "train";
    ep.has_meta = true;
    ep.obs_dim = obs_dim;
    ep.act_dim = act_dim;
    ep.t0 = begin.toSec();
    ep.step_period = dt;
    const int64_t n = static_cast<int64_t>(std::floor((last - begin).toSec() / dt + 1e-9)) + 1;
    if (n <= 0 || n > static_cast<int64_t>(kMaxEpisodeSteps)) continue;
    ep.num_steps = static_cast<int>(n);
    ep.observations.assign(static_cast<size_t>(n) * obs_dim, 0.f);
    ep.actions.assign(static_cast<size_t>(n) * act_dim, 0.f);
    ep.has_obs.assign(n, 0);
    ep.has_action.assign(n, 0);
    ep.has_image.assign(n, 0);
    // The camera's images (one camera: the network's input).
    const SpecImage* camera = spec.images.empty() ? nullptr : &spec.images[0];
    const size_t image_bytes = camera ? static_cast<size_t>(camera->size) * camera->size * 3 : 0;
    if (camera) {
      ep.image_size = camera->size;
      ep.images.assign(static_cast<size_t>(n) * image_bytes, 0);
    }
    std::vector<CommandTrack> tracks;
    tracks.reserve(cmd_topics.size());
    for (size_t c = 0; c < cmd_topics.size(); ++c) {
      tracks.emplace_back(spec, cmd_topics[c], rec->commands[c], begin, n);
      if (!tracks.back().aligned()) continue;
      const CommandAlignment& a = tracks.back().alignment();
      SpecFieldReport& r = report_.fields[cmd_index + c];
      // (The phase: commands-weighted over the episodes.)
      const uint64_t before = r.aligned_commands;
      r.aligned_commands += a.commands;
      if (r.aligned_commands)
        r.phase_s =
            (r.phase_s * static_cast<double>(before) + a.phase * static_cast<double>(a.commands)) /
            static_cast<double>(r.aligned_commands);
      r.ambiguous += a.ambiguous;
      ambiguous[c] += a.ambiguous;
      aligned[c] += a.commands;
      r.shifted += a.shifted;
      r.dropped += a.dropped;
      r.spread_s = std::max(r.spread_s, a.spread);
    }
    uint64_t missing_obs = 0, missing_act = 0, missing_img = 0;
    std::string first_obs_why, first_act_why, first_img_why;
    for (int64_t k = 0; k < n; ++k) {
      const ros::Time t = begin + ros::Duration(dt * static_cast<double>(k));
      Usage& u = usage[bag_of(t)];
      ++u.ticks;
      std::vector<int> stale_topics;
      const std::string why =
          SampleObservation(spec, layout, histories, t, begin, &obs, &stale_topics);
      for (size_t j = 0; j < layout.topics.size(); ++j) {
        const bool bad = std::find(stale_topics.begin(), stale_topics.end(), static_cast<int>(j)) !=
                         stale_topics.end();
        for (int idx : layout.topics[j].fields) {
          ++report_.fields[idx].ticks;
          (bad ? report_.fields[idx].stale_ticks : report_.fields[idx].covered_ticks)++;
        }
      }
      if (why.empty()) {
        std::copy(obs.begin(), obs.end(), ep.observations.begin() + k * obs_dim);
        ep.has_obs[k] = 1;
      } else {
        ++u.no_obs;
        if (missing_obs++ == 0)
          first_obs_why = why + " at tick " + std::to_string(k) + " (" + Stamp(t) + ")";
      }
      std::string awhy;
      for (size_t c = 0; c < cmd_topics.size(); ++c) {
        const TopicSample* s = nullptr;
        const std::string cwhy = tracks[c].At(k, t, &s);
        SpecFieldReport& r = report_.fields[cmd_index + c];
        ++r.ticks;
        (cwhy.empty() ? r.covered_ticks : r.stale_ticks)++;
        if (cwhy.empty())
          PutCommand(spec, cmd_topics[c], *s, &act);
        else if (awhy.empty())
          awhy = cwhy;
      }
      if (awhy.empty()) {
        std::copy(act.begin(), act.end(), ep.actions.begin() + k * act_dim);
        ep.has_action[k] = 1;
      } else {
        ++u.no_cmd;
        if (missing_act++ == 0)
          first_act_why = awhy + " at tick " + std::to_string(k) + " (" + Stamp(t) + ")";
      }
      bool image_ok = true;
      if (camera) {
        const TopicSample* img = nullptr;
        const std::string iwhy = SampleImage(spec, *camera, rec->images[0], t, begin, &img);
        SpecFieldReport& ir = report_.fields[image_index];
        ++ir.ticks;
        if (iwhy.empty()) {
          std::copy(img->pixels.begin(), img->pixels.end(), ep.images.begin() + k * image_bytes);
          ep.has_image[k] = 1;
          ++ir.covered_ticks;
        } else {
          image_ok = false;
          ++ir.stale_ticks;
          ++u.no_image;
          if (missing_img++ == 0)
            first_img_why = iwhy + " at tick " + std::to_string(k) + " (" + Stamp(t) + ")";
        }
      }
      if (ep.has_obs[k] && ep.has_action[k] && image_ok) {
        ++report_.complete_ticks;
        ++u.complete;
      }
    }
    report_.ticks += static_cast<uint64_t>(n);
    ++report_.episodes;
    const std::string who = rec->label + ": episode " + std::to_string(ep.meta.episode_id) +
                            " (from " + Stamp(begin) + "): ";
    if (missing_obs)
      ep.problems.push_back(who + std::to_string(missing_obs) +
                            " ticks without a fresh observation (first: " + first_obs_why + ")");
    if (missing_act)
      ep.problems.push_back(who + std::to_string(missing_act) +
                            " ticks without a fresh command (first: " + first_act_why + ")");
    if (missing_img)
      ep.problems.push_back(who + std::to_string(missing_img) +
                            " ticks without a fresh image (first: " + first_img_why + ")");
    for (const auto& p : ep.problems) report_.problems.push_back(p);
    fn(std::move(ep));
  }
  // Commands without stamps counted for another tick than the one they arrived in.
  for (size_t c = 0; c < cmd_topics.size(); ++c) {
    const SpecFieldReport& r = report_.fields[cmd_index + c];
    if (ambiguous[c])
      report_.problems.push_back(
          rec->label + ": topic " + r.topic + " (" + r.name + "): " + std::to_string(ambiguous[c]) +
          " of " + std::to_string(aligned[c]) +
          " commands arrived more than a quarter period off the others' phase: their ticks are "
          "ambiguous");
  }
  for (size_t b = 0; b < rec->bags.size(); ++b) {
    const Usage& u = usage[b];
    report_.usage.push_back(
        rec->bags[b].path + ": " + std::to_string(u.ticks) + " ticks in episodes, " +
        std::to_string(u.complete) + " complete; not used: " + std::to_string(u.no_obs) +
        " without a fresh observation, " + std::to_string(u.no_cmd) + " without a command, " +
        std::to_string(u.no_image) + " without an image");
  }
}

}  // namespace msspr::ros_bridge
