// Dataset bags without a master: write, read back bit for bit, and report damage.
#include "msspr_bags/dataset_bag.h"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <unistd.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <string>

#include "msspr/Action.h"
#include "msspr/EpisodeInfo.h"
#include "msspr/Observation.h"
#include "msspr_bags/dataset_bag_validator.h"
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

TEST(DatasetBag, SuccessFlagsMeasureTheFirstSuccessDimsOnly) {
  // A 4-D state whose first two values reach the goal's while the other two
  // never do (the ant: xy against a full-state goal).
  const std::vector<float> obs{0, 0, 5, 5, 0.9f, 0, 5, 5, 3, 0, 5, 5};  // 3 steps
  const std::vector<float> act(3, 0.0f);
  EpisodeMeta meta;
  meta.env = "test";
  meta.split = "train";
  meta.goal = {1, 0, -5, -5};
  for (int dims : {0, 2}) {
    const std::string path = TempPath("success" + std::to_string(dims) + ".bag");
    {
      DatasetBagWriter w(path, 0.1);
      w.WriteEpisode(meta, 3, 4, 1, obs.data(), act.data(), nullptr, 0, 0.5, dims);
      w.Close();
    }
    rosbag::Bag bag(path);
    std::vector<bool> flags;
    for (const rosbag::MessageInstance& m :
         rosbag::View(bag, rosbag::TopicQuery(kObservationTopic)))
      flags.push_back(m.instantiate<msspr::Observation>()->success);
    bag.close();
    std::remove(path.c_str());
    // dims 2: |(0.9, 0) - (1, 0)| = 0.1 is within 0.5; the others are not. All 4: never.
    EXPECT_EQ(flags, (dims == 2 ? std::vector<bool>{false, true, false}
                                : std::vector<bool>{false, false, false}))
        << "success_dims " << dims;
  }
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

// The bytes ros::serialization writes for `msg`.
template <class M>
std::vector<uint8_t> Serialize(const M& msg) {
  std::vector<uint8_t> buf(ros::serialization::serializationLength(msg));
  ros::serialization::OStream out(buf.data(), static_cast<uint32_t>(buf.size()));
  ros::serialization::serialize(out, msg);
  return buf;
}

// The reader's layout check of M accepts exactly M's own serialization: not a
// byte less, not a byte more. The layout is derived from the definition
// generated from the .msg, so a field added to a .msg changes it too; should a
// new field be one that the derivation lays out wrong, this names the type,
// the field and the layout.
template <class M>
void ExpectLayoutFitsSerialization(const M& msg) {
  const std::string type = ros::message_traits::datatype<M>();
  const MessageLayout* layout = nullptr;
  try {
    layout = &MessageLayout::Of<M>();
  } catch (const std::exception& e) {
    FAIL() << type << ": the dataset bag reader cannot derive its wire layout: " << e.what();
  }
  const std::vector<uint8_t> bytes = Serialize(msg);
  std::string why;
  EXPECT_TRUE(layout->Fits(bytes.data(), bytes.size(), &why))
      << type << ": the layout the reader derives from its definition does not hold the "
      << bytes.size() << " bytes ros::serialization writes (" << why
      << "); every bag would read as corrupt. Derived layout: " << layout->Describe();
  if (bytes.empty()) return;
  EXPECT_FALSE(layout->Fits(bytes.data(), bytes.size() - 1)) << type << ": one byte short";
  std::vector<uint8_t> longer = bytes;
  longer.push_back(0);
  EXPECT_FALSE(layout->Fits(longer.data(), longer.size(), &why)) << type << ": one byte more";
  EXPECT_NE(why.find("1 bytes left over"), std::string::npos) << why;
}

TEST(MessageLayout, EachMessageOfADatasetBagFitsItsOwnSerialization) {
  msspr::Observation o;
  o.header.seq = 7;
  o.header.stamp = ros::Time(12, 34);
  o.header.frame_id = "world";
  o.episode_id = 3;
  o.step = 41;
  o.state = {1.f, 2.f, 3.f};
  o.goal = {4.f, 5.f};
  o.success = true;
  o.last = true;
  msspr::Action a;
  a.header.frame_id = "x";
  a.episode_id = 3;
  a.step = 41;
  a.action = {0.5f, -0.5f};
  msspr::EpisodeInfo e;
  e.header.frame_id = "world";
  e.episode_id = 9;
  e.env = "pointmaze-medium";
  e.split = "val";
  e.task_id = -2;
  e.seed = 0x123456789ull;
  e.start = {0.f, 1.f};
  e.goal = {2.f, 3.f, 4.f};
  sensor_msgs::Image img;
  img.header.frame_id = kCameraFrame;
  img.encoding = "rgb8";
  img.width = img.height = 4;
  img.step = 12;
  img.data.assign(48, 7);
  ExpectLayoutFitsSerialization(o);
  ExpectLayoutFitsSerialization(a);
  ExpectLayoutFitsSerialization(e);
  ExpectLayoutFitsSerialization(img);
  // Empty strings and arrays as well.
  ExpectLayoutFitsSerialization(msspr::Observation());
  ExpectLayoutFitsSerialization(msspr::Action());
  ExpectLayoutFitsSerialization(msspr::EpisodeInfo());
  ExpectLayoutFitsSerialization(sensor_msgs::Image());
}

TEST(MessageLayout, CorruptLengthsAreRejectedNamingTheField) {
  msspr::Observation o;
  o.header.frame_id = "world";
  o.state = {1.f, 2.f};
  o.goal = {3.f, 4.f};
  std::vector<uint8_t> bytes = Serialize(o);
  // The count of `state` follows the header, episode_id and step.
  const size_t at = ros::serialization::serializationLength(o.header) + 8;
  const uint32_t huge = 0x40000000u;
  std::memcpy(bytes.data() + at, &huge, 4);
  std::string why;
  EXPECT_FALSE(MessageLayout::Of<msspr::Observation>().Fits(bytes.data(), bytes.size(), &why));
  EXPECT_NE(why.find("field 'state' (float32[]) at byte " + std::to_string(at) +
                     " declares 1073741824 items"),
            std::string::npos)
      << why;
  // Every 4-byte word set to 0xFFFFFFFF: a length is caught, nothing runs past the buffer.
  const std::vector<uint8_t> good = Serialize(o);
  int rejected = 0;
  for (size_t k = 0; k + 4 <= good.size(); ++k) {
    bytes = good;
    std::memset(bytes.data() + k, 0xFF, 4);
    rejected += !MessageLayout::Of<msspr::Observation>().Fits(bytes.data(), bytes.size());
  }
  EXPECT_GT(rejected, 0);
  EXPECT_NE(MessageLayout::Of<msspr::Observation>().Describe().find("float32[] state"),
            std::string::npos)
      << MessageLayout::Of<msspr::Observation>().Describe();
}

TEST(MessageLayout, NestedMessagesFixedArraysStringArraysAndConstants) {
  // Standard messages with what msspr's own do not use yet: constants, float64[9],
  // nested messages, arrays of fixed-size and of varying-size messages, string[], duration.
  sensor_msgs::CameraInfo info;
  info.distortion_model = "plumb_bob";
  info.D = {0.1, 0.2};
  info.roi.width = 3;
  ExpectLayoutFitsSerialization(info);
  diagnostic_msgs::DiagnosticArray diag;
  diag.status.resize(2);
  diag.status[0].name = "arm";
  diag.status[1].values.resize(3);
  diag.status[1].values[2].key = "temperature";
  diag.status[1].values[2].value = "41";
  ExpectLayoutFitsSerialization(diag);
  visualization_msgs::MarkerArray markers;
  markers.markers.resize(2);
  markers.markers[0].points.resize(5);
  markers.markers[1].colors.resize(2);
  markers.markers[1].text = "value";
  markers.markers[1].lifetime = ros::Duration(1.5);
  ExpectLayoutFitsSerialization(markers);
  std::vector<uint8_t> bytes = Serialize(diag);
  std::string why;
  EXPECT_FALSE(MessageLayout::Of<diagnostic_msgs::DiagnosticArray>().Fits(bytes.data(),
                                                                          bytes.size() - 3, &why));
  EXPECT_NE(why.find("status[1].values[2].value"), std::string::npos) << why;
}

TEST(MessageLayout, ATypeItCannotLayOutIsNamed) {
  try {
    MessageLayout("pkg/Thing", "uint32 a\nwidget b\n");
    FAIL() << "unknown type accepted";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("pkg/Thing"), std::string::npos) << what;
    EXPECT_NE(what.find("field 'b' has type 'widget'"), std::string::npos) << what;
  }
  const MessageLayout layout("pkg/Thing", "int32 A=3\nstring B=x # y\nuint8[2] c  # two\n");
  const uint8_t two[2] = {1, 2};
  EXPECT_TRUE(layout.Fits(two, 2));
  EXPECT_EQ(layout.Describe(), "uint8[2] c");
}

}  // namespace

