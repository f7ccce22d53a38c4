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
  // The first goal after the first tick (found by search: the recording's goals are
  // shared by all its episodes), and the one in effect before it.
  const double first_tick = ep->t0 + tolerance;
  size_t next = static_cast<size_t>(
      std::upper_bound(goals.begin(), goals.end(), first_tick,
                       [](double t, const auto& g) { return t < g.first.toSec(); }) -
      goals.begin());
  const std::vector<float>* current = next > 0 ? &goals[next - 1].second : nullptr;
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

// Samples a recording's episodes at the control ticks: each tick's observation, commands
// and image, counted per field, per bag and per episode.
class SpecBagReader::EpisodeSampler {
 public:
  EpisodeSampler(const RobotSpec& spec, Recording& rec, SpecBagReport& report)
      : spec_(spec),
        rec_(rec),
        report_(report),
        dt_(1.0 / spec.control_rate),
        obs_dim_(spec.obs_dim()),
        act_dim_(spec.action_dim()),
        image_row_(static_cast<int>(spec.observation.size())),
        cmd_row_(static_cast<int>(report.fields.size() - rec.cmd_topics.size())),
        camera_(spec.images.empty() ? nullptr : &spec.images[0]),
        usage_(rec.bags.size()),
        aligned_(rec.cmd_topics.size(), 0),
        ambiguous_(rec.cmd_topics.size(), 0),
        act_(static_cast<size_t>(spec.action_dim()), 0.f) {}

  // The episode of ticks begin, begin + dt, ... up to `last`, as episode `id`; false
  // (nothing counted) when its length is out of range.
  bool Sample(const ros::Time& begin, const ros::Time& last, uint64_t id, BagEpisode* ep) {
    const int64_t n = static_cast<int64_t>(std::floor((last - begin).toSec() / dt_ + 1e-9)) + 1;
    if (n <= 0 || n > static_cast<int64_t>(kMaxEpisodeSteps)) return false;
    Allocate(id, begin, n, ep);
    std::vector<CommandTrack> tracks = Tracks(begin, n);
    Missing obs, cmd, img;
    for (int64_t k = 0; k < n; ++k) {
      const ros::Time t = begin + ros::Duration(dt_ * static_cast<double>(k));
      Usage& u = usage_[BagOf(t)];
      ++u.ticks;
      const bool have_obs = ObservationAt(k, t, begin, ep, &obs);
      const bool have_cmd = CommandsAt(k, t, tracks, ep, &cmd);
      const bool have_img = !camera_ || ImageAt(k, t, begin, ep, &img);
      u.no_obs += !have_obs;
      u.no_cmd += !have_cmd;
      u.no_image += !have_img;
      if (have_obs && have_cmd && have_img) {
        ++report_.complete_ticks;
        ++u.complete;
      }
    }
    report_.ticks += static_cast<uint64_t>(n);
    ++report_.episodes;
    const std::string who =
        rec_.label + ": episode " + std::to_string(id) + " (from " + Stamp(begin) + "): ";
    obs.Report(who, "observation", &ep->problems);
    cmd.Report(who, "command", &ep->problems);
    img.Report(who, "image", &ep->problems);
    for (const auto& p : ep->problems) report_.problems.push_back(p);
    FillGoals(rec_.goals, obs_dim_, spec_.tolerance, ep);
    return true;
  }

  // After the last episode: the commands whose ticks are ambiguous, and a usage line per bag.
  void AddRecordingProblems() {
    for (size_t c = 0; c < rec_.cmd_topics.size(); ++c) {
      const SpecFieldReport& r = report_.fields[cmd_row_ + c];
      if (ambiguous_[c])
        report_.problems.push_back(
            rec_.label + ": topic " + r.topic + " (" + r.name +
            "): " + std::to_string(ambiguous_[c]) + " of " + std::to_string(aligned_[c]) +
            " commands arrived more than a quarter period off the others' phase: their ticks "
            "are ambiguous");
    }
    for (size_t b = 0; b < rec_.bags.size(); ++b) {
      const Usage& u = usage_[b];
      report_.usage.push_back(
          rec_.bags[b].path + ": " + std::to_string(u.ticks) + " ticks in episodes, " +
          std::to_string(u.complete) + " complete; not used: " + std::to_string(u.no_obs) +
          " without a fresh observation, " + std::to_string(u.no_cmd) + " without a command, " +
          std::to_string(u.no_image) + " without an image");
    }
  }

