// In-memory cube-single-play episode collection: the play oracle on a
// collection reset, rows as OGBench's generate_manipspace.py stores them
// (OGBench's manipspace play data).
#pragma once

#include <cstdint>
#include <vector>

#include "msspr_sim/cube_env.h"
#include "msspr_sim/cube_oracle.h"

namespace msspr::sim {

// How a play dataset is collected (cube-single, cube-double, the puzzles), with the options of
// its play oracle.
template <class OracleOptions>
struct PlayCollectOptions {
  int episode_length = 1001;  // rows per episode (OGBench: 1001)
  bool images = false;        // needs a rendering env
  uint64_t seed = 0;          // base seed; episode k uses EpisodeSeed(seed, k)
  OracleOptions oracle;
};
using CubeCollectOptions = PlayCollectOptions<CubePlayOracleOptions>;

// One play episode (cube-single, the puzzles); every row holds the state before its action.
struct PlayEpisode {
  uint64_t index = 0, seed = 0;
  int length = 0;
  std::vector<float> observations;  // [length, obs dim] float32 (28 for cube-single)
  // [length, 5] float32 in [-1, 1]: the clipped action sent; the last row's
  // action is recorded but not stepped (OGBench's last row is terminal).
  std::vector<float> actions;
  std::vector<double> qpos;     // [length, nq] (cube-single 15: arm 6, fingers 2, cube 7)
  std::vector<double> qvel;     // [length, nv] (cube-single 14)
  std::vector<uint8_t> images;  // [length, S, S, 3] uint8 if images, else empty
};
using CubeEpisode = PlayEpisode;

// Collects episode `index`: env.ResetForCollection(EpisodeSeed(seed, index)),
// CubePlayOracle(EpisodeSeed(seed, index) ^ salt); for each row the oracle's
// action is rounded to float32, stored, and (but for the last row) stepped
// with exactly the stored value, so replaying the stored actions from the
// same reset reproduces the stored rows. Throws std::invalid_argument if
// episode_length < 1 or images are asked of a non-rendering env.
CubeEpisode CollectCubeEpisode(CubeEnv& env, const CubeCollectOptions& options, uint64_t index);

}  // namespace msspr::sim