// A message written by another version of msspr's .msg: the same type name and
// the same bytes, but another definition (another md5).
struct OtherObservation {
  msspr::Observation msg;
};

}  // namespace msspr::ros_bridge

namespace ros {
namespace message_traits {
template <>
struct MD5Sum<msspr::ros_bridge::OtherObservation> {
  static const char* value() { return "0123456789abcdef0123456789abcdef"; }
  static const char* value(const msspr::ros_bridge::OtherObservation&) { return value(); }
};
template <>
struct DataType<msspr::ros_bridge::OtherObservation> {
  static const char* value() { return "msspr/Observation"; }
  static const char* value(const msspr::ros_bridge::OtherObservation&) { return value(); }
};
template <>
struct Definition<msspr::ros_bridge::OtherObservation> {
  static const char* value() { return "Header header\nuint32 episode_id\n"; }
  static const char* value(const msspr::ros_bridge::OtherObservation&) { return value(); }
};
}  // namespace message_traits
namespace serialization {
template <>
struct Serializer<msspr::ros_bridge::OtherObservation> {
  template <typename Stream, typename T>
  inline static void allInOne(Stream& stream, T m) {
    stream.next(m.msg);
  }
  ROS_DECLARE_ALLINONE_SERIALIZER
};
}  // namespace serialization
}  // namespace ros

