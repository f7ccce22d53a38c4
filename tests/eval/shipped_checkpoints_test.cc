// The shipped state checkpoints of the ant and the arm's scene (msspr_policy_node/checkpoints/,
// served by MSSPR_DEMO_ENV=antmaze-medium|scene make demo) are Ms.PR's and reach the goals of
// their env's task 1 in its simulator, in process by OGBench's protocol.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <string>

#include "msspr_core/policy.h"
#include "msspr_eval/ant_evaluator.h"
#include "msspr_eval/arm_task_evaluator.h"
#include "msspr_sim/package_files.h"

namespace msspr::agent {
namespace {

// msspr_policy_node/checkpoints/NAME, checked to be a Ms.PR state policy of these sizes.
core::Policy LoadShipped(const std::string& name, int obs_dim, int action_dim) {
  torch::set_num_threads(1);
  auto policy = core::Policy::Load(sim::PackageFile("msspr_policy_node/checkpoints/" + name));
  EXPECT_EQ(policy.agent_name(), "mspr") << name;
  EXPECT_EQ(policy.obs_dim(), obs_dim) << name;
  EXPECT_EQ(policy.action_dim(), action_dim) << name;
  return policy;
}

// antmaze-medium-state.pt (with the subgoal policy). Task 1, (1,1) -> (6,6): 60% over 50
// episodes when it was shipped; here 10.
TEST(ShippedAntCheckpoint, IsMsprAndReachesAntmazeMediumTask1Goals) {
  auto policy = LoadShipped("antmaze-medium-state.pt", 29, 8);
  EXPECT_EQ(policy.options().agent.subgoal_steps, 25);
  AntEvalOptions o;
  o.tasks = {1};
  o.episodes = 10;
  const AntEvalResult r = EvaluateOnAntMaze(policy, o);
  ASSERT_EQ(r.success.size(), 1u);
  EXPECT_GE(r.success[0], 0.2) << "task 1 over 10 episodes";
  EXPECT_GT(r.mean_steps_success[0], 0.0);
}

// scene-state.pt. Task 1 ("open": the drawer and the window opened) over the first 10
// episodes of --seed 0: 70% (109 steps on average) when it was shipped.
TEST(ShippedSceneCheckpoint, IsMsprAndOpensTheDrawerAndWindow) {
  auto policy = LoadShipped("scene-state.pt", 40, 5);
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
