// msspr_bag_info: summarises an msspr dataset bag and reports what is wrong with it.
// Exit status: 0 whole, 1 inconsistent (missing or malformed messages), 2 unreadable.
#include <ros/time.h>
#include <sys/stat.h>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "msspr_bags/dataset_bag.h"
#include "msspr_bridge/cli_args.h"
#include "msspr_robot_interface/spec_bag.h"
#ifdef MSSPR_BAG_INFO_EXPORT
#include "msspr_core/npz.h"
#endif

namespace {

// Prints the first max_problems problems to stderr, then how many more there were.
void PrintProblems(const std::vector<std::string>& problems, long max_problems) {
  for (size_t i = 0; i < problems.size() && static_cast<long>(i) < max_problems; ++i)
    std::fprintf(stderr, "  %s\n", problems[i].c_str());
  if (static_cast<long>(problems.size()) > max_problems)
    std::fprintf(stderr, "  ... and %zu more\n", problems.size() - max_problems);
}

// The per-tick dataset a spec extracts, in OGBench's .npz layout (--export).
struct Export {
  std::vector<float> observations, actions, terminals, goals;
  std::vector<double> timestamps;
  std::vector<uint8_t> images;
  int obs_dim = 0, act_dim = 0, image_size = 0;
  int64_t steps = 0;
  bool with_goals = true;  // every episode so far had goal rows

  // Appends the episode's complete runs of steps (Segments), each one trajectory.
  void Add(const msspr::ros_bridge::BagEpisode& ep) {
    obs_dim = ep.obs_dim;
    act_dim = ep.act_dim;
    image_size = ep.image_size;
    with_goals = with_goals && !ep.goals.empty();
    const size_t image_bytes = static_cast<size_t>(ep.image_size) * ep.image_size * 3;
    for (const auto& [b, e] : ep.Segments()) {
      for (int t = b; t < e; ++t) {
        observations.insert(observations.end(), ep.observations.begin() + t * ep.obs_dim,
                            ep.observations.begin() + (t + 1) * ep.obs_dim);
        actions.insert(actions.end(), ep.actions.begin() + t * ep.act_dim,
                       ep.actions.begin() + (t + 1) * ep.act_dim);
        terminals.push_back(t == e - 1 ? 1.f : 0.f);
        if (with_goals)
          goals.insert(goals.end(), ep.goals.begin() + t * ep.obs_dim,
                       ep.goals.begin() + (t + 1) * ep.obs_dim);
        timestamps.push_back(ep.t0 + t * ep.step_period);
        if (image_bytes)
          images.insert(images.end(), ep.images.begin() + t * image_bytes,
                        ep.images.begin() + (t + 1) * image_bytes);
        ++steps;
      }
    }
  }

