// SpecBagReader's second half: a recording's decoded messages cut into episodes
// and sampled at the control ticks (the spans of the episodes, the commands of
// each tick, the per-bag usage). The first half, reading the bags, is spec_bag.cc.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "msspr_robot_interface/command_alignment.h"
#include "spec_bag_recording.h"

namespace msspr::ros_bridge {

using spec_bag_internal::Stamp;

namespace {

// ep->goals: at each tick t0 + t * step_period, the last goal stamped at or before it
// (within `tolerance` after, as the observations), NaN before the first. `goals` is
// in time order; nothing when it is empty.
void FillGoals(const std::vector<std::pair<ros::Time, std::vector<float>>>& goals, int obs_dim,
               double tolerance, BagEpisode* ep) {
  if (goals.empty()) return;
  ep->goals.assign(static_cast<size_t>(ep->num_steps) * obs_dim,
                   std::numeric_limits<float>::quiet_NaN());
  size_t next = 0;  // the first goal after the current tick
  const std::vector<float>* current = nullptr;
  for (int t = 0; t < ep->num_steps; ++t) {
    const double tick = ep->t0 + t * ep->step_period + tolerance;
    while (next < goals.size() && goals[next].first.toSec() <= tick)
      current = &goals[next++].second;
    if (current && static_cast<int>(current->size()) == obs_dim)
      std::copy(current->begin(), current->end(),
                ep->goals.begin() + static_cast<size_t>(t) * obs_dim);
  }
}

}  // namespace

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
    std::vector<double> receipts;  // s after begin
    for (auto it = lo; it != s.end() && it->stamp < end; ++it) {
      samples_.push_back(&*it);
      receipts.push_back((it->stamp - begin).toSec());
    }
    alignment_ = AlignCommands(receipts, 0.0, period, ticks);
    // Per tick, the tick at or before it that has a command (-1: none yet), so that a tick
    // without one finds the command it holds in one step.
    latest_tick_.resize(alignment_.command_of_tick.size());
    int64_t latest = -1;
    for (size_t k = 0; k < latest_tick_.size(); ++k) {
      if (alignment_.command_of_tick[k] >= 0) latest = static_cast<int64_t>(k);
      latest_tick_[k] = latest;
    }
  }

  // The command of tick k (at time t), or why there is none.
  std::string At(int64_t k, const ros::Time& t, const TopicSample** out) const {
    if (!aligned_) return NewestCommand(spec_, topic_.topic, history_, t, begin_, out);
    const int64_t j = latest_tick_[static_cast<size_t>(k)];
    if (j < 0) return "topic " + topic_.topic + ": no command yet";
    const TopicSample* s =
        samples_[static_cast<size_t>(alignment_.command_of_tick[static_cast<size_t>(j)])];
    if (j < k && s->stamp < Before(t, ros::Duration(spec_.stale_after)))
      return "topic " + topic_.topic + ": no command for this tick, the last is " +
             std::to_string((t - s->stamp).toSec()) + " s old (stale_after " +
             std::to_string(spec_.stale_after) + " s)";
    *out = s;
    return "";
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
  std::vector<int64_t> latest_tick_;  // per tick: the latest tick <= it with a command, or -1
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
  std::stable_sort(rec->goals.begin(), rec->goals.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
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
    FillGoals(rec->goals, obs_dim, spec.tolerance, &ep);
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
