#include "msspr_sim/cube_dataset.h"

#include <stdexcept>

#include "msspr_sim/expert.h"
#include "msspr_sim/random_util.h"

namespace msspr::sim {
namespace {

// Separates the oracle's random stream from the reset's.
constexpr uint64_t kOracleSalt = 0x6F7261636C65ULL;  // "oracle"

}  // namespace

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
  CubePlayOracle oracle(Mix64(ep.seed ^ kOracleSalt), options.oracle);
  const size_t n = static_cast<size_t>(ep.length);
  ep.observations.reserve(n * CubeEnv::kObservationSize);
  ep.actions.reserve(n * CubeEnv::kActionSize);
  for (int t = 0; t < ep.length; ++t) {
    const CubeEnv::Observation o = env.GetObservation();
    ep.observations.insert(ep.observations.end(), o.begin(), o.end());
    const std::vector<double> qpos = env.Qpos(), qvel = env.Qvel();
    ep.qpos.insert(ep.qpos.end(), qpos.begin(), qpos.end());
    ep.qvel.insert(ep.qvel.end(), qvel.begin(), qvel.end());
    if (options.images) {
      const std::vector<uint8_t> rgb = env.Render();
      ep.images.insert(ep.images.end(), rgb.begin(), rgb.end());
    }
    const CubeEnv::Action raw = oracle.Act(env);
    CubeEnv::Action sent;
    for (int i = 0; i < CubeEnv::kActionSize; ++i) {
      const float a = RoundToFloat(raw[i]);
      ep.actions.push_back(a);
      sent[i] = a;
    }
    if (t + 1 < ep.length) env.Step(sent);
  }
  return ep;
}

}  // namespace msspr::sim