  // Writes observations [N, obs_dim] and actions [N, action_dim] float32, terminals [N]
  // float32 (1 on each trajectory's last step), timestamps [N] float64 (s, the ticks),
  // with a camera images [N, S, S, 3] uint8, and with a recorded pose or observation
  // goal goals [N, obs_dim] float32 (the goal in effect at each tick, NaN before the
  // first). Throws on failure.
  void Write(const std::string& path) const {
#ifdef MSSPR_BAG_INFO_EXPORT
    using msspr::core::NpyArray;
    std::vector<NpyArray> arrays = {
        {"observations",
         "<f4",
         {steps, obs_dim},
         observations.data(),
         sizeof(float) * observations.size()},
        {"actions", "<f4", {steps, act_dim}, actions.data(), sizeof(float) * actions.size()},
        {"terminals", "<f4", {steps}, terminals.data(), sizeof(float) * terminals.size()},
        {"timestamps", "<f8", {steps}, timestamps.data(), sizeof(double) * timestamps.size()}};
    if (image_size)
      arrays.push_back(
          {"images", "|u1", {steps, image_size, image_size, 3}, images.data(), images.size()});
    if (with_goals && steps > 0)
      arrays.push_back(
          {"goals", "<f4", {steps, obs_dim}, goals.data(), sizeof(float) * goals.size()});
    msspr::core::SaveNpzArrays(path, arrays);
#else
    throw std::runtime_error("--export " + path +
                             ": this build has no msspr_core (the .npz writer)");
#endif
  }
};

// msspr_bag_info --robot SPEC.yaml BAG...: what the spec would extract from the bags
// (one recording, in time order), per field. Exit 0 whole, 1 problems, 2 nothing usable.
int SpecInfo(const std::string& spec_path, const std::vector<std::string>& bags,
             const std::string& ns, const std::string& export_path, long max_problems) {
  using namespace msspr::ros_bridge;
  RobotSpec spec;
  try {
    spec = LoadRobotSpec(spec_path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "msspr_bag_info: %s\n", e.what());
    return 2;
  }
  try {
    SpecBagReader reader(spec, bags);
    if (!ns.empty()) reader.set_namespace(ns);
    uint64_t steps = 0, trajectories = 0;
    Export out;
    reader.ForEachEpisode([&](BagEpisode&& ep) {
      for (const auto& [b, e] : ep.Segments()) {
        steps += static_cast<uint64_t>(e - b);
        ++trajectories;
      }
      if (!export_path.empty()) out.Add(ep);
    });
    const SpecBagReport& r = reader.report();
    for (const std::string& path : bags) std::printf("bag:          %s\n", path.c_str());
    std::printf("robot:        %s (%s), control rate %.3g Hz, observation dim %d, action dim %d\n",
                spec.name.c_str(), spec_path.c_str(), spec.control_rate, spec.obs_dim(),
                spec.action_dim());
    std::printf(
        "episodes:     %lu (split by %s), %lu ticks, %lu with observation%s and action -> %lu "
        "trajectories, %lu steps\n",
        static_cast<unsigned long>(r.episodes), spec.episodes.split_by.c_str(),
        static_cast<unsigned long>(r.ticks), static_cast<unsigned long>(r.complete_ticks),
        spec.images.empty() ? "" : ", image", static_cast<unsigned long>(trajectories),
        static_cast<unsigned long>(steps));
    if (r.bags > 1 || r.latched_repeats)
      std::printf(
          "recording:    %lu bags read as one in time order; %lu repeated latched episode "
          "messages ignored\n",
          static_cast<unsigned long>(r.bags), static_cast<unsigned long>(r.latched_repeats));
    // Columns as wide as the longest field name and topic (at least 14 and 22).
    int name_w = 14, topic_w = 22;
    for (const auto& f : r.fields) {
      name_w = std::max(name_w, static_cast<int>(f.name.size()));
      topic_w = std::max(topic_w, static_cast<int>(f.topic.size()));
    }
    std::printf("%-*s %-*s %8s %8s %9s %6s %8s %6s %6s %6s %6s %8s\n", name_w, "field", topic_w,
                "topic", "messages", "rate_hz", "coverage", "gaps", "max_gap", "stale", "late",
                "order", "nan", "unread");
    for (const auto& f : r.fields)
      std::printf("%-*s %-*s %8lu %8.2f %8.1f%% %6lu %7.2fs %6lu %6lu %6lu %6lu %8lu\n", name_w,
                  f.name.c_str(), topic_w, f.topic.c_str(), static_cast<unsigned long>(f.messages),
                  f.rate_hz, 100.0 * f.coverage(), static_cast<unsigned long>(f.gaps), f.max_gap_s,
                  static_cast<unsigned long>(f.stale_ticks), static_cast<unsigned long>(f.late),
                  static_cast<unsigned long>(f.out_of_order),
                  static_cast<unsigned long>(f.nonfinite),
                  static_cast<unsigned long>(f.unreadable + f.bad_images));
    for (const auto& f : r.fields) {
      if (!f.image) continue;
      const auto& im = *std::find_if(spec.images.begin(), spec.images.end(),
                                     [&](const SpecImage& i) { return i.name == f.name; });
      std::printf(
          "image:        %s (topic %s, %s -> %dx%d rgb8): %lu images at %.2f Hz, coverage "
          "%.1f%%, %lu bad images (undecodable, wrong encoding or size) rejected\n",
          f.name.c_str(), f.topic.c_str(), f.type.c_str(), im.size, im.size,
          static_cast<unsigned long>(f.messages), f.rate_hz, 100.0 * f.coverage(),
          static_cast<unsigned long>(f.bad_images));
    }
    // Commands without stamps: where they arrive relative to the ticks (command_alignment.h).
    for (const auto& f : r.fields) {
      if (!f.aligned) continue;
      std::printf(
          "timing:       %s (topic %s, no stamp): %lu commands arrive %+.1f ms after their ticks "
          "(all within %.1f ms of that); %lu ambiguous (over a quarter period off), %lu moved to "
          "a free neighbouring tick, %lu dropped (two for one tick)\n",
          f.name.c_str(), f.topic.c_str(), static_cast<unsigned long>(f.aligned_commands),
          1e3 * f.phase_s, 1e3 * f.spread_s, static_cast<unsigned long>(f.ambiguous),
          static_cast<unsigned long>(f.shifted), static_cast<unsigned long>(f.dropped));
    }
    for (const auto& u : r.usage) std::printf("used:         %s\n", u.c_str());
    std::printf(
        "(coverage: ticks with a fresh value; gaps: stamps more than stale_after = %.3g s "
        "apart;\n"
        " stale: ticks without a fresh value; late: received more than stale_after after the "
        "stamp;\n"
        " order: stamped before the previous message, dropped; nan: NaN/Inf, rejected;\n"
        " unread: messages without a field of the spec, or bad images, rejected)\n",
        spec.stale_after);
    int status = 0;
    if (!r.problems.empty()) {
      status = 1;
      std::fprintf(stderr, "%s: problems reading the bags through it:\n", spec_path.c_str());
      // Every line names the spec, so that a line copied alone still says which.
      std::vector<std::string> lines;
      for (const auto& p : r.problems) lines.push_back(p + " [" + spec_path + "]");
      PrintProblems(lines, max_problems);
    }
    if (!export_path.empty() && steps > 0) {
      out.Write(export_path);
      std::printf(
          "export:       %s: %ld steps, %lu trajectories (observations, actions, terminals, "
          "timestamps%s)\n",
          export_path.c_str(), static_cast<long>(out.steps),
          static_cast<unsigned long>(trajectories), out.image_size ? ", images" : "");
    }
    if (steps == 0) {
      std::fprintf(stderr,
                   "msspr_bag_info: %s extracts no step (an observation and a command at the same "
                   "tick) from these bags\n",
                   spec_path.c_str());
      status = 2;
    }
    return status;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "msspr_bag_info: %s: %s\n", spec_path.c_str(), e.what());
    return 2;
  }
}

