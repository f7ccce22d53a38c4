// The shipped scene checkpoint (msspr_policy_node/checkpoints/scene-state.pt, served by
// MSSPR_DEMO_ENV=scene make demo) solves the scene's task 1 ("open": the drawer and the window
// opened) in the arm simulator, in process by OGBench's protocol; it is Ms.PR's.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include "msspr_core/policy.h"
#include "msspr_eval/arm_task_evaluator.h"
#include "msspr_sim/package_files.h"

namespace msspr::agent {
namespace {

// Task 1 over the first 10 episodes of --seed 0: 70% (109 steps on average) when it was shipped.
TEST(ShippedSceneCheckpoint, IsMsprAndOpensTheDrawerAndWindow) {
  torch::set_num_threads(1);
  auto policy =
      core::Policy::Load(sim::PackageFile("msspr_policy_node/checkpoints/scene-state.pt"));
  EXPECT_EQ(policy.agent_name(), "mspr");
  EXPECT_EQ(policy.obs_dim(), 40);
  EXPECT_EQ(policy.action_dim(), 5);
  ArmTaskEvalOptions o;
  o.tasks = {1};
  o.episodes = 10;
  const ArmTaskEvalResult r = EvaluateOnScene(policy, o);
  ASSERT_EQ(r.success.size(), 1u);
  EXPECT_GE(r.success[0], 0.3) << "task 1 over 10 episodes";
  EXPECT_GT(r.mean_steps_success[0], 0.0);
  EXPECT_LT(r.mean_steps_success[0], 750.0);
}

}  // namespace
}  // namespace msspr::agent
