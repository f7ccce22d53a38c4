// Dataset bags without a master: write, read back bit for bit, and report damage.
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <rosbag/bag.h>

#include "dataset_bag.h"
#include "msspr/Action.h"
#include "msspr/Observation.h"
#include "msspr_sim/dataset_gen.h"
#include "msspr_sim/point_maze.h"

namespace msspr::ros_bridge {
namespace {

std::string TempPath(const std::string& name) {
  return "/tmp/msspr_test_" + std::to_string(getpid()) + "_" + name;
}

std::vector<sim::Episode> WriteDataset(const std::string& path, int n, int length, bool images) {
  sim::PointMazeOptions eo;
  eo.enable_rendering = images;
  sim::PointMaze env(eo);
  sim::CollectOptions co;
  co.episode_length = length;
  co.images = images;
  co.seed = 5;
  DatasetBagWriter w(path, 0.1);
  std::vector<sim::Episode> eps;
  for (int k = 0; k < n; ++k) {
    eps.push_back(sim::CollectEpisode(env, co, static_cast<uint64_t>(k)));
    const auto& ep = eps.back();
    EpisodeMeta meta;
    meta.episode_id = static_cast<uint64_t>(k);
    meta.env = "pointmaze-medium";
    meta.split = k + 1 == n ? "val" : "train";
    meta.seed = ep.seed;
    meta.goal = {static_cast<float>(ep.goal.x()), static_cast<float>(ep.goal.y())};
    w.WriteEpisode(meta, ep.length, 2, 2, ep.observations.data(), ep.actions.data(),
                   images ? ep.images.data() : nullptr, 64, 1.0);
  }
  w.Close();
  return eps;
}

TEST(DatasetBag, RoundTripIsBitExact) {
  ros::Time::init();
  const std::string path = TempPath("roundtrip.bag");
  const auto eps = WriteDataset(path, 4, 120, /*images=*/false);
  DatasetBagReader r(path);
  int k = 0;
  r.ForEachEpisode([&](BagEpisode&& ep) {
    ASSERT_LT(k, 4);
    EXPECT_EQ(ep.meta.episode_id, static_cast<uint64_t>(k));
    EXPECT_EQ(ep.meta.split, k == 3 ? "val" : "train");
    EXPECT_EQ(ep.meta.seed, eps[k].seed);
    EXPECT_TRUE(ep.complete()) << (ep.problems.empty() ? "" : ep.problems[0]);
    ASSERT_EQ(ep.num_steps, 120);
    EXPECT_EQ(ep.observations, eps[k].observations);  // bit for bit
    EXPECT_EQ(ep.actions, eps[k].actions);
    EXPECT_EQ(ep.image_size, 0);
    ASSERT_EQ(ep.Segments().size(), 1u);
    EXPECT_EQ(ep.Segments()[0], std::make_pair(0, 120));
    ++k;
  });
  EXPECT_EQ(k, 4);
  EXPECT_EQ(r.report().steps, 480u);
  EXPECT_TRUE(r.report().problems.empty());
  std::remove(path.c_str());
}

TEST(DatasetBag, ImagesRoundTrip) {
  ros::Time::init();
  const std::string path = TempPath("images.bag");
  const auto eps = WriteDataset(path, 2, 30, /*images=*/true);
  DatasetBagReader r(path);
  int k = 0;
  r.ForEachEpisode([&](BagEpisode&& ep) {
    EXPECT_EQ(ep.image_size, 64);
    EXPECT_EQ(ep.images, eps[k].images);
    EXPECT_EQ(ep.observations, eps[k].observations);
    EXPECT_TRUE(ep.complete());
    ++k;
  });
  EXPECT_EQ(k, 2);
  std::remove(path.c_str());
}

TEST(DatasetBag, GapsAreReportedNotBridged) {
  ros::Time::init();
  const std::string path = TempPath("gaps.bag");
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    for (uint32_t t = 0; t < 10; ++t) {
      const ros::Time stamp(1.0 + t);
      msspr::Observation o;
      o.header.stamp = stamp;
      o.episode_id = 0;
      o.step = t;
      o.state = {float(t), 0.f};
      if (t != 4 && t != 5) bag.write(kObservationTopic, stamp, o);  // dropped observations
      msspr::Action a;
      a.episode_id = 0;
      a.step = t;
      a.action = {0.5f, 0.5f};
      bag.write(kActionTopic, stamp, a);
    }
  }
  DatasetBagReader r(path);
  int n = 0;
  r.ForEachEpisode([&](BagEpisode&& ep) {
    ++n;
    EXPECT_FALSE(ep.complete());
    const auto seg = ep.Segments();
    ASSERT_EQ(seg.size(), 2u);
    EXPECT_EQ(seg[0], std::make_pair(0, 4));
    EXPECT_EQ(seg[1], std::make_pair(6, 10));
  });
  EXPECT_EQ(n, 1);
  EXPECT_EQ(r.report().missing_observations, 2u);
  bool named = false;
  for (auto& p : r.report().problems) named |= p.find("steps 4-5") != std::string::npos;
  EXPECT_TRUE(named);
  std::remove(path.c_str());
}

TEST(DatasetBag, CorruptAndTruncatedBagsNameTheFile) {
  ros::Time::init();
  const std::string junk = TempPath("junk.bag");
  { std::ofstream(junk) << "this is not a bag"; }
  try {
    DatasetBagReader r(junk);
    r.ForEachEpisode([](BagEpisode&&) {});
    FAIL() << "junk bag accepted";
  } catch (const BagError& e) {
    EXPECT_NE(std::string(e.what()).find(junk), std::string::npos) << e.what();
  }
  const std::string path = TempPath("trunc.bag");
  WriteDataset(path, 3, 200, false);
  std::string bytes;
  {
    std::ifstream f(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(f), {});
  }
  {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  }
  try {
    DatasetBagReader r(path);
    r.ForEachEpisode([](BagEpisode&&) {});
    FAIL() << "truncated bag accepted";
  } catch (const BagError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  std::remove(junk.c_str());
  std::remove(path.c_str());
}

}  // namespace
}  // namespace msspr::ros_bridge
