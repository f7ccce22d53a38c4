// The reader of dataset bags (dataset_bag.h): checks a bag's structure and each
// message's bytes (dataset_bag_validator.h), then gathers the messages into episodes.
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Image.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <sstream>

#include "msspr/Action.h"
#include "msspr/EpisodeInfo.h"
#include "msspr/Observation.h"
#include "msspr_bags/dataset_bag.h"
#include "msspr_bags/dataset_bag_validator.h"
#include "msspr_bridge/msg_conversion.h"

namespace msspr::ros_bridge {

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

// MessageInstance::instantiate with the bytes checked first against the layout
// of M (nullptr for another type, as instantiate). Throws BagError naming the
// bag for a corrupt message.
template <class M>
boost::shared_ptr<M> Instantiate(const rosbag::MessageInstance& m, const std::string& path,
                                 uint64_t index) {
  if (m.getMD5Sum() != ros::message_traits::md5sum<M>() && m.getMD5Sum() != "*") return nullptr;
  std::vector<uint8_t> buf(m.size());
  ros::serialization::OStream out(buf.data(), static_cast<uint32_t>(buf.size()));
  m.write(out);
  std::string why;
  if (!MessageLayout::Of<M>().Fits(buf.data(), buf.size(), &why))
    throw BagError(path + ": message " + std::to_string(index) + " on " + m.getTopic() +
                   " is corrupt (its " + std::to_string(buf.size()) + " bytes do not hold the " +
                   ros::message_traits::datatype<M>() + " its fields declare: " + why + ")");
  auto msg = boost::make_shared<M>();
  ros::serialization::IStream in(buf.data(), static_cast<uint32_t>(buf.size()));
  ros::serialization::deserialize(in, *msg);
  return msg;
}

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

// A self-consistent rgb8 image: its side, or 0.
uint32_t RgbSide(const sensor_msgs::Image& img) {
  if (img.encoding != "rgb8" || img.width != img.height || img.width == 0 ||
      img.width > kMaxImageSide)
    return 0;
  if (uint64_t{img.step} != uint64_t{img.width} * 3 ||
      img.data.size() != uint64_t{img.step} * img.height)
    return 0;
  return img.width;
}

// Step indices come from the data: one far beyond the episode's observed length (twice
// the number of distinct steps it carries) is rejected, so a corrupt `step` never drives an
// allocation. Drops those steps' messages; returns the number of steps (0: none).
int CheckStepRange(PartialEpisode& p, const std::string& who, BagEpisode* ep,
                   BagReadReport* report) {
  std::map<uint32_t, int> distinct;
  for (auto& kv : p.obs) distinct[kv.first] = 1;
  for (auto& kv : p.actions) distinct[kv.first] = 1;
  const uint64_t limit = std::max<uint64_t>(16, 2 * distinct.size());
  uint32_t max_step = 0;
  bool any = false;
  for (auto& [t, one] : distinct) {
    if (t >= limit) {
      ++report->out_of_range_steps;
      ep->problems.push_back(who + "step " + std::to_string(t) + " out of range (episode has " +
                             std::to_string(distinct.size()) + " steps)");
      continue;
    }
    max_step = std::max(max_step, t), any = true;
  }
  for (auto it = p.obs.begin(); it != p.obs.end();)
    it = it->first >= limit ? p.obs.erase(it) : std::next(it);
  for (auto it = p.actions.begin(); it != p.actions.end();)
    it = it->first >= limit ? p.actions.erase(it) : std::next(it);
  return any ? static_cast<int>(max_step) + 1 : 0;
}

// The observations and actions into their arrays. A wrong size is a problem; NaN / Inf
// rejects the step (counted, and it splits the episode as a gap would).
void FillStatesAndActions(const PartialEpisode& p, const std::string& who, BagEpisode* ep,
                          BagReadReport* report) {
  const int n = ep->num_steps;
  if (!p.obs.empty()) ep->obs_dim = static_cast<int>(p.obs.begin()->second->state.size());
  if (!p.actions.empty()) ep->act_dim = static_cast<int>(p.actions.begin()->second->action.size());
  ep->observations.assign(static_cast<size_t>(n) * ep->obs_dim, 0.f);
  ep->actions.assign(static_cast<size_t>(n) * ep->act_dim, 0.f);
  // Copies one message's numbers into step t's row, or says why not.
  auto fill = [&](uint32_t t, const std::vector<float>& values, int dim, const char* what,
                  std::vector<float>* rows, std::vector<uint8_t>* has,
                  std::vector<uint32_t>* nonfinite) {
    if (static_cast<int>(values.size()) != dim) {
      ep->problems.push_back(who + what + " at step " + std::to_string(t) + " has " +
                             std::to_string(values.size()) + " numbers, expected " +
                             std::to_string(dim));
      return;
    }
    if (!AllFinite(values)) {
      nonfinite->push_back(t);
      return;
    }
    std::copy(values.begin(), values.end(), rows->begin() + t * dim);
    (*has)[t] = 1;
  };
  std::vector<uint32_t> bad_obs, bad_act;
  for (auto& [t, m] : p.obs)
    fill(t, m->state, ep->obs_dim, "observation", &ep->observations, &ep->has_obs, &bad_obs);
  for (auto& [t, m] : p.actions)
    fill(t, m->action, ep->act_dim, "action", &ep->actions, &ep->has_action, &bad_act);
  auto describe = [&](const std::vector<uint32_t>& steps, const char* what, uint64_t* count) {
    if (steps.empty()) return;
    *count += steps.size();
    std::string list;
    for (size_t i = 0; i < steps.size() && i < 4; ++i)
      list += (i ? ", " : "") + std::to_string(steps[i]);
    ep->problems.push_back(who + std::to_string(steps.size()) + " " + what +
                           " with NaN or Inf rejected (step" + (steps.size() > 1 ? "s " : " ") +
                           list + (steps.size() > 4 ? ", ..." : "") + ")");
  };
  describe(bad_obs, "observations", &report->nonfinite_observations);
  describe(bad_act, "actions", &report->nonfinite_actions);
}

// The images of the steps: the size is the most common one among self-consistent rgb8
// images; the rest are reported per step.
void FillImages(const PartialEpisode& p, const std::string& who, BagEpisode* ep,
                BagReadReport* report) {
  const int n = ep->num_steps;
  std::map<uint32_t, int> sides;
  for (auto& kv : p.images)
    if (const uint32_t side = RgbSide(*kv.second)) ++sides[side];
  if (!p.images.empty() && sides.empty())
    ep->problems.push_back(who + std::to_string(p.images.size()) +
                           " images, none a consistent rgb8 image (size, step and data disagree)");
  if (!sides.empty()) {
    const auto best = std::max_element(sides.begin(), sides.end(),
                                       [](auto& a, auto& b) { return a.second < b.second; });
    ep->image_size = static_cast<int>(best->first);
    const size_t bytes = static_cast<size_t>(ep->image_size) * ep->image_size * 3;
    if (bytes * n > kMaxEpisodeImageBytes) {
      ep->problems.push_back(who + "images of " + std::to_string(ep->image_size) + "x" +
                             std::to_string(ep->image_size) + " for " + std::to_string(n) +
                             " steps exceed the per-episode limit; images dropped");
      ep->image_size = 0;
    }
  }
  if (ep->image_size <= 0) return;
  const size_t bytes = static_cast<size_t>(ep->image_size) * ep->image_size * 3;
  ep->images.assign(bytes * n, 0);
  for (auto& [t, m] : p.obs) {
    auto it = p.images.find(m->header.stamp);
    if (it == p.images.end()) continue;
    const std::string bad = CheckRgbImage(*it->second, ep->image_size);
    if (!bad.empty()) {
      ++report->bad_images;
      ep->problems.push_back(who + "image at step " + std::to_string(t) + ": " + bad);
      continue;
    }
    std::memcpy(ep->images.data() + bytes * t, it->second->data.data(), bytes);
    ep->has_image[t] = 1;
  }
}

BagEpisode Finalize(PartialEpisode&& p, BagReadReport* report) {
  BagEpisode ep = std::move(p.ep);
  const std::string who = "episode " + std::to_string(ep.meta.episode_id) + ": ";
  ep.num_steps = CheckStepRange(p, who, &ep, report);
  const int n = ep.num_steps;
  ep.has_obs.assign(n, 0);
  ep.has_action.assign(n, 0);
  ep.has_image.assign(n, 0);
  FillStatesAndActions(p, who, &ep, report);
  FillImages(p, who, &ep, report);
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
    ep.problems.push_back(who + std::to_string(p.duplicates) +
                          " conflicting duplicate messages (first kept)");
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
  CheckBagStructure(path_);
  try {
    bag_->open(path_, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw BagError(path_ + ": cannot open as a rosbag: " + e.what() +
                   " (not a bag, or truncated; a recording cut short may be repaired with"
                   " 'rosbag reindex')");
  }
}

DatasetBagReader::~DatasetBagReader() = default;

uint64_t DatasetBagReader::CountObservations() const {
  try {
    return rosbag::View(*bag_, rosbag::TopicQuery(std::vector<std::string>{kObservationTopic}))
        .size();
  } catch (const rosbag::BagException& e) {
    throw BagError(path_ + ": cannot read the bag index: " + e.what());
  }
}

namespace {

// Assembles episodes from a bag's messages in time order and hands each one, finalized, to
// `fn` once no later message can belong to it: live recordings can interleave the tail of
// one episode with the head of the next, never more, so episodes two ids behind the newest
// are complete.
class EpisodeAssembler {
 public:
  EpisodeAssembler(const std::string& path, BagReadReport& report,
                   const std::function<void(BagEpisode&&)>& fn)
      : path_(path), report_(report), fn_(fn) {}

  void Read(const rosbag::MessageInstance& m) {
    ++report_.messages;
    const std::string& topic = m.getTopic();
    if (topic == kObservationTopic) {
      if (auto o = Typed<msspr::Observation>(m)) AddObservation(o);
    } else if (topic == kActionTopic) {
      if (auto a = Typed<msspr::Action>(m)) AddAction(a);
    } else if (topic == kEpisodeTopic) {
      if (auto e = Typed<msspr::EpisodeInfo>(m)) AddEpisodeInfo(*e);
    } else if (topic == kImageTopic) {
      if (auto img = Typed<sensor_msgs::Image>(m)) AddImage(img);
    }
    Flush(false);
  }

  // Finalizes and hands over the open episodes: all, or those two ids behind the newest.
  void Flush(bool all) {
    while (!open_.empty() && (all || open_.begin()->first + 2 <= max_id_)) {
      auto node = open_.extract(open_.begin());
      for (auto& kv : node.mapped().obs) stamp_owner_.erase(kv.second->header.stamp);
      BagEpisode ep = Finalize(std::move(node.mapped()), &report_);
      in_callback_ = true;
      fn_(std::move(ep));
      in_callback_ = false;
    }
  }

  // Whether an exception comes from fn (it passes through unchanged).
  bool in_callback() const { return in_callback_; }

  // The problems of the whole bag, after the last Flush.
  void AddBagProblems() {
    if (!pending_images_.empty())
      report_.problems.push_back(std::to_string(pending_images_.size()) +
                                 " images match no observation stamp");
    for (const auto& [type, seen] : other_definitions_)
      report_.problems.push_back(std::to_string(seen.first) + " " + type +
                                 " messages were written with another definition of " + type +
                                 " (" + seen.second +
                                 "): the bag comes from another version of msspr's messages");
    if (report_.foreign_messages > 0)
      report_.problems.push_back(std::to_string(report_.foreign_messages) +
                                 " messages of an unexpected type on msspr topics");
  }

 private:
  // The message as M; null for a message of another type on the topic, counted (those
  // of the expected type but another definition, from another version of the .msg, are
  // named apart).
  template <class M>
  boost::shared_ptr<M> Typed(const rosbag::MessageInstance& m) {
    auto msg = Instantiate<M>(m, path_, report_.messages);
    if (msg) return msg;
    ++report_.foreign_messages;
    const char* type = ros::message_traits::datatype<M>();
    if (m.getDataType() == type) {
      auto& [n, md5s] = other_definitions_[type];
      if (n++ == 0)
        md5s =
            "md5 " + m.getMD5Sum() + "; this build reads md5 " + ros::message_traits::md5sum<M>();
    }
    return nullptr;
  }

  // A step index beyond kMaxEpisodeSteps is rejected as it is read.
  bool StepOk(uint32_t id, uint32_t step, const char* what) {
    if (step < kMaxEpisodeSteps) return true;
    ++report_.out_of_range_steps;
    report_.problems.push_back("episode " + std::to_string(id) + ": " + what + " step " +
                               std::to_string(step) + " out of range (limit " +
                               std::to_string(kMaxEpisodeSteps) + " steps)");
    return false;
  }

  PartialEpisode& Slot(uint32_t id) {
    auto& p = open_[id];
    p.ep.meta.episode_id = id;
    if (!any_ || id > max_id_) max_id_ = id;
    any_ = true;
    return p;
  }

  void AddObservation(const msspr::Observation::ConstPtr& o) {
    if (!StepOk(o->episode_id, o->step, "observation")) return;
    auto& p = Slot(o->episode_id);
    auto [it_o, fresh] = p.obs.emplace(o->step, o);
    if (!fresh && it_o->second->state != o->state) ++p.duplicates;  // re-sends are identical
    stamp_owner_[o->header.stamp] = o->episode_id;
    auto it = pending_images_.find(o->header.stamp);
    if (it != pending_images_.end()) {
      p.images.emplace(it->first, it->second);
      pending_images_.erase(it);
    }
  }

  void AddAction(const msspr::Action::ConstPtr& a) {
    if (!StepOk(a->episode_id, a->step, "action")) return;
    auto& p = Slot(a->episode_id);
    auto [it_a, fresh] = p.actions.emplace(a->step, a);
    if (!fresh && it_a->second->action != a->action) ++p.duplicates;
  }

  void AddEpisodeInfo(const msspr::EpisodeInfo& e) {
    auto& p = Slot(e.episode_id);
    p.ep.has_meta = true;
    p.ep.meta.env = e.env;
    p.ep.meta.split = e.split.empty() ? "train" : e.split;
    p.ep.meta.task_id = e.task_id;
    p.ep.meta.seed = e.seed;
    p.ep.meta.start = e.start;
    p.ep.meta.goal = e.goal;
  }

  // The image shares its stamp with its observation; it may come first.
  void AddImage(const sensor_msgs::Image::ConstPtr& img) {
    auto owner = stamp_owner_.find(img->header.stamp);
    if (owner != stamp_owner_.end() && open_.count(owner->second))
      open_[owner->second].images.emplace(img->header.stamp, img);
    else
      pending_images_.emplace(img->header.stamp, img);
  }

  const std::string& path_;
  BagReadReport& report_;
  const std::function<void(BagEpisode&&)>& fn_;
  std::map<uint32_t, PartialEpisode> open_;
  uint32_t max_id_ = 0;
  bool any_ = false;
  bool in_callback_ = false;
  std::map<ros::Time, uint32_t> stamp_owner_;                         // observation stamp -> id
  std::map<ros::Time, sensor_msgs::Image::ConstPtr> pending_images_;  // image before its obs
  std::map<std::string, std::pair<uint64_t, std::string>> other_definitions_;  // type -> n, md5s
};

}  // namespace

void DatasetBagReader::ForEachEpisode(const std::function<void(BagEpisode&&)>& fn) {
  report_ = BagReadReport{};
  EpisodeAssembler assembler(path_, report_, fn);
  try {
    rosbag::View view(
        *bag_, rosbag::TopicQuery({kEpisodeTopic, kObservationTopic, kActionTopic, kImageTopic}));
    if (view.size() == 0)
      throw BagError(path_ + ": no messages on " + kObservationTopic + " / " + kActionTopic +
                     " (not an msspr dataset bag?)");
    for (const rosbag::MessageInstance& m : view) assembler.Read(m);
  } catch (const std::exception& e) {
    // rosbag errors, corrupt messages, and deserialization errors (ros::Exception);
    // the episodes read so far are delivered first.
    if (assembler.in_callback()) throw;
    const bool named = dynamic_cast<const BagError*>(&e) != nullptr;
    const std::string what = e.what();
    try {
      assembler.Flush(true);
    } catch (...) {
      if (assembler.in_callback()) throw;
    }
    if (named) throw BagError(what);
    throw BagError(path_ + ": truncated or corrupt after " + std::to_string(report_.messages) +
                   " messages: " + what);
  }
  assembler.Flush(true);
  assembler.AddBagProblems();
}

}  // namespace msspr::ros_bridge
