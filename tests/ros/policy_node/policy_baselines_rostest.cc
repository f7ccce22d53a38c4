// rostest of msspr_policy_node serving a baseline agent's export
// (tests/ros/policy_node/policy_serves_{gcbc,hiql}.test): its diagnostics name the agent,
// and its actions are those of the same export loaded in process.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "msspr_core/policy.h"
#include "policy_client.h"

namespace msspr::testing {
namespace {

TEST(PolicyServesBaseline, ActionsMatchTheExportInProcess) {
  ros::NodeHandle pnh("~");
  std::string agent, checkpoint;
  ASSERT_TRUE(pnh.getParam("agent", agent)) << "~agent not set";
  ASSERT_TRUE(pnh.getParam("checkpoint", checkpoint)) << "~checkpoint not set";
  core::Policy reference = core::Policy::Load(checkpoint);
  ASSERT_EQ(reference.agent_name(), agent);
  PolicyClient c;
  ASSERT_TRUE(c.WaitForPolicy()) << "policy node not up";
  EXPECT_EQ(c.helper().DiagValue(kPolicyStatus, "agent"), agent);
  const std::vector<std::vector<float>> states{{0.f, 0.f}, {1.5f, -2.f}, {-3.f, 4.f}};
  const std::vector<std::vector<float>> goals{{4.f, 0.f}, {-1.f, 2.5f}, {0.5f, 0.5f}};
  uint32_t step = 0;
  std::vector<std::vector<float>> seen;
  for (const auto& s : states) {
    for (const auto& g : goals) {
      c.SendObservation(1, step, s, g);
      const msspr::Action::ConstPtr a = c.WaitForAction(1, step, 10.0);
      ASSERT_TRUE(a) << "no action for step " << step;
      ExpectValidAction(*a);
      const std::vector<float> expected = reference.Act(s, g);
      ASSERT_EQ(a->action.size(), expected.size());
      for (size_t k = 0; k < expected.size(); ++k)
        EXPECT_NEAR(a->action[k], expected[k], 1e-5) << agent << " step " << step << " dim " << k;
      seen.push_back(a->action);
      ++step;
    }
  }
  // Goal-conditioned: not every (state, goal) pair gets the same action.
  bool differ = false;
  for (const auto& a : seen)
    differ |= std::abs(a[0] - seen[0][0]) + std::abs(a[1] - seen[0][1]) > 1e-6;
  EXPECT_TRUE(differ) << "every input got the same action";
}

}  // namespace
}  // namespace msspr::testing

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "msspr_policy_baselines_rostest", ros::init_options::AnonymousName);
  ros::Time::init();
  return RUN_ALL_TESTS();
}
