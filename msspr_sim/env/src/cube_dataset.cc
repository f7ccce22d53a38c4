#include "msspr_sim/cube_dataset.h"

#include <stdexcept>

#include "msspr_sim/expert.h"
#include "msspr_sim/random_util.h"
#include "play_recording.h"

namespace msspr::sim {

CubeEpisode CollectCubeEpisode(CubeEnv& env, const CubeCollectOptions& options, uint64_t index) {
  if (options.episode_length < 1)
    throw std::invalid_argument("CollectCubeEpisode: episode_length must be >= 1");
  if (options.images && !env.options().enable_rendering)
    throw std::invalid_argument("CollectCubeEpisode: images need an env with enable_rendering");
  CubeEpisode ep;
  ep.index = index;
  ep.seed = EpisodeSeed(options.seed, index);
  ep.length = options.episode_length;
  env.ResetForCollection(ep.seed);
  CubePlayOracle oracle(Mix64(ep.seed ^ internal::kOracleSalt), options.oracle);
  internal::RecordPlayEpisode(env, oracle, options.images, &ep);
  return ep;
}

}  // namespace msspr::sim
