#include "msspr_sim/cube_dataset.h"

#include <gtest/gtest.h>

#include <string>

#include "cube_test_util.h"

namespace msspr::sim {
namespace {

TEST(CubeDatasetTest, RowsAreTheStateBeforeEachAction) {
  CubeEnv env(testing_util::CubeOptions());
  CubeCollectOptions o;
  o.episode_length = 120;
  o.seed = 9;
  const CubeEpisode ep = CollectCubeEpisode(env, o, 3);
  ASSERT_EQ(ep.observations.size(), 120u * 28);
  ASSERT_EQ(ep.actions.size(), 120u * 5);
  ASSERT_EQ(ep.qpos.size(), 120u * 15);
  ASSERT_EQ(ep.qvel.size(), 120u * 14);
  EXPECT_TRUE(ep.images.empty());
  for (float a : ep.actions) ASSERT_TRUE(a >= -1.0f && a <= 1.0f);
  // The observation's arm joints and cube position are the row's qpos.
  for (int t = 0; t < ep.length; ++t) {
    for (int i = 0; i < 6; ++i)
      EXPECT_EQ(ep.observations[t * 28 + i], static_cast<float>(ep.qpos[t * 15 + i]));
    EXPECT_NEAR(ep.observations[t * 28 + 19], 10 * (ep.qpos[t * 15 + 8] - 0.425), 1e-5);
  }
  // Same seed and index, same episode; another index, another one.
  CubeEnv other(testing_util::CubeOptions());
  const CubeEpisode again = CollectCubeEpisode(other, o, 3);
  EXPECT_EQ(again.observations, ep.observations);
  EXPECT_EQ(again.actions, ep.actions);
  EXPECT_NE(CollectCubeEpisode(other, o, 4).observations, ep.observations);

  // Replaying the stored actions from the same reset reproduces every row.
  other.ResetForCollection(ep.seed);
  for (int t = 0; t < ep.length; ++t) {
    const CubeEnv::Observation obs = other.GetObservation();
    ASSERT_TRUE(std::equal(obs.begin(), obs.end(), ep.observations.begin() + t * 28))
        << "row " << t;
    if (t + 1 < ep.length) {
      CubeEnv::Action a;
      for (int i = 0; i < 5; ++i) a[i] = ep.actions[t * 5 + i];
      other.Step(a);
    }
  }
  o.images = true;
  EXPECT_THROW(CollectCubeEpisode(env, o, 0), std::invalid_argument);
  o.images = false;
  o.episode_length = 0;
  EXPECT_THROW(CollectCubeEpisode(env, o, 0), std::invalid_argument);
}

TEST(CubeDatasetTest, ImagesAreStoredPerRow) {
  CubeEnvOptions eo = testing_util::CubeOptions();
  eo.enable_rendering = true;
  eo.scene.pixel_style = true;
  CubeEnv env(eo);
  CubeCollectOptions o;
  o.episode_length = 5;
  o.images = true;
  const CubeEpisode ep = CollectCubeEpisode(env, o, 0);
  ASSERT_EQ(ep.images.size(), 5u * 64 * 64 * 3);
  const std::vector<uint8_t> last(ep.images.end() - 64 * 64 * 3, ep.images.end());
  EXPECT_EQ(env.Render(), last) << "the last row's image is the final state";
}

}  // namespace
}  // namespace msspr::sim