namespace msspr::ros_bridge {
namespace {

TEST(DatasetBag, MessagesOfAnotherDefinitionAreNamedNotReadAsCorrupt) {
  ros::Time::init();
  const std::string path = TempPath("otherdef.bag");
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    for (uint32_t t = 0; t < 3; ++t) {
      const ros::Time stamp(1.0 + t);
      OtherObservation o;
      o.msg.header.stamp = stamp;
      o.msg.step = t;
      o.msg.state = {1.f, 2.f};
      msspr::Action a;
      a.step = t;
      a.action = {0.5f, -0.5f};
      bag.write(kObservationTopic, stamp, o);
      bag.write(kActionTopic, stamp, a);
    }
  }
  DatasetBagReader r(path);
  r.ForEachEpisode([](BagEpisode&& ep) { EXPECT_EQ(ep.Segments().size(), 0u); });
  EXPECT_EQ(r.report().foreign_messages, 3u);
  EXPECT_TRUE(AnyProblemHas(r.report(),
                            "3 msspr/Observation messages were written with another definition of "
                            "msspr/Observation (md5 0123456789abcdef0123456789abcdef; this build "
                            "reads md5 "))
      << (r.report().problems.empty() ? "" : r.report().problems[0]);
  std::remove(path.c_str());
}
}  // namespace
}  // namespace msspr::ros_bridge
