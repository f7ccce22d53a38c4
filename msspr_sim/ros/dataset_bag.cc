#include "dataset_bag.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <sstream>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Image.h>

#include "msg_conversion.h"
#include "msspr/Action.h"
#include "msspr/EpisodeInfo.h"
#include "msspr/Observation.h"

namespace msspr::ros_bridge {

DatasetBagWriter::DatasetBagWriter(const std::string& path, double control_dt, bool lz4)
    : path_(path), control_dt_(control_dt), bag_(std::make_unique<rosbag::Bag>()) {
  try {
    bag_->open(path, rosbag::bagmode::Write);
  } catch (const rosbag::BagException& e) {
    throw BagError(path + ": cannot open for writing: " + e.what());
  }
  if (lz4) bag_->setCompression(rosbag::compression::LZ4);
}

DatasetBagWriter::~DatasetBagWriter() {
  try {
    Close();
  } catch (...) {
  }
}

void DatasetBagWriter::Close() {
  if (bag_ && bag_->isOpen()) bag_->close();
}

void DatasetBagWriter::WriteEpisode(const EpisodeMeta& meta, int length, int obs_dim, int act_dim,
                                    const float* observations, const float* actions,
                                    const uint8_t* images, int image_size,
                                    double success_radius) {
  if (!bag_->isOpen()) throw BagError(path_ + ": writer already closed");
  ++tick_;  // the reset
  const ros::Time t0 = TickToTime(tick_, control_dt_);
  msspr::EpisodeInfo info;
  info.header.stamp = t0;
  info.episode_id = static_cast<uint32_t>(meta.episode_id);
  info.env = meta.env;
  info.split = meta.split;
  info.task_id = meta.task_id;
  info.seed = meta.seed;
  info.start = meta.start;
  info.goal = meta.goal;
  bag_->write(kEpisodeTopic, t0, info);
  ++messages_;

  msspr::Observation obs;
  obs.episode_id = info.episode_id;
  obs.goal = meta.goal;
  obs.header.frame_id = "world";
  msspr::Action act;
  act.episode_id = info.episode_id;
  const size_t image_bytes = static_cast<size_t>(image_size) * image_size * 3;
  for (int t = 0; t < length; ++t) {
    if (t > 0) ++tick_;
    const ros::Time stamp = TickToTime(tick_, control_dt_);
    obs.header.stamp = stamp;
    obs.step = static_cast<uint32_t>(t);
    obs.state.assign(observations + static_cast<size_t>(t) * obs_dim,
                     observations + static_cast<size_t>(t + 1) * obs_dim);
    double d2 = 0.0;
    for (int k = 0; k < obs_dim && k < static_cast<int>(meta.goal.size()); ++k) {
      const double d = static_cast<double>(obs.state[k]) - meta.goal[k];
      d2 += d * d;
    }
    obs.success = !meta.goal.empty() && std::sqrt(d2) <= success_radius;
    obs.last = (t == length - 1);
    bag_->write(kObservationTopic, stamp, obs);
    if (images != nullptr) {
      bag_->write(kImageTopic, stamp,
                  ToImageMsg(images + static_cast<size_t>(t) * image_bytes, image_size, stamp,
                             kCameraFrame));
      ++messages_;
    }
    act.header.stamp = stamp;
    act.step = obs.step;
    act.action.assign(actions + static_cast<size_t>(t) * act_dim,
                      actions + static_cast<size_t>(t + 1) * act_dim);
    bag_->write(kActionTopic, stamp, act);
    messages_ += 2;
  }
}

std::vector<std::pair<int, int>> BagEpisode::Segments() const {
  std::vector<std::pair<int, int>> out;
  const bool need_image = image_size > 0;
  int begin = -1;
  for (int t = 0; t <= num_steps; ++t) {
    const bool ok = t < num_steps && has_obs[t] && has_action[t] && (!need_image || has_image[t]);
    if (ok && begin < 0) begin = t;
    if (!ok && begin >= 0) {
      out.emplace_back(begin, t);
      begin = -1;
    }
  }
  return out;
}

namespace {

// Collects the messages of one episode until it can be finalised.
struct PartialEpisode {
  BagEpisode ep;
  std::map<uint32_t, msspr::Observation::ConstPtr> obs;
  std::map<uint32_t, msspr::Action::ConstPtr> actions;
  std::map<ros::Time, sensor_msgs::Image::ConstPtr> images;  // keyed by stamp
  uint64_t duplicates = 0;
};

// Describes missing steps compactly: "3 (steps 10-12)".
std::string DescribeMissing(const std::vector<uint8_t>& have, int n, uint64_t* count) {
  std::ostringstream s;
  std::vector<std::pair<int, int>> runs;
  for (int t = 0; t < n; ++t) {
    if (have[t]) continue;
    if (!runs.empty() && runs.back().second == t - 1)
      runs.back().second = t;
    else
      runs.emplace_back(t, t);
  }
  uint64_t c = 0;
  for (auto& r : runs) c += static_cast<uint64_t>(r.second - r.first + 1);
  *count += c;
  if (runs.empty()) return "";
  s << c << " (step" << (c > 1 ? "s " : " ");
  for (size_t i = 0; i < runs.size() && i < 4; ++i) {
    if (i) s << ", ";
    s << runs[i].first;
    if (runs[i].second != runs[i].first) s << "-" << runs[i].second;
  }
  if (runs.size() > 4) s << ", ...";
  s << ")";
  return s.str();
}

BagEpisode Finalize(PartialEpisode&& p, BagReadReport* report) {
  BagEpisode ep = std::move(p.ep);
  uint32_t max_step = 0;
  bool any = false;
  for (auto& kv : p.obs) max_step = std::max(max_step, kv.first), any = true;
  for (auto& kv : p.actions) max_step = std::max(max_step, kv.first), any = true;
  ep.num_steps = any ? static_cast<int>(max_step) + 1 : 0;
  const int n = ep.num_steps;
  ep.has_obs.assign(n, 0);
  ep.has_action.assign(n, 0);
  ep.has_image.assign(n, 0);
  if (!p.obs.empty()) ep.obs_dim = static_cast<int>(p.obs.begin()->second->state.size());
  if (!p.actions.empty()) ep.act_dim = static_cast<int>(p.actions.begin()->second->action.size());
  ep.observations.assign(static_cast<size_t>(n) * ep.obs_dim, 0.f);
  ep.actions.assign(static_cast<size_t>(n) * ep.act_dim, 0.f);
  const std::string who = "episode " + std::to_string(ep.meta.episode_id) + ": ";
  for (auto& [t, m] : p.obs) {
    if (static_cast<int>(m->state.size()) != ep.obs_dim) {
      ep.problems.push_back(who + "observation at step " + std::to_string(t) + " has " +
                            std::to_string(m->state.size()) + " numbers, expected " +
                            std::to_string(ep.obs_dim));
      continue;
    }
    std::copy(m->state.begin(), m->state.end(), ep.observations.begin() + t * ep.obs_dim);
    ep.has_obs[t] = 1;
  }
  for (auto& [t, m] : p.actions) {
    if (static_cast<int>(m->action.size()) != ep.act_dim) {
      ep.problems.push_back(who + "action at step " + std::to_string(t) + " has " +
                            std::to_string(m->action.size()) + " numbers, expected " +
                            std::to_string(ep.act_dim));
      continue;
    }
    std::copy(m->action.begin(), m->action.end(), ep.actions.begin() + t * ep.act_dim);
    ep.has_action[t] = 1;
  }
  if (!p.images.empty()) {
    ep.image_size = static_cast<int>(p.images.begin()->second->width);
    const size_t bytes = static_cast<size_t>(ep.image_size) * ep.image_size * 3;
    ep.images.assign(bytes * n, 0);
    for (auto& [t, m] : p.obs) {
      auto it = p.images.find(m->header.stamp);
      if (it == p.images.end()) continue;
      const std::string bad = CheckRgbImage(*it->second, ep.image_size);
      if (!bad.empty()) {
        ep.problems.push_back(who + "image at step " + std::to_string(t) + ": " + bad);
        continue;
      }
      std::memcpy(ep.images.data() + bytes * t, it->second->data.data(), bytes);
      ep.has_image[t] = 1;
    }
  }
  if (!ep.has_meta) ep.problems.push_back(who + std::string("no message on ") + kEpisodeTopic);
  std::string miss = DescribeMissing(ep.has_obs, n, &report->missing_observations);
  if (!miss.empty()) ep.problems.push_back(who + "missing observations: " + miss);
  miss = DescribeMissing(ep.has_action, n, &report->missing_actions);
  if (!miss.empty()) ep.problems.push_back(who + "missing actions: " + miss);
  if (ep.image_size > 0) {
    miss = DescribeMissing(ep.has_image, n, &report->missing_images);
    if (!miss.empty()) ep.problems.push_back(who + "missing images: " + miss);
  }
  if (p.duplicates > 0)
    ep.problems.push_back(who + std::to_string(p.duplicates) + " conflicting duplicate messages (first kept)");
  report->duplicates += p.duplicates;
  report->episodes += 1;
  report->steps += static_cast<uint64_t>(n);
  if (ep.problems.empty()) report->complete_episodes += 1;
  for (auto& s : ep.problems) report->problems.push_back(s);
  return ep;
}

}  // namespace

DatasetBagReader::DatasetBagReader(std::string path)
    : path_(std::move(path)), bag_(std::make_unique<rosbag::Bag>()) {
  try {
    bag_->open(path_, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw BagError(path_ + ": cannot open as a rosbag: " + e.what() +
                   " (not a bag, or truncated; a recording cut short may be repaired with"
                   " 'rosbag reindex')");
  }
}

DatasetBagReader::~DatasetBagReader() = default;

void DatasetBagReader::ForEachEpisode(const std::function<void(BagEpisode&&)>& fn) {
  report_ = BagReadReport{};
  std::map<uint32_t, PartialEpisode> open;
  uint32_t max_id = 0;
  bool any = false;
  std::map<ros::Time, uint32_t> stamp_owner;  // observation stamp -> episode id
  std::map<ros::Time, sensor_msgs::Image::ConstPtr> pending_images;  // image before its obs
  // Episodes two ids behind the newest are complete: live recordings can interleave
  // the tail of one episode with the head of the next, never more.
  auto flush = [&](bool all) {
    while (!open.empty() && (all || open.begin()->first + 2 <= max_id)) {
      auto node = open.extract(open.begin());
      for (auto& kv : node.mapped().obs) stamp_owner.erase(kv.second->header.stamp);
      fn(Finalize(std::move(node.mapped()), &report_));
    }
  };
  auto slot = [&](uint32_t id) -> PartialEpisode& {
    auto& p = open[id];
    p.ep.meta.episode_id = id;
    if (!any || id > max_id) max_id = id;
    any = true;
    return p;
  };
  try {
    rosbag::View view(*bag_, rosbag::TopicQuery({kEpisodeTopic, kObservationTopic, kActionTopic,
                                                 kImageTopic}));
    if (view.size() == 0)
      throw BagError(path_ + ": no messages on " + kObservationTopic + " / " + kActionTopic +
                     " (not an msspr dataset bag?)");
    for (const rosbag::MessageInstance& m : view) {
      ++report_.messages;
      const std::string& topic = m.getTopic();
      if (topic == kObservationTopic) {
        auto o = m.instantiate<msspr::Observation>();
        if (!o) {
          ++report_.foreign_messages;
          continue;
        }
        auto& p = slot(o->episode_id);
        auto [it_o, fresh] = p.obs.emplace(o->step, o);
        if (!fresh && it_o->second->state != o->state) ++p.duplicates;  // re-sends are identical
        stamp_owner[o->header.stamp] = o->episode_id;
        auto it = pending_images.find(o->header.stamp);
        if (it != pending_images.end()) {
          p.images.emplace(it->first, it->second);
          pending_images.erase(it);
        }
      } else if (topic == kActionTopic) {
        auto a = m.instantiate<msspr::Action>();
        if (!a) {
          ++report_.foreign_messages;
          continue;
        }
        auto& p = slot(a->episode_id);
        auto [it_a, fresh] = p.actions.emplace(a->step, a);
        if (!fresh && it_a->second->action != a->action) ++p.duplicates;
      } else if (topic == kEpisodeTopic) {
        auto e = m.instantiate<msspr::EpisodeInfo>();
        if (!e) {
          ++report_.foreign_messages;
          continue;
        }
        auto& p = slot(e->episode_id);
        p.ep.has_meta = true;
        p.ep.meta.env = e->env;
        p.ep.meta.split = e->split.empty() ? "train" : e->split;
        p.ep.meta.task_id = e->task_id;
        p.ep.meta.seed = e->seed;
        p.ep.meta.start = e->start;
        p.ep.meta.goal = e->goal;
      } else if (topic == kImageTopic) {
        auto img = m.instantiate<sensor_msgs::Image>();
        if (!img) {
          ++report_.foreign_messages;
          continue;
        }
        // The image shares its stamp with its observation; it may come first.
        auto owner = stamp_owner.find(img->header.stamp);
        if (owner != stamp_owner.end() && open.count(owner->second))
          open[owner->second].images.emplace(img->header.stamp, img);
        else
          pending_images.emplace(img->header.stamp, img);
      }
      flush(false);
    }
  } catch (const rosbag::BagException& e) {
    flush(true);
    throw BagError(path_ + ": truncated or corrupt after " + std::to_string(report_.messages) +
                   " messages: " + e.what());
  }
  flush(true);
  if (!pending_images.empty())
    report_.problems.push_back(std::to_string(pending_images.size()) +
                               " images match no observation stamp");
  if (report_.foreign_messages > 0)
    report_.problems.push_back(std::to_string(report_.foreign_messages) +
                               " messages of an unexpected type on msspr topics");
}

}  // namespace msspr::ros_bridge
