#include "msspr_sim/puzzle_dataset.h"

#include <stdexcept>

#include "msspr_sim/expert.h"  // EpisodeSeed
#include "play_recording.h"

namespace msspr::sim {

PlayEpisode CollectPuzzleEpisode(PuzzleEnv& env, const PuzzleCollectOptions& options,
                                 uint64_t index) {
  if (options.episode_length < 1)
    throw std::invalid_argument("CollectPuzzleEpisode: episode_length must be >= 1");
  if (options.images && !env.options().enable_rendering)
    throw std::invalid_argument("CollectPuzzleEpisode: images need an env with enable_rendering");
  PlayEpisode ep;
  ep.index = index;
  ep.seed = EpisodeSeed(options.seed, index);
  ep.length = options.episode_length;
  env.ResetForCollection(ep.seed);
  PuzzlePlayOracle oracle(Mix64(ep.seed ^ internal::kOracleSalt), options.oracle);
  internal::RecordPlayEpisode(env, oracle, options.images, &ep);
  return ep;
}

}  // namespace msspr::sim
