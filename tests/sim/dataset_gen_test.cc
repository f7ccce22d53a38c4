#include "msspr_sim/dataset_gen.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace msspr::sim {
namespace {

TEST(DatasetGenTest, EpisodeLayoutAndDeterminism) {
  PointMazeOptions eo;
  PointMaze env(eo);
  CollectOptions o;
  o.seed = 17;
  const Episode a = CollectEpisode(env, o, 3);
  EXPECT_EQ(a.index, 3u);
  EXPECT_EQ(a.seed, EpisodeSeed(17, 3));
  EXPECT_EQ(a.length, 1001);
  EXPECT_EQ(a.observations.size(), 2002u);
  EXPECT_EQ(a.actions.size(), 2002u);
  EXPECT_TRUE(a.images.empty());
  EXPECT_FLOAT_EQ(a.observations[0], static_cast<float>(a.start.x()));
  EXPECT_FLOAT_EQ(a.observations[1], static_cast<float>(a.start.y()));
  CollectEpisode(env, o, 5);  // the env's history must not matter
  const Episode b = CollectEpisode(env, o, 3);
  EXPECT_EQ(a.observations, b.observations);
  EXPECT_EQ(a.actions, b.actions);
  EXPECT_EQ(a.goal, b.goal);
  PointMaze fresh(eo);
  EXPECT_EQ(CollectEpisode(fresh, o, 3).observations, a.observations);
  const Episode c = CollectEpisode(env, o, 4);
  EXPECT_NE(a.observations, c.observations);
  o.seed = 18;
  EXPECT_NE(CollectEpisode(env, o, 3).observations, a.observations);
  for (float v : a.actions) ASSERT_LE(std::abs(v), 1.0f);
}

TEST(DatasetGenTest, StoredActionsReplayTheObservations) {
  PointMazeOptions eo;
  eo.maze = "large";
  PointMaze env(eo);
  CollectOptions o;
  o.maze = "large";
  o.kind = DatasetKind::kStitch;
  o.episode_length = 201;
  const Episode ep = CollectEpisode(env, o, 0);
  PointMaze replay(eo);
  replay.Reset(ep.start, ep.goal);
  for (int t = 0; t + 1 < ep.length; ++t) {
    const Eigen::Vector2d s = replay.Step({ep.actions[2 * t], ep.actions[2 * t + 1]});
    ASSERT_EQ(static_cast<float>(s.x()), ep.observations[2 * (t + 1)]) << t;
    ASSERT_EQ(static_cast<float>(s.y()), ep.observations[2 * (t + 1) + 1]) << t;
  }
}

TEST(DatasetGenTest, ImagesAreDeterministic) {
  PointMazeOptions eo;
  eo.enable_rendering = true;
  PointMaze env(eo);
  CollectOptions o;
  o.episode_length = 40;
  o.images = true;
  const Episode a = CollectEpisode(env, o, 1);
  ASSERT_EQ(a.images.size(), 40u * 64 * 64 * 3);
  const Episode b = CollectEpisode(env, o, 1);
  EXPECT_EQ(a.images, b.images);
  EXPECT_EQ(a.observations, b.observations);
  // Images do not change the trajectory.
  PointMaze plain{PointMazeOptions{}};
  o.images = false;
  EXPECT_EQ(CollectEpisode(plain, o, 1).observations, a.observations);
}

TEST(DatasetGenTest, BadOptionsThrow) {
  PointMaze env{PointMazeOptions{}};
  CollectOptions o;
  o.maze = "large";
  EXPECT_THROW(CollectEpisode(env, o, 0), std::invalid_argument);
  o.maze = "medium";
  o.images = true;
  EXPECT_THROW(CollectEpisode(env, o, 0), std::invalid_argument);
  o.images = false;
  o.episode_length = 0;
  EXPECT_THROW(CollectEpisode(env, o, 0), std::invalid_argument);
}

}  // namespace
}  // namespace msspr::sim
