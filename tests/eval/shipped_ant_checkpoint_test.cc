// The shipped antmaze-medium checkpoint (msspr_policy_node/checkpoints/antmaze-medium-state.pt,
// served by MSSPR_DEMO_ENV=antmaze-medium make demo) reaches goals of antmaze-medium in the
// ant simulator, in process by OGBench's protocol; it is Ms.PR's, with the subgoal policy.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "msspr_core/policy.h"
#include "msspr_eval/ant_evaluator.h"
#include "msspr_sim/package_files.h"

namespace msspr::agent {
namespace {

// Task 1, (1,1) -> (6,6): 60% over 50 episodes when it was shipped; here 10.
TEST(ShippedAntCheckpoint, IsMsprAndReachesAntmazeMediumTask1Goals) {
  torch::set_num_threads(1);
  auto policy =
      core::Policy::Load(sim::PackageFile("msspr_policy_node/checkpoints/antmaze-medium-state.pt"));
  EXPECT_EQ(policy.agent_name(), "mspr");
  EXPECT_EQ(policy.options().agent.subgoal_steps, 25);
  EXPECT_EQ(policy.obs_dim(), 29);
  EXPECT_EQ(policy.action_dim(), 8);
  AntEvalOptions o;
  o.tasks = {1};
  o.episodes = 10;
  const AntEvalResult r = EvaluateOnAntMaze(policy, o);
  ASSERT_EQ(r.success.size(), 1u);
  EXPECT_GE(r.success[0], 0.2) << "task 1 over 10 episodes";
  EXPECT_GT(r.mean_steps_success[0], 0.0);
}

}  // namespace
}  // namespace msspr::agent