 private:
  // Per bag (by the time of the tick): ticks, complete ones, and why the others are not.
  struct Usage {
    uint64_t ticks = 0, complete = 0, no_obs = 0, no_cmd = 0, no_image = 0;
  };
  // An episode's ticks without a fresh input of one kind: the count and the first's reason.
  struct Missing {
    uint64_t count = 0;
    std::string first;
    void Note(const std::string& why, int64_t k, const ros::Time& t) {
      if (count++ == 0) first = why + " at tick " + std::to_string(k) + " (" + Stamp(t) + ")";
    }
    void Report(const std::string& who, const char* what, std::vector<std::string>* problems) {
      if (count)
        problems->push_back(who + std::to_string(count) + " ticks without a fresh " + what +
                            " (first: " + first + ")");
    }
  };

  void Allocate(uint64_t id, const ros::Time& begin, int64_t n, BagEpisode* ep) const {
    ep->meta.episode_id = id;
    ep->meta.env = spec_.name;
    ep->meta.split = "train";
    ep->has_meta = true;
    ep->obs_dim = obs_dim_;
    ep->act_dim = act_dim_;
    ep->t0 = begin.toSec();
    ep->step_period = dt_;
    ep->num_steps = static_cast<int>(n);
    ep->observations.assign(static_cast<size_t>(n) * obs_dim_, 0.f);
    ep->actions.assign(static_cast<size_t>(n) * act_dim_, 0.f);
    ep->has_obs.assign(n, 0);
    ep->has_action.assign(n, 0);
    ep->has_image.assign(n, 0);
    if (camera_) {  // one camera: the network's input
      ep->image_size = camera_->size;
      ep->images.assign(static_cast<size_t>(n) * ImageBytes(), 0);
    }
  }

  size_t ImageBytes() const {
    return camera_ ? static_cast<size_t>(camera_->size) * camera_->size * 3 : 0;
  }

  size_t BagOf(const ros::Time& t) const {
    size_t b = 0;
    while (b + 1 < rec_.bags.size() && rec_.bags[b + 1].begin <= t) ++b;
    return b;
  }

  // Each command topic's track over the episode; the alignment of unstamped commands is
  // counted (its phase commands-weighted over the episodes).
  std::vector<CommandTrack> Tracks(const ros::Time& begin, int64_t n) {
    std::vector<CommandTrack> tracks;
    tracks.reserve(rec_.cmd_topics.size());
    for (size_t c = 0; c < rec_.cmd_topics.size(); ++c) {
      tracks.emplace_back(spec_, rec_.cmd_topics[c], rec_.commands[c], begin, n);
      if (!tracks.back().aligned()) continue;
      const CommandAlignment& a = tracks.back().alignment();
      SpecFieldReport& r = report_.fields[cmd_row_ + c];
      const uint64_t before = r.aligned_commands;
      r.aligned_commands += a.commands;
      if (r.aligned_commands)
        r.phase_s =
            (r.phase_s * static_cast<double>(before) + a.phase * static_cast<double>(a.commands)) /
            static_cast<double>(r.aligned_commands);
      r.ambiguous += a.ambiguous;
      ambiguous_[c] += a.ambiguous;
      aligned_[c] += a.commands;
      r.shifted += a.shifted;
      r.dropped += a.dropped;
      r.spread_s = std::max(r.spread_s, a.spread);
    }
    return tracks;
  }

