// msspr_collect --env cube-single (and puzzle-3x3 / puzzle-4x4): the bag it writes has the
// dataset layout, the play dataset's dimensions and splits, and its stored actions,
// replayed from each episode's collection reset, reproduce its stored observations bit for
// bit. Also usage errors. No master needed.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "msspr_bags/dataset_bag.h"
#include "msspr_sim/cube_double_env.h"
#include "msspr_sim/cube_env.h"
#include "msspr_sim/package_files.h"
#include "msspr_sim/puzzle_env.h"
#include "msspr_sim/scene_env.h"

namespace msspr::ros_bridge {
namespace {

std::string TempPath(const std::string& name) {
  return "/tmp/msspr_cube_test_" + std::to_string(getpid()) + "_" + name;
}

// msspr_collect ARGS to its end (test::RunTool): the exit status, and its output into *output.
int RunCollect(const std::string& args, std::string* output = nullptr) {
  const test::ToolOutput r = test::RunTool(std::string(MSSPR_COLLECT_EXE) + " " + args, 280);
  if (output != nullptr) *output = r.text;
  return r.status;
}

TEST(CubeCollect, WritesPlayDatasetThatReplays) {
  const std::string bag = TempPath("play.bag");
  std::string out;
  ASSERT_EQ(RunCollect(
                "--env cube-single --episodes 2 --val-episodes 1 --length 60 --seed 3 --out " + bag,
                &out),
            0)
      << out;
  EXPECT_NE(out.find("2 train + 1 val episodes of 60 steps"), std::string::npos) << out;
  EXPECT_NE(out.find("steps/s"), std::string::npos) << out;

  sim::CubeEnvOptions eo;
  eo.urdf_path = sim::DefaultArmUrdf();
  sim::CubeEnv env(eo);
  DatasetBagReader reader(bag);
  std::vector<std::string> splits;
  reader.ForEachEpisode([&](BagEpisode&& ep) {
    ASSERT_TRUE(ep.complete()) << ep.problems.front();
    ASSERT_TRUE(ep.has_meta);
    EXPECT_EQ(ep.meta.env, "cube-single");
    EXPECT_EQ(ep.num_steps, 60);
    EXPECT_EQ(ep.obs_dim, sim::CubeEnv::kObservationSize);
    EXPECT_EQ(ep.act_dim, sim::CubeEnv::kActionSize);
    EXPECT_EQ(ep.image_size, 0);
    EXPECT_TRUE(ep.meta.goal.empty());
    splits.push_back(ep.meta.split);
    const int D = sim::CubeEnv::kObservationSize, A = sim::CubeEnv::kActionSize;
    const sim::CubeEnv::Observation o0 = env.ResetForCollection(ep.meta.seed);
    ASSERT_EQ(ep.meta.start, std::vector<float>(o0.begin(), o0.end()));
    double moved = 0;
    for (int t = 0; t < ep.num_steps; ++t) {
      const sim::CubeEnv::Observation o = env.GetObservation();
      for (int i = 0; i < D; ++i)
        ASSERT_EQ(o[i], ep.observations[t * D + i])
            << "episode " << ep.meta.episode_id << " step " << t;
      sim::CubeEnv::Action a;
      for (int i = 0; i < A; ++i) {
        const float v = ep.actions[t * A + i];
        ASSERT_GE(v, -1.0f);
        ASSERT_LE(v, 1.0f);
        a[i] = v;
        moved += std::abs(v);
      }
      if (t + 1 < ep.num_steps) env.Step(a);
    }
    EXPECT_GT(moved, 1.0);  // the oracle acts
  });
  EXPECT_EQ(splits, (std::vector<std::string>{"train", "train", "val"}));
  EXPECT_EQ(reader.report().episodes, 3u);
  std::filesystem::remove(bag);
}

TEST(CubeCollect, Images) {
  const std::string bag = TempPath("img.bag");
  std::string out;
  ASSERT_EQ(RunCollect("--env cube-single --episodes 2 --val-episodes 0 --length 5 "
                       "--image-episodes 1 --quiet --out " +
                           bag,
                       &out),
            0)
      << out;
  DatasetBagReader reader(bag);
  std::vector<int> sizes;
  reader.ForEachEpisode([&](BagEpisode&& ep) {
    EXPECT_TRUE(ep.complete());
    sizes.push_back(ep.image_size);
    if (ep.image_size > 0) {
      EXPECT_EQ(ep.images.size(), 5u * 64 * 64 * 3);
      long sum = 0;
      for (uint8_t v : ep.images) sum += v;
      EXPECT_GT(sum, 0);
    }
  });
  EXPECT_EQ(sizes, (std::vector<int>{64, 0}));
  std::filesystem::remove(bag);
}

// Collects `env_name` (1 train + 1 val episode of 50 steps) and replays every stored action in
// `env` from its episode's collection reset: every stored row of `dim` floats comes back.
template <class Env>
void ExpectCollectionReplays(const std::string& env_name, Env& env, int dim) {
  const std::string bag = TempPath(env_name + ".bag");
  std::string out;
  ASSERT_EQ(RunCollect("--env " + env_name +
                           " --episodes 1 --val-episodes 1 --length 50 --seed 2 --out " + bag,
                       &out),
            0)
      << out;
  const int A = 5;
  DatasetBagReader reader(bag);
  std::vector<std::string> splits;
  reader.ForEachEpisode([&](BagEpisode&& ep) {
    ASSERT_TRUE(ep.complete()) << ep.problems.front();
    EXPECT_EQ(ep.meta.env, env_name);
    ASSERT_EQ(ep.obs_dim, dim);
    EXPECT_EQ(ep.act_dim, A);
    splits.push_back(ep.meta.split);
    env.ResetForCollection(ep.meta.seed);
    for (int t = 0; t < ep.num_steps; ++t) {
      const auto o = env.GetObservation();
      for (int i = 0; i < dim; ++i)
        ASSERT_EQ(o[i], ep.observations[t * dim + i])
            << env_name << " episode " << ep.meta.episode_id << " step " << t;
      typename Env::Action a;
      for (int i = 0; i < A; ++i) a[i] = ep.actions[t * A + i];
      if (t + 1 < ep.num_steps) env.Step(a);
    }
  });
  EXPECT_EQ(splits, (std::vector<std::string>{"train", "val"})) << env_name;
  std::filesystem::remove(bag);
}

TEST(PuzzleCollect, WritesFiftyFiveAndEightyThreeFloatRowsThatReplay) {
  for (const int side : {3, 4}) {
    sim::PuzzleEnvOptions eo;
    eo.urdf_path = sim::DefaultArmUrdf();
    eo.side = side;
    sim::PuzzleEnv env(eo);
    ExpectCollectionReplays("puzzle-" + std::to_string(side) + "x" + std::to_string(side), env,
                            side == 3 ? 55 : 83);
  }
}

TEST(CubeDoubleCollect, WritesThirtySevenFloatRowsThatReplay) {
  sim::CubeDoubleEnvOptions eo;
  eo.urdf_path = sim::DefaultArmUrdf();
  sim::CubeDoubleEnv env(eo);
  ExpectCollectionReplays("cube-double", env, 37);
}

TEST(SceneCollect, WritesFortyFloatRowsThatReplay) {
  sim::SceneEnvOptions eo;
  eo.urdf_path = sim::DefaultArmUrdf();
  sim::SceneEnv env(eo);
  ExpectCollectionReplays("scene", env, 40);
}

TEST(CubeCollect, UsageErrors) {
  std::string out;
  const std::string bag = TempPath("usage.bag");  // never written
  EXPECT_EQ(RunCollect("--env cube-single --maze large --out " + bag, &out), 2);
  EXPECT_NE(out.find("--maze does not apply"), std::string::npos) << out;
  EXPECT_EQ(RunCollect("--env cube-triple --out " + bag, &out), 2);
  EXPECT_EQ(RunCollect("--urdf a.urdf --out " + bag, &out), 2);
  EXPECT_EQ(RunCollect("--env puzzle-3x3 --kind stitch --out " + bag, &out), 2);
  EXPECT_NE(out.find("--kind does not apply to --env puzzle-3x3"), std::string::npos) << out;
  EXPECT_EQ(
      RunCollect("--env cube-single --urdf /nonexistent.urdf --episodes 1 --quiet --out " + bag,
                 &out),
      1);
  EXPECT_FALSE(std::filesystem::exists(bag));
}

}  // namespace
}  // namespace msspr::ros_bridge
