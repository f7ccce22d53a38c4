// Internal: the row loop of the play datasets (cube-single, the puzzles), one piece for
// every manipulation env and its play oracle.
#ifndef MSSPR_SIM_SRC_PLAY_RECORDING_H_
#define MSSPR_SIM_SRC_PLAY_RECORDING_H_

#include <cstdint>
#include <vector>

#include "msspr_sim/cube_dataset.h"
#include "msspr_sim/random_util.h"

namespace msspr::sim::internal {

// Separates an oracle's random stream from its episode's reset.
constexpr uint64_t kOracleSalt = 0x6F7261636C65ULL;  // "oracle"

// Records ep->length rows of `env` from its current state: each row's observation, qpos,
// qvel (and image), then the oracle's action rounded to float32, stored and (but for the
// last row) stepped with exactly the stored value, so that replaying the stored actions
// from the same reset reproduces the rows.
template <class Env, class Oracle>
void RecordPlayEpisode(Env& env, Oracle& oracle, bool images, PlayEpisode* ep) {
  const size_t n = static_cast<size_t>(ep->length);
  constexpr int kActions = Env::kActionSize;
  ep->actions.reserve(n * kActions);
  for (int t = 0; t < ep->length; ++t) {
    const auto o = env.GetObservation();
    if (t == 0) ep->observations.reserve(n * o.size());
    ep->observations.insert(ep->observations.end(), o.begin(), o.end());
    const std::vector<double> qpos = env.Qpos(), qvel = env.Qvel();
    ep->qpos.insert(ep->qpos.end(), qpos.begin(), qpos.end());
    ep->qvel.insert(ep->qvel.end(), qvel.begin(), qvel.end());
    if (images) {
      const std::vector<uint8_t> rgb = env.Render();
      ep->images.insert(ep->images.end(), rgb.begin(), rgb.end());
    }
    const typename Env::Action raw = oracle.Act(env);
    typename Env::Action sent;
    for (int i = 0; i < kActions; ++i) {
      const float a = RoundToFloat(raw[i]);
      ep->actions.push_back(a);
      sent[i] = a;
    }
    if (t + 1 < ep->length) env.Step(sent);
  }
}

}  // namespace msspr::sim::internal

#endif  // MSSPR_SIM_SRC_PLAY_RECORDING_H_
