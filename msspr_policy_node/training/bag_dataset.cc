#include "bag_dataset.h"

#include <memory>
#include <sstream>

#include "msspr_bags/dataset_bag.h"
#include "msspr_robot_interface/spec_bag.h"

namespace msspr::agent {

bool IsBagPath(const std::string& path) {
  return path.size() >= 4 && path.compare(path.size() - 4, 4, ".bag") == 0;
}

std::string BagLoadReport::Summary() const {
  std::ostringstream s;
  s << bags << " bag(s): " << episodes << " episodes read -> " << trajectories << " trajectories, "
    << steps << " steps";
  if (episodes_other_split)
    s << "; " << episodes_other_split << " episodes of another split skipped";
  if (episodes_without_images)
    s << "; " << episodes_without_images << " episodes without images skipped";
  if (incomplete_episodes)
    s << "; " << incomplete_episodes << " incomplete episodes (" << missing_observations
      << " missing observations, " << missing_actions << " missing actions, " << missing_images
      << " missing images, " << duplicates << " conflicting duplicates; " << dropped_steps
      << " steps dropped, gaps split trajectories)";
  return s.str();
}

namespace {

// The episode's complete runs of steps (without images requested, its image gaps do not
// split it) into `builder`, each a trajectory, but those shorter than min_segment_steps.
// Returns the steps kept.
int AddSegments(ros_bridge::BagEpisode& ep, const BagLoadOptions& options, int obs_dim, int act_dim,
                int image_size, core::DatasetBuilder* builder, BagLoadReport* r) {
  std::vector<std::pair<int, int>> runs;
  if (options.images) {
    runs = ep.Segments();
  } else {
    const int saved = ep.image_size;
    ep.image_size = 0;
    runs = ep.Segments();
    ep.image_size = saved;
  }
  const size_t image_bytes = static_cast<size_t>(image_size) * image_size * 3;
  int kept = 0;
  for (const auto& [b, e] : runs) {
    const int T = e - b;
    if (T < options.min_segment_steps) {
      ++r->short_segments;
      continue;
    }
    builder->AddEpisode(ep.observations.data() + static_cast<size_t>(b) * obs_dim,
                        ep.actions.data() + static_cast<size_t>(b) * act_dim, T,
                        options.images ? ep.images.data() + b * image_bytes : nullptr);
    ++r->trajectories;
    r->steps += static_cast<uint64_t>(T);
    kept += T;
  }
  return kept;
}

}  // namespace

core::Dataset LoadBagDataset(const std::vector<std::string>& bags, const BagLoadOptions& options,
                             BagLoadReport* report) {
  BagLoadReport local;
  BagLoadReport& r = report ? *report : local;
  r = BagLoadReport{};
  std::unique_ptr<core::DatasetBuilder> builder;
  int obs_dim = 0, act_dim = 0, image_size = 0;
  std::string first_bag;
  // Steps in all the bags (every split), from their indexes: the builder
  // reserves them once. Growing by doubling would need twice the memory of
  // the images at its peak (a 1.1M-frame image dataset is 13.5 GB).
  std::vector<std::unique_ptr<ros_bridge::DatasetBagReader>> readers;
  std::vector<std::unique_ptr<ros_bridge::SpecBagReader>> spec_readers;
  uint64_t total_observations = 0;
  if (options.robot) {
    // A robot's bags are one recording (rosbag record --split files): one reader for all.
    spec_readers.push_back(std::make_unique<ros_bridge::SpecBagReader>(*options.robot, bags));
    if (!options.ns.empty()) spec_readers.back()->set_namespace(options.ns);
    total_observations = spec_readers.back()->CountObservations();
  }
  for (const std::string& path : bags) {
    if (!options.robot) {
      readers.push_back(std::make_unique<ros_bridge::DatasetBagReader>(path));
      total_observations += readers.back()->CountObservations();
    }
  }
  for (size_t bag_index = 0; bag_index < bags.size(); ++bag_index) {
    if (options.robot && bag_index > 0) break;  // (the one reader read them all)
    const std::string& path = bags[bag_index];
    r.bags += options.robot ? bags.size() : 1;
    auto add = [&](ros_bridge::BagEpisode&& ep) {
      ++r.episodes;
      if (options.robot) {  // ticks without fresh inputs (the dataset reader counts its own)
        for (int t = 0; t < ep.num_steps; ++t) {
          r.missing_observations += ep.has_obs[t] ? 0 : 1;
          r.missing_actions += ep.has_action[t] ? 0 : 1;
          r.missing_images += options.images && ep.image_size && !ep.has_image[t] ? 1 : 0;
        }
      }
      if (!options.split.empty() && ep.meta.split != options.split) {
        ++r.episodes_other_split;
        return;
      }
      if (options.images && ep.image_size == 0) {
        ++r.episodes_without_images;
        return;
      }
      if (ep.num_steps == 0) return;
      if (!builder) {
        obs_dim = ep.obs_dim;
        act_dim = ep.act_dim;
        image_size = options.images ? ep.image_size : 0;
        first_bag = path;
        r.env = ep.meta.env;
        core::ImageShape shape;
        if (options.images) shape = core::ImageShape{image_size, image_size, 3};
        builder = std::make_unique<core::DatasetBuilder>(obs_dim, act_dim, shape);
        builder->Reserve(static_cast<int64_t>(total_observations));
      }
      if (ep.obs_dim != obs_dim || ep.act_dim != act_dim ||
          (options.images && ep.image_size != image_size)) {
        std::ostringstream msg;
        msg << path << ": episode " << ep.meta.episode_id << " has observation/action/image sizes "
            << ep.obs_dim << "/" << ep.act_dim << "/" << ep.image_size << ", but " << first_bag
            << " had " << obs_dim << "/" << act_dim << "/" << image_size;
        throw core::DatasetError(msg.str());
      }
      if (!ep.complete()) {
        ++r.incomplete_episodes;
        for (const auto& p : ep.problems) r.problems.push_back(path + ": " + p);
      }
      const int kept = AddSegments(ep, options, obs_dim, act_dim, image_size, builder.get(), &r);
      r.dropped_steps += static_cast<uint64_t>(ep.num_steps - kept);
    };
    if (options.robot) {
      ros_bridge::SpecBagReader& reader = *spec_readers[0];
      reader.ForEachEpisode(add);
      // Problems of whole topics (out of order, NaN / Inf) are not episode problems.
      for (const auto& p : reader.report().problems)
        if (p.find(": episode ") == std::string::npos) r.problems.push_back(p);
      for (const auto& u : reader.report().usage) r.usage.push_back(u);
      continue;
    }
    ros_bridge::DatasetBagReader& reader = *readers[bag_index];
    reader.ForEachEpisode(add);
    const auto& rr = reader.report();
    r.missing_observations += rr.missing_observations;
    r.missing_actions += rr.missing_actions;
    r.missing_images += options.images ? rr.missing_images : 0;
    r.duplicates += rr.duplicates;
  }
  if (!builder || builder->size() == 0) {
    std::string list;
    for (const auto& b : bags) list += (list.empty() ? "" : ", ") + b;
    throw core::DatasetError("no " +
                             (options.split.empty() ? std::string("") : options.split + " ") +
                             "episodes" + (options.images ? " with images" : "") + " in " + list);
  }
  return builder->Build();
}

}  // namespace msspr::agent
