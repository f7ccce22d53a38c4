// In-memory puzzle-3x3-play / puzzle-4x4-play episode collection: the puzzle's play oracle
// (PuzzlePlayOracle) on a collection reset, rows as cube-single's (cube_dataset.h).
#pragma once

#include <cstdint>

#include "msspr_sim/cube_dataset.h"
#include "msspr_sim/puzzle_env.h"
#include "msspr_sim/puzzle_oracle.h"

namespace msspr::sim {

using PuzzleCollectOptions = PlayCollectOptions<PuzzleOracleOptions>;

// Collects episode `index`: env.ResetForCollection(EpisodeSeed(seed, index)), the play
// oracle seeded from it; observations [length, 19 + 4 N], actions [length, 5], qpos and
// qvel [length, 8 + N]. Replaying the stored actions from the same reset reproduces the
// rows. Throws std::invalid_argument if episode_length < 1 or images are asked of a
// non-rendering env.
PlayEpisode CollectPuzzleEpisode(PuzzleEnv& env, const PuzzleCollectOptions& options,
                                 uint64_t index);

}  // namespace msspr::sim