const char kUsage[] =
    "usage: msspr_bag_info [--robot SPEC.yaml [--ns NS]] BAG [BAG...] [--max-problems "
    "N]\n"
    "Prints episodes, steps, observation/action dimensions, images and gaps of\n"
    "msspr dataset bags. With --robot: what the robot interface spec extracts from\n"
    "bags of standard messages, per field: coverage, rate, gaps, stale and late\n"
    "samples, stamps out of order, rejected NaN/Inf, and per camera its images'\n"
    "coverage, rate and bad images (undecodable or of a wrong encoding). The bags\n"
    "are one recording in time order (rosbag record --split files join); commands\n"
    "without stamps are timed against the ticks. --ns NS resolves the spec's\n"
    "relative topics under NS (default: the spec's namespace:, else the one\n"
    "namespace of the recording that holds them all).\n"
    "Exit 0: whole; 1: inconsistent; 2: unreadable.\n";

// msspr_bag_info BAG: one msspr dataset bag's episodes, steps, sizes, images, gaps and
// rejected messages. Returns 0 whole, 1 inconsistent; throws on an unreadable bag.
int DatasetInfo(const std::string& path, long max_problems) {
  using namespace msspr::ros_bridge;
  int status = 0;
  DatasetBagReader reader(path);
  std::map<std::string, uint64_t> splits;
  std::set<std::string> envs;
  std::set<int> obs_dims, act_dims, image_sizes;
  uint64_t image_episodes = 0, image_steps = 0;
  int min_len = 0, max_len = 0;
  uint64_t n = 0, sum_len = 0;
  reader.ForEachEpisode([&](BagEpisode&& ep) {
    splits[ep.meta.split]++;
    if (!ep.meta.env.empty()) envs.insert(ep.meta.env);
    if (ep.obs_dim) obs_dims.insert(ep.obs_dim);
    if (ep.act_dim) act_dims.insert(ep.act_dim);
    if (ep.image_size) {
      image_sizes.insert(ep.image_size);
      ++image_episodes;
      for (uint8_t h : ep.has_image) image_steps += h;
    }
    min_len = n == 0 ? ep.num_steps : std::min(min_len, ep.num_steps);
    max_len = std::max(max_len, ep.num_steps);
    sum_len += static_cast<uint64_t>(ep.num_steps);
    ++n;
  });
  const BagReadReport& r = reader.report();
  struct stat st {};
  const double mb = stat(path.c_str(), &st) == 0 ? st.st_size / 1e6 : 0.0;
  auto join = [](const auto& set) {
    std::string s;
    for (const auto& v : set) s += (s.empty() ? "" : ", ") + std::to_string(v);
    return s.empty() ? std::string("-") : s;
  };
  std::string env_s;
  for (const auto& e : envs) env_s += (env_s.empty() ? "" : ", ") + e;
  std::string split_s;
  for (const auto& [k, v] : splits)
    split_s += (split_s.empty() ? "" : ", ") + k + " " + std::to_string(v);
  std::printf("bag:          %s (%.1f MB, %lu messages)\n", path.c_str(), mb,
              static_cast<unsigned long>(r.messages));
  std::printf("env:          %s\n", env_s.empty() ? "-" : env_s.c_str());
  std::printf("episodes:     %lu (%s), %lu complete\n", static_cast<unsigned long>(r.episodes),
              split_s.c_str(), static_cast<unsigned long>(r.complete_episodes));
  std::printf("steps:        %lu (episode length min %d, mean %.1f, max %d)\n",
              static_cast<unsigned long>(r.steps), min_len, n ? double(sum_len) / n : 0.0, max_len);
  std::printf("observation:  dim %s float32 on %s\n", join(obs_dims).c_str(), kObservationTopic);
  std::printf("action:       dim %s float32 on %s\n", join(act_dims).c_str(), kActionTopic);
  if (image_episodes)
    std::printf("images:       %lu episodes, %lu frames, %sx%s rgb8 on %s\n",
                static_cast<unsigned long>(image_episodes), static_cast<unsigned long>(image_steps),
                join(image_sizes).c_str(), join(image_sizes).c_str(), kImageTopic);
  else
    std::printf("images:       none\n");
  const uint64_t gaps = r.missing_observations + r.missing_actions + r.missing_images;
  if (gaps == 0 && r.duplicates == 0)
    std::printf("gaps:         none\n");
  else
    std::printf(
        "gaps:         %lu missing observations, %lu missing actions, %lu missing images, %lu "
        "duplicates\n",
        static_cast<unsigned long>(r.missing_observations),
        static_cast<unsigned long>(r.missing_actions), static_cast<unsigned long>(r.missing_images),
        static_cast<unsigned long>(r.duplicates));
  const uint64_t rejected =
      r.out_of_range_steps + r.nonfinite_observations + r.nonfinite_actions + r.bad_images;
  if (rejected > 0)
    std::printf(
        "rejected:     %lu steps out of range, %lu observations and %lu actions with NaN/Inf, "
        "%lu bad images\n",
        static_cast<unsigned long>(r.out_of_range_steps),
        static_cast<unsigned long>(r.nonfinite_observations),
        static_cast<unsigned long>(r.nonfinite_actions), static_cast<unsigned long>(r.bad_images));
  const bool mixed = obs_dims.size() > 1 || act_dims.size() > 1 || image_sizes.size() > 1;
  if (!r.problems.empty() || mixed) {
    status = 1;
    std::fprintf(stderr, "%s: inconsistent dataset bag:\n", path.c_str());
    if (mixed) std::fprintf(stderr, "  episodes disagree on observation/action/image sizes\n");
    PrintProblems(r.problems, max_problems);
  }
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace msspr::ros_bridge;
  std::vector<std::string> bags;
  long max_problems = 20;
  std::string robot, ns, export_path;
  try {
    CliArgs args(argc, argv, {"help"}, {"max-problems", "robot", "ns", "export"});
    bags = args.positional();
    max_problems = args.GetInt("max-problems", 20, 0, 1000000);
    robot = args.Get("robot", "");
    ns = args.Get("ns", "");
    export_path = args.Get("export", "");
    if (!ns.empty() && robot.empty()) throw CliError("--ns is for --robot's topics");
    if (!export_path.empty() && robot.empty())
      throw CliError("--export writes what --robot's spec extracts: give --robot SPEC.yaml");
    if (args.Has("help") || bags.empty()) {
      std::cout << kUsage;
      return bags.empty() && !args.Has("help") ? 2 : 0;
    }
  } catch (const std::exception& e) {
    std::cerr << "msspr_bag_info: " << e.what() << "\n";
    return 2;
  }
  ros::Time::init();
  if (!robot.empty()) return SpecInfo(robot, bags, ns, export_path, max_problems);
  int status = 0;
  for (const std::string& path : bags) {
    try {
      status = std::max(status, DatasetInfo(path, max_problems));
    } catch (const std::exception& e) {
      std::fprintf(stderr, "msspr_bag_info: %s\n", e.what());
      status = 2;
    }
  }
  return status;
}
