#include "spec_bag.h"

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include "robot_fields.h"

namespace msspr::ros_bridge {
namespace {

// The bag topic a spec topic names: "/odom" or "odom" as given, else the one
// bag topic ending in "/odom" (a recording made in a namespace). "" when none.
std::string MatchTopic(const std::string& spec_topic, const std::map<std::string, std::string>& bag_topics,
                       const std::string& path) {
  const std::string abs = spec_topic[0] == '/' ? spec_topic : "/" + spec_topic;
  if (bag_topics.count(abs)) return abs;
  if (spec_topic[0] == '/') return "";
  std::string found;
  for (const auto& [t, type] : bag_topics) {
    if (t.size() > abs.size() && t.compare(t.size() - abs.size(), abs.size(), abs) == 0) {
      if (!found.empty())
        throw BagError(path + ": topic " + spec_topic + " is ambiguous: both " + found + " and " + t + " end in it");
      found = t;
    }
  }
  return found;
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

SpecBagReader::SpecBagReader(RobotSpec spec, std::vector<std::string> bags)
    : spec_(std::move(spec)), bags_(std::move(bags)) {}

uint64_t SpecBagReader::CountObservations() const {
  uint64_t n = 0;
  for (const auto& path : bags_) {
    try {
      rosbag::Bag bag(path, rosbag::bagmode::Read);
      std::map<std::string, std::string> topics;
      rosbag::View all(bag);
      for (const auto* c : all.getConnections()) topics[c->topic] = c->datatype;
      const std::string t = MatchTopic(spec_.observation[0].topic, topics, path);
      if (!t.empty()) n += rosbag::View(bag, rosbag::TopicQuery(t)).size();
    } catch (const rosbag::BagException& e) {
      throw BagError(path + ": cannot open as a rosbag: " + e.what());
    }
  }
  return n;
}

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
    report_.fields.push_back(cmd);
  }
  uint64_t next_id = 0;
  for (const auto& path : bags_) ReadBag(path, &next_id, fn);
}

void SpecBagReader::ReadBag(const std::string& path, uint64_t* next_id,
                            const std::function<void(BagEpisode&&)>& fn) {
  const RobotSpec& spec = spec_;
  const SpecLayout layout(spec);
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
  // Every topic of the spec must be in the bag with the spec's type.
  auto resolve = [&](const std::string& topic, const std::string& type, const std::string& who) {
    const std::string t = MatchTopic(topic, bag_topics, path);
    if (t.empty()) {
      std::string have;
      for (const auto& [name, ty] : bag_topics) have += (have.empty() ? "" : ", ") + name;
      throw BagError(path + ": no topic " + topic + " (" + who + " of " + spec.source + "); the bag has " +
                     (have.empty() ? "no topics" : have));
    }
    if (bag_topics[t] != type)
      throw BagError(path + ": topic " + t + " (" + who + " of " + spec.source + ") holds " + bag_topics[t] +
                     ", the spec reads " + type);
    return t;
  };
  // tf2 fields read /tf (and /tf_static when the bag has it) into a tf2 buffer.
  std::string tf_topic, tf_static_topic;
  std::vector<std::string> obs_topics;
  for (const auto& topic : layout.topics) {
    const SpecField& f = spec.observation[topic.fields[0]];
    if (topic.type == kTf2Type) {
      tf_topic = resolve("/tf", "tf2_msgs/TFMessage", "field '" + f.name + "'");
      if (bag_topics.count("/tf_static")) tf_static_topic = resolve("/tf_static", "tf2_msgs/TFMessage", "tf2");
      obs_topics.push_back("");  // sampled from the buffer after each /tf message
      continue;
    }
    obs_topics.push_back(resolve(topic.name, topic.type, "field '" + f.name + "'"));
  }
  const std::vector<RobotSpec::CommandTopic> cmd_topics = spec.CommandTopics();
  std::vector<std::string> cmd_bag_topics;
  for (const auto& c : cmd_topics)
    cmd_bag_topics.push_back(resolve(c.topic, c.type, cmd_topics.size() == 1 ? "the action" : "the action on " + c.topic));
  std::vector<std::string> image_bag_topics;
  for (const auto& im : spec.images) image_bag_topics.push_back(resolve(im.topic, im.type, "image '" + im.name + "'"));
  std::string episode_topic, episode_type;
  if (spec.episodes.split_by == "topic") {
    const std::string t = MatchTopic(spec.episodes.topic, bag_topics, path);
    if (t.empty()) throw BagError(path + ": no topic " + spec.episodes.topic + " (episodes of " + spec.source + ")");
    episode_topic = t;
    episode_type = bag_topics[t];
  }

  const std::vector<SpecFieldReport> before = report_.fields;
  std::vector<TopicHistory> histories(layout.topics.size());
  std::vector<TopicHistory> commands(cmd_topics.size());
  std::vector<TopicHistory> images(spec.images.size());
  const int image_index = static_cast<int>(spec.observation.size());  // the first camera row
  std::vector<ros::Time> boundaries;
  const ros::Duration stale(spec.stale_after), tol(spec.tolerance);
  const int cmd_index = static_cast<int>(report_.fields.size() - cmd_topics.size());  // the first command row
  tf2::BufferCore tf_buffer(ros::Duration(60.0));
  // Per-field statistics of one decoded (or rejected) message.
  auto account = [&](const std::vector<int>& report_fields, const TopicSample& s, bool ok, bool nonfinite,
                     const std::string& why, bool in_order) {
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
          r.first_problem = "stamp " + Stamp(s.stamp) + " before the previous message's (received " +
                            Stamp(s.receipt) + ")";
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
        boundaries.push_back(stamp);
        if (std::find(cmd_bag_topics.begin(), cmd_bag_topics.end(), topic) == cmd_bag_topics.end() &&
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
          const bool ok = DecodeTf(spec, layout.topics[k], tf_buffer, receipt, &s, &why, &nonfinite);
          if (!ok && !nonfinite) continue;  // the frames are not connected (yet)
          if (ok && !histories[k].samples().empty() && s.stamp == histories[k].samples().back().stamp) continue;
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
          if (auto msg = m.instantiate<sensor_msgs::Image>()) ok = DecodeImageSample(im, *msg, receipt, &s, &why);
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

  for (auto& r : report_.fields)
    r.rate_hz = r.messages > 1 && r.last > r.first ? (r.messages - 1) / (r.last - r.first) : 0.0;
  // Problems per field (this bag's), named by bag, topic and field.
  for (size_t i = 0; i < report_.fields.size(); ++i) {
    SpecFieldReport r = report_.fields[i];
    r.out_of_order -= before[i].out_of_order;
    r.nonfinite -= before[i].nonfinite;
    r.unreadable -= before[i].unreadable;
    r.bad_images -= before[i].bad_images;
    const std::string who = path + ": topic " + r.topic + (r.image ? " (image '" : " (field '") + r.name + "'): ";
    if (r.out_of_order)
      report_.problems.push_back(who + std::to_string(r.out_of_order) +
                                 " messages stamped before the one received before them, dropped (first: " +
                                 r.first_problem + ")");
    if (r.nonfinite) report_.problems.push_back(who + std::to_string(r.nonfinite) + " messages with NaN or Inf rejected");
    if (r.unreadable)
      report_.problems.push_back(who + std::to_string(r.unreadable) + " messages unreadable (first: " +
                                 r.first_problem + ")");
    if (r.bad_images)
      report_.problems.push_back(who + std::to_string(r.bad_images) + " bad images rejected (first: " +
                                 r.first_problem + ")");
  }

  // Episodes: [begin, end) in stamps of the first observation topic.
  const auto& primary = histories[0].samples();
  if (primary.empty()) {
    report_.problems.push_back(path + ": topic " + layout.topics[0].name + ": no usable message");
    return;
  }
  std::vector<std::pair<ros::Time, ros::Time>> episodes;  // [begin, last tick allowed]
  const ros::Time inf = ros::TIME_MAX;
  if (spec.episodes.split_by == "bag") {
    episodes.emplace_back(primary.front().stamp, primary.back().stamp + tol);
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
    std::sort(boundaries.begin(), boundaries.end());
    boundaries.erase(std::unique(boundaries.begin(), boundaries.end()), boundaries.end());
    if (boundaries.empty())
      throw BagError(path + ": no message on " + episode_topic + " (the episode topic of " + spec.source + ")");
    if (primary.front().stamp < Before(boundaries.front(), tol))
      report_.problems.push_back(path + ": data before the first message on " + episode_topic + " ignored");
    for (size_t i = 0; i < boundaries.size(); ++i) {
      const ros::Time next = i + 1 < boundaries.size() ? boundaries[i + 1] : inf;
      // The newest primary stamp before the next boundary ends it.
      auto it = std::lower_bound(primary.begin(), primary.end(), Before(next, tol),
                                 [](const TopicSample& s, const ros::Time& x) { return s.stamp < x; });
      if (it == primary.begin()) continue;
      const ros::Time last = std::prev(it)->stamp;
      if (last < Before(boundaries[i], tol)) continue;  // no data in this episode
      episodes.emplace_back(boundaries[i], last + tol);
    }
  }

  const double dt = 1.0 / spec.control_rate;
  const int obs_dim = spec.obs_dim(), act_dim = spec.action_dim();
  std::vector<float> obs, act;
  for (const auto& [begin, last] : episodes) {
    BagEpisode ep;
    ep.meta.episode_id = (*next_id)++;
    ep.meta.env = spec.name;
    ep.meta.split = "train";
    ep.has_meta = true;
    ep.obs_dim = obs_dim;
    ep.act_dim = act_dim;
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
    uint64_t missing_obs = 0, missing_act = 0, missing_img = 0;
    std::string first_obs_why, first_act_why, first_img_why;
    for (int64_t k = 0; k < n; ++k) {
      const ros::Time t = begin + ros::Duration(dt * static_cast<double>(k));
      std::vector<int> stale_topics;
      const std::string why = SampleObservation(spec, layout, histories, t, begin, &obs, &stale_topics);
      for (size_t j = 0; j < layout.topics.size(); ++j) {
        const bool bad = std::find(stale_topics.begin(), stale_topics.end(), static_cast<int>(j)) != stale_topics.end();
        for (int idx : layout.topics[j].fields) {
          ++report_.fields[idx].ticks;
          (bad ? report_.fields[idx].stale_ticks : report_.fields[idx].covered_ticks)++;
        }
      }
      if (why.empty()) {
        std::copy(obs.begin(), obs.end(), ep.observations.begin() + k * obs_dim);
        ep.has_obs[k] = 1;
      } else if (missing_obs++ == 0) {
        first_obs_why = why + " at tick " + std::to_string(k) + " (" + Stamp(t) + ")";
      }
      const std::string awhy = SampleCommands(spec, cmd_topics, commands, t, begin, &act);
      for (size_t c = 0; c < cmd_topics.size(); ++c) {
        const TopicSample* newest = nullptr;
        const bool fresh = NewestCommand(spec, cmd_topics[c].topic, commands[c], t, begin, &newest).empty();
        ++report_.fields[cmd_index + c].ticks;
        (fresh ? report_.fields[cmd_index + c].covered_ticks : report_.fields[cmd_index + c].stale_ticks)++;
      }
      if (awhy.empty()) {
        std::copy(act.begin(), act.end(), ep.actions.begin() + k * act_dim);
        ep.has_action[k] = 1;
      } else {
        if (missing_act++ == 0) first_act_why = awhy + " at tick " + std::to_string(k) + " (" + Stamp(t) + ")";
      }
      bool image_ok = true;
      if (camera) {
        const TopicSample* img = nullptr;
        const std::string iwhy = SampleImage(spec, *camera, images[0], t, begin, &img);
        SpecFieldReport& ir = report_.fields[image_index];
        ++ir.ticks;
        if (iwhy.empty()) {
          std::copy(img->pixels.begin(), img->pixels.end(), ep.images.begin() + k * image_bytes);
          ep.has_image[k] = 1;
          ++ir.covered_ticks;
        } else {
          image_ok = false;
          ++ir.stale_ticks;
          if (missing_img++ == 0) first_img_why = iwhy + " at tick " + std::to_string(k) + " (" + Stamp(t) + ")";
        }
      }
      if (ep.has_obs[k] && ep.has_action[k] && image_ok) ++report_.complete_ticks;
    }
    report_.ticks += static_cast<uint64_t>(n);
    ++report_.episodes;
    const std::string who = path + ": episode " + std::to_string(ep.meta.episode_id) + " (from " + Stamp(begin) + "): ";
    if (missing_obs)
      ep.problems.push_back(who + std::to_string(missing_obs) + " ticks without a fresh observation (first: " +
                            first_obs_why + ")");
    if (missing_act)
      ep.problems.push_back(who + std::to_string(missing_act) + " ticks without a fresh command (first: " +
                            first_act_why + ")");
    if (missing_img)
      ep.problems.push_back(who + std::to_string(missing_img) + " ticks without a fresh image (first: " +
                            first_img_why + ")");
    for (const auto& p : ep.problems) report_.problems.push_back(p);
    fn(std::move(ep));
  }
}

}  // namespace msspr::ros_bridge