  bool ObservationAt(int64_t k, const ros::Time& t, const ros::Time& begin, BagEpisode* ep,
                     Missing* missing) {
    const SpecLayout& layout = rec_.layout;
    std::vector<int> stale_topics;
    const std::string why =
        SampleObservation(spec_, layout, rec_.histories, t, begin, &obs_, &stale_topics);
    for (size_t j = 0; j < layout.topics.size(); ++j) {
      const bool bad = std::find(stale_topics.begin(), stale_topics.end(), static_cast<int>(j)) !=
                       stale_topics.end();
      for (int idx : layout.topics[j].fields) {
        ++report_.fields[idx].ticks;
        (bad ? report_.fields[idx].stale_ticks : report_.fields[idx].covered_ticks)++;
      }
    }
    if (!why.empty()) {
      missing->Note(why, k, t);
      return false;
    }
    std::copy(obs_.begin(), obs_.end(), ep->observations.begin() + k * obs_dim_);
    ep->has_obs[k] = 1;
    return true;
  }

  bool CommandsAt(int64_t k, const ros::Time& t, std::vector<CommandTrack>& tracks, BagEpisode* ep,
                  Missing* missing) {
    std::string awhy;
    for (size_t c = 0; c < rec_.cmd_topics.size(); ++c) {
      const TopicSample* s = nullptr;
      const std::string cwhy = tracks[c].At(k, t, &s);
      SpecFieldReport& r = report_.fields[cmd_row_ + c];
      ++r.ticks;
      (cwhy.empty() ? r.covered_ticks : r.stale_ticks)++;
      if (cwhy.empty())
        PutCommand(spec_, rec_.cmd_topics[c], *s, &act_);
      else if (awhy.empty())
        awhy = cwhy;
    }
    if (!awhy.empty()) {
      missing->Note(awhy, k, t);
      return false;
    }
    std::copy(act_.begin(), act_.end(), ep->actions.begin() + k * act_dim_);
    ep->has_action[k] = 1;
    return true;
  }

  bool ImageAt(int64_t k, const ros::Time& t, const ros::Time& begin, BagEpisode* ep,
               Missing* missing) {
    const TopicSample* img = nullptr;
    const std::string why = SampleImage(spec_, *camera_, rec_.images[0], t, begin, &img);
    SpecFieldReport& r = report_.fields[image_row_];
    ++r.ticks;
    if (!why.empty()) {
      ++r.stale_ticks;
      missing->Note(why, k, t);
      return false;
    }
    std::copy(img->pixels.begin(), img->pixels.end(), ep->images.begin() + k * ImageBytes());
    ep->has_image[k] = 1;
    ++r.covered_ticks;
    return true;
  }

  const RobotSpec& spec_;
  Recording& rec_;
  SpecBagReport& report_;
  const double dt_;
  const int obs_dim_, act_dim_;
  const int image_row_, cmd_row_;  // the report's first camera and first command rows
  const SpecImage* camera_;
  std::vector<Usage> usage_;
  std::vector<uint64_t> aligned_, ambiguous_;  // per command topic: unstamped, ambiguous
  std::vector<float> obs_, act_;               // one tick's numbers
};

void SpecBagReader::EmitEpisodes(Recording* rec, uint64_t* next_id,
                                 const std::function<void(BagEpisode&&)>& fn) {
  const auto& primary = rec->histories[0].samples();
  if (primary.empty()) {
    report_.problems.push_back(rec->label + ": topic " + rec->layout.topics[0].name +
                               ": no usable message");
    return;
  }
  std::stable_sort(rec->goals.begin(), rec->goals.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  EpisodeSampler sampler(spec_, *rec, report_);
  for (const auto& [begin, last] : EpisodeSpans(rec)) {
    BagEpisode ep;
    if (sampler.Sample(begin, last, (*next_id)++, &ep)) fn(std::move(ep));
  }
  sampler.AddRecordingProblems();
}
}  // namespace msspr::ros_bridge
