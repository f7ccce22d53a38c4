#include "msspr_sim/dataset_gen.h"

#include <algorithm>
#include <stdexcept>

#include "msspr_sim/random_util.h"  // RoundToFloat

namespace msspr::sim {

Episode CollectEpisode(PointMaze& env, const CollectOptions& options, uint64_t index) {
  if (env.map().name() != options.maze) {
    throw std::invalid_argument("CollectEpisode: env maze '" + env.map().name() +
                                "' differs from options.maze '" + options.maze + "'");
  }
  if (options.episode_length < 1) {
    throw std::invalid_argument("CollectEpisode: episode_length must be >= 1");
  }
  if (options.images && !env.options().enable_rendering) {
    throw std::invalid_argument("CollectEpisode: images need a PointMaze with enable_rendering");
  }
  Episode ep;
  ep.index = index;
  ep.seed = EpisodeSeed(options.seed, index);
  ep.length = options.episode_length;
  const size_t n = static_cast<size_t>(ep.length);
  const size_t image_bytes =
      static_cast<size_t>(env.options().image_size) * env.options().image_size * 3;
  ep.observations.resize(n * 2);
  ep.actions.resize(n * 2);
  if (options.images) ep.images.resize(n * image_bytes);

  Eigen::Vector2d s = env.ResetRandom(ep.seed);
  ep.start = s;
  ep.goal = env.goal();
  CollectionExpert expert(env.map(), options.kind, options.noise_std, ep.seed);
  for (size_t t = 0; t < n; ++t) {
    // Stored as float32 and stepped with exactly the stored value (a ROS
    // Action carries float32 too), so a replay of the data reproduces it. The
    // expert sees the float32 state, as the expert node does over ROS.
    const float sx = RoundToFloat(s.x()), sy = RoundToFloat(s.y());
    const Eigen::Vector2d raw = expert.Act(Eigen::Vector2d(sx, sy));
    const float ax = RoundToFloat(raw.x()), ay = RoundToFloat(raw.y());
    const Eigen::Vector2d a(static_cast<double>(ax), static_cast<double>(ay));
    ep.observations[2 * t] = sx;
    ep.observations[2 * t + 1] = sy;
    ep.actions[2 * t] = ax;
    ep.actions[2 * t + 1] = ay;
    if (options.images) env.Render(ep.images.data() + t * image_bytes);
    if (t + 1 < n) s = env.Step(a);
  }
  return ep;
}

}  // namespace msspr::sim
