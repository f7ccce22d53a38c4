// Dataset bags without a master: write, read back bit for bit, and report damage.
#include "dataset_bag.h"

#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <sensor_msgs/Image.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <string>

#include "msspr/Action.h"
#include "msspr/Observation.h"
#include "msspr_sim/dataset_gen.h"
#include "msspr_sim/point_maze.h"

namespace msspr::ros_bridge {
namespace {

std::string TempPath(const std::string& name) {
  return "/tmp/msspr_test_" + std::to_string(getpid()) + "_" + name;
}

std::vector<sim::Episode> WriteDataset(const std::string& path, int n, int length, bool images,
                                       bool lz4 = true) {
  sim::PointMazeOptions eo;
  eo.enable_rendering = images;
  sim::PointMaze env(eo);
  sim::CollectOptions co;
  co.episode_length = length;
  co.images = images;
  co.seed = 5;
  DatasetBagWriter w(path, 0.1, lz4);
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

// One episode of n steps; `edit` may change each observation/action before it is written.
void WriteRaw(const std::string& path, uint32_t n,
              const std::function<void(uint32_t, msspr::Observation&, msspr::Action&)>& edit,
              const std::function<void(uint32_t, sensor_msgs::Image&)>& image = nullptr) {
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  for (uint32_t t = 0; t < n; ++t) {
    const ros::Time stamp(1.0 + t);
    msspr::Observation o;
    o.header.stamp = stamp;
    o.step = t;
    o.state = {float(t), 0.f};
    msspr::Action a;
    a.step = t;
    a.action = {0.5f, -0.5f};
    edit(t, o, a);
    bag.write(kObservationTopic, stamp, o);
    bag.write(kActionTopic, stamp, a);
    if (image) {
      sensor_msgs::Image img;
      img.header.stamp = stamp;
      img.encoding = "rgb8";
      img.width = img.height = 8;
      img.step = 24;
      img.data.assign(8 * 24, static_cast<uint8_t>(t));
      image(t, img);
      bag.write(kImageTopic, stamp, img);
    }
  }
}

bool AnyProblemHas(const BagReadReport& r, const std::string& text) {
  for (const auto& p : r.problems)
    if (p.find(text) != std::string::npos) return true;
  return false;
}

TEST(DatasetBag, HostileStepIndicesAreRejectedAndCounted) {
  ros::Time::init();
  const std::string path = TempPath("steps.bag");
  WriteRaw(path, 12, [](uint32_t t, msspr::Observation& o, msspr::Action& a) {
    if (t == 10) o.step = 0xFFFFFFFFu;  // would wrap num_steps and write out of bounds
    if (t == 11) a.step = 50000;        // far beyond the episode: would allocate and leave a gap
  });
  DatasetBagReader r(path);
  int n = 0;
  r.ForEachEpisode([&](BagEpisode&& ep) {
    ++n;
    EXPECT_LE(ep.num_steps, 12);
    EXPECT_EQ(ep.Segments().front(), std::make_pair(0, 10));
  });
  EXPECT_EQ(n, 1);
  EXPECT_EQ(r.report().out_of_range_steps, 2u);
  EXPECT_TRUE(AnyProblemHas(r.report(), "step 4294967295 out of range"))
      << r.report().problems.size();
  EXPECT_TRUE(AnyProblemHas(r.report(), "step 50000 out of range (episode has"));
  std::remove(path.c_str());
}

TEST(DatasetBag, NonFiniteStatesAndActionsAreRejectedAndCounted) {
  ros::Time::init();
  const std::string path = TempPath("nan.bag");
  WriteRaw(path, 10, [](uint32_t t, msspr::Observation& o, msspr::Action& a) {
    if (t == 3) o.state[1] = std::numeric_limits<float>::quiet_NaN();
    if (t == 6) a.action[0] = std::numeric_limits<float>::infinity();
  });
  DatasetBagReader r(path);
  r.ForEachEpisode([&](BagEpisode&& ep) {
    EXPECT_EQ(ep.Segments(), (std::vector<std::pair<int, int>>{{0, 3}, {4, 6}, {7, 10}}));
  });
  EXPECT_EQ(r.report().nonfinite_observations, 1u);
  EXPECT_EQ(r.report().nonfinite_actions, 1u);
  EXPECT_TRUE(AnyProblemHas(r.report(), "1 observations with NaN or Inf rejected (step 3)"));
  std::remove(path.c_str());
}

TEST(DatasetBag, ImagesWhoseDeclaredSizeDisagreesWithTheirDataAreRejected) {
  ros::Time::init();
  const std::string path = TempPath("images.bag");
  WriteRaw(
      path, 6, [](uint32_t, msspr::Observation&, msspr::Action&) {},
      [](uint32_t t, sensor_msgs::Image& img) {
        if (t == 0) img.width = img.height = 0x7FFFFFFF;  // first image: would size the buffers
        if (t == 2) img.step = 0xFFFFFFFFu;
        if (t == 3) img.width = img.height = 64;  // data of an 8x8 image
        if (t == 4) img.data.resize(10);
      });
  DatasetBagReader r(path);
  r.ForEachEpisode([&](BagEpisode&& ep) {
    EXPECT_EQ(ep.image_size, 8);
    EXPECT_EQ(ep.has_image, (std::vector<uint8_t>{0, 1, 0, 0, 0, 1}));
    EXPECT_EQ(ep.images.size(), 6u * 8 * 8 * 3);
  });
  EXPECT_EQ(r.report().bad_images, 4u);
  // No consistent image at all: the episode has no images, and says why.
  WriteRaw(
      path, 3, [](uint32_t, msspr::Observation&, msspr::Action&) {},
      [](uint32_t, sensor_msgs::Image& img) { img.step = 0xFFFFFFFFu; });
  DatasetBagReader r2(path);
  r2.ForEachEpisode([&](BagEpisode&& ep) { EXPECT_EQ(ep.image_size, 0); });
  EXPECT_TRUE(AnyProblemHas(r2.report(), "none a consistent rgb8 image"));
  std::remove(path.c_str());
}

TEST(DatasetBag, CorruptChunkInTheMiddleIsAnErrorNamingTheBag) {
  ros::Time::init();
  const std::string path = TempPath("flipped.bag");
  std::mt19937 rng(11);  // seeded corruption
  for (bool lz4 : {true, false}) {
    WriteDataset(path, 6, 200, false, lz4);
    std::string good;
    {
      std::ifstream f(path, std::ios::binary);
      good.assign(std::istreambuf_iterator<char>(f), {});
    }
    int errors = 0;
    for (int k = 0; k < 12; ++k) {
      std::string bytes = good;
      const size_t at = good.size() / 4 + rng() % (good.size() / 2);
      for (size_t i = at; i < at + 64 && i < bytes.size(); ++i)
        bytes[i] = static_cast<char>(bytes[i] ^ (rng() | 1));
      {
        std::ofstream f(path, std::ios::binary | std::ios::trunc);
        f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
      }
      try {
        DatasetBagReader r(path);
        r.ForEachEpisode([](BagEpisode&&) {});
        // Damage that rosbag cannot see (inside a message's numbers) reads as data.
      } catch (const BagError& e) {
        ++errors;
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      } catch (const std::exception& e) {
        ADD_FAILURE() << "not a BagError: " << e.what();
      }
    }
    EXPECT_GT(errors, 0) << (lz4 ? "lz4" : "uncompressed");
  }
  std::remove(path.c_str());
}

TEST(DatasetBagWriter, NeverTruncatesAnExistingBagBeforeItIsComplete) {
  ros::Time::init();
  const std::string path = TempPath("keep.bag");
  WriteDataset(path, 2, 50, false);
  const auto size = std::filesystem::file_size(path);
  const std::vector<float> obs(2 * 10, 1.f), act(2 * 10, 0.f);
  EpisodeMeta meta;
  {
    DatasetBagWriter w(path, 0.1);  // abandoned: destroyed without Close()
    w.WriteEpisode(meta, 10, 2, 2, obs.data(), act.data(), nullptr, 0, 1.0);
    EXPECT_EQ(std::filesystem::file_size(path), size);
  }
  EXPECT_EQ(std::filesystem::file_size(path), size);
  for (const auto& e : std::filesystem::directory_iterator("/tmp"))
    EXPECT_EQ(e.path().string().find(path + ".tmp"), std::string::npos) << e.path();
  {
    DatasetBagWriter w(path, 0.1);
    w.WriteEpisode(meta, 10, 2, 2, obs.data(), act.data(), nullptr, 0, 1.0);
    w.Close();  // now the new bag replaces the old one
  }
  DatasetBagReader r(path);
  r.ForEachEpisode([](BagEpisode&& ep) { EXPECT_EQ(ep.num_steps, 10); });
  EXPECT_EQ(r.report().episodes, 1u);
  std::remove(path.c_str());
}

}  // namespace
}  // namespace msspr::ros_bridge
