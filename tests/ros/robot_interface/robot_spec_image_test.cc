// Robot interface specs with a camera: the images: section and image goals in
// the loader, the one decode + resize of camera images (robot_fields.h
// DecodeImage) for every encoding, corrupt images rejected with a clear
// error, and a bag's images read through the spec equal to the native
// dataset's images of the same episodes. No master needed.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "msspr_bags/dataset_bag.h"
#include "msspr_robot_interface/robot_fields.h"
#include "msspr_robot_interface/robot_spec.h"
#include "msspr_robot_interface/spec_bag.h"
#include "replace_once.h"
#include "robot_spec_test.h"

namespace msspr::ros_bridge {
namespace {

namespace fs = std::filesystem;

std::string CameraSpecPath() {
  return std::string(MSSPR_SOURCE_DIR) + "/config/robots/pointmaze_camera.yaml";
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The error of parsing `yaml` ("" when it loads).
std::string ParseError(const std::string& yaml) {
  try {
    ParseRobotSpec(yaml, "cam.yaml");
  } catch (const RobotSpecError& e) {
    return e.what();
  }
  return "";
}

TEST(RobotSpecImages, TheShippedCameraSpecLoads) {
  const RobotSpec s = LoadRobotSpec(CameraSpecPath());
  EXPECT_EQ(s.name, "pointmaze_camera");
  ASSERT_EQ(s.images.size(), 1u);
  EXPECT_EQ(s.images[0].name, "camera");
  EXPECT_EQ(s.images[0].topic, "camera/image");
  EXPECT_EQ(s.images[0].type, kImageType);
  EXPECT_EQ(s.images[0].size, 64);
  EXPECT_EQ(s.goal.source, "image");
  EXPECT_EQ(s.goal.topic, "goal_image");
  EXPECT_EQ(s.goal.type, kImageType);
  EXPECT_EQ(s.obs_dim(), 2);
  EXPECT_EQ(s.action_dim(), 2);
  EXPECT_EQ(CompareRobotSpecs(s, ParseRobotSpec(s.text, "again")), "");
}

TEST(RobotSpecImages, BadImageEntriesAreRejectedNamingFileCameraAndTopic) {
  const std::string spec = ReadFile(CameraSpecPath());
  // An unknown key in a camera entry.
  std::string e =
      ParseError(testing_util::ReplaceOnce(spec, "    size: 64\n", "    size: 64\n    sise: 32\n"));
  EXPECT_NE(e.find("cam.yaml: image 'camera' (topic camera/image): unknown key 'sise'"),
            std::string::npos)
      << e;
  // No size, a size out of range, a type that is no image.
  e = ParseError(testing_util::ReplaceOnce(spec, "    size: 64\n", ""));
  EXPECT_NE(e.find("image 'camera' (topic camera/image): no size"), std::string::npos) << e;
  e = ParseError(testing_util::ReplaceOnce(spec, "    size: 64\n", "    size: 4\n"));
  EXPECT_NE(e.find("size must be in 8..1024"), std::string::npos) << e;
  e = ParseError(testing_util::ReplaceOnce(spec, "    type: sensor_msgs/Image   #",
                                           "    type: sensor_msgs/PointCloud2   #"));
  EXPECT_NE(
      e.find(
          "image 'camera' (topic camera/image): unsupported image type 'sensor_msgs/PointCloud2'"),
      std::string::npos)
      << e;
  e = ParseError(testing_util::ReplaceOnce(spec, "    topic: camera/image\n", ""));
  EXPECT_NE(e.find("image 'camera': no topic"), std::string::npos) << e;
  // Two cameras.
  e = ParseError(testing_util::ReplaceOnce(
      spec, "observation:  ", R"(  - {name: second, topic: cam2, type: sensor_msgs/Image, size: 64}
observation:  )"));
  EXPECT_NE(e.find("images: 2 cameras, a pixels policy takes one"), std::string::npos) << e;
  // An image as an observation field.
  e = ParseError(testing_util::ReplaceOnce(spec, "    type: nav_msgs/Odometry",
                                           "    type: sensor_msgs/CompressedImage"));
  EXPECT_NE(e.find("observation field 'position' (topic odom"), std::string::npos) << e;
  EXPECT_NE(e.find("name the camera in the images: section"), std::string::npos) << e;
  // Goals: an image goal needs a camera; a camera needs an image goal of an image type.
  const std::string no_images = testing_util::ReplaceOnce(
      spec, spec.substr(spec.find("images:"), spec.find("observation:") - spec.find("images:")),
      "");
  e = ParseError(no_images);
  EXPECT_NE(e.find("goal (topic goal_image): source image needs a camera in the images: section"),
            std::string::npos)
      << e;
  e = ParseError(testing_util::ReplaceOnce(
      spec, "  source: image\n  topic: goal_image\n  type: sensor_msgs/Image\n",
      "  source: pose\n  topic: goal_pose\n  type: geometry_msgs/PoseStamped\n  fields:\n"
      "    - {observation: position, field: pose.position, components: [x, y]}\n"));
  EXPECT_NE(e.find("goal: a spec with images serves pixels policies, whose goal is an image"),
            std::string::npos)
      << e;
  e = ParseError(testing_util::ReplaceOnce(spec, "  type: sensor_msgs/Image\naction",
                                           "  type: sensor_msgs/Imag\naction"));
  EXPECT_NE(e.find("goal (topic goal_image): source image takes sensor_msgs/Image or "
                   "sensor_msgs/CompressedImage"),
            std::string::npos)
      << e;
  e = ParseError(testing_util::ReplaceOnce(spec, "  type: sensor_msgs/Image\naction",
                                           "  type: sensor_msgs/Image\n  colour: rgb\naction"));
  EXPECT_NE(e.find("goal: unknown key 'colour'"), std::string::npos) << e;
  const std::string no_goal = testing_util::ReplaceOnce(
      spec, "goal:\n  source: image\n  topic: goal_image\n  type: sensor_msgs/Image\n", "");
  e = ParseError(no_goal);
  EXPECT_NE(e.find("a spec with images needs a goal"), std::string::npos) << e;
}

TEST(RobotSpecImages, CompareNamesTheCamera) {
  const std::string spec = ReadFile(CameraSpecPath());
  const RobotSpec a = ParseRobotSpec(spec, "a");
  std::string d = CompareRobotSpecs(
      a, ParseRobotSpec(testing_util::ReplaceOnce(spec, "    size: 64\n", "    size: 32\n"), "b"));
  EXPECT_EQ(d, "image 0 'camera' (topic camera/image): size 64 vs 32");
  d = CompareRobotSpecs(
      a,
      ParseRobotSpec(
          testing_util::ReplaceOnce(spec, "    topic: camera/image\n", "    topic: cam\n"), "b"));
  EXPECT_EQ(d, "image 0 'camera' (topic camera/image): topic camera/image vs cam");
  d = CompareRobotSpecs(
      a, ParseRobotSpec(testing_util::ReplaceOnce(spec, "    type: sensor_msgs/Image   #",
                                                  "    type: sensor_msgs/CompressedImage #"),
                        "b"));
  EXPECT_EQ(d,
            "image 0 'camera' (topic camera/image): type sensor_msgs/Image vs "
            "sensor_msgs/CompressedImage");
  d = CompareRobotSpecs(
      a, ParseRobotSpec(testing_util::ReplaceOnce(spec, "  type: sensor_msgs/Image\naction",
                                                  "  type: sensor_msgs/CompressedImage\naction"),
                        "b"));
  EXPECT_EQ(d, "goal (topic goal_image): type sensor_msgs/Image vs sensor_msgs/CompressedImage");
}

// A smooth 96x128 picture (rows x cols) in BGR, and the messages of it in each encoding.
cv::Mat Picture() {
  cv::Mat bgr(96, 128, CV_8UC3);
  for (int y = 0; y < bgr.rows; ++y)
    for (int x = 0; x < bgr.cols; ++x)
      bgr.at<cv::Vec3b>(y, x) =
          cv::Vec3b(static_cast<uint8_t>(40 + x), static_cast<uint8_t>(30 + 2 * y),
                    static_cast<uint8_t>(200 - x / 2 - y / 2));
  return bgr;
}

sensor_msgs::Image ImageMsg(const cv::Mat& m, const std::string& encoding) {
  sensor_msgs::Image msg;
  msg.height = static_cast<uint32_t>(m.rows);
  msg.width = static_cast<uint32_t>(m.cols);
  msg.encoding = encoding;
  msg.step = static_cast<uint32_t>(m.cols * m.channels());
  msg.data.assign(m.data, m.data + static_cast<size_t>(msg.step) * m.rows);
  return msg;
}

sensor_msgs::CompressedImage CompressedMsg(const cv::Mat& bgr, const std::string& format) {
  sensor_msgs::CompressedImage msg;
  msg.format = format;
  cv::imencode(format == "png" ? ".png" : ".jpg", bgr, msg.data, {cv::IMWRITE_JPEG_QUALITY, 95});
  return msg;
}

TEST(RobotSpecImages, EveryEncodingDecodesToTheSameResizedArray) {
  const cv::Mat bgr = Picture();
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  std::vector<uint8_t> from_rgb, from_bgr, from_png, from_jpeg, from_padded;
  std::string why;
  ASSERT_TRUE(DecodeImage(ImageMsg(rgb, "rgb8"), 64, &from_rgb, &why)) << why;
  ASSERT_TRUE(DecodeImage(ImageMsg(bgr, "bgr8"), 64, &from_bgr, &why)) << why;
  ASSERT_TRUE(DecodeImage(CompressedMsg(bgr, "png"), 64, &from_png, &why)) << why;
  ASSERT_TRUE(DecodeImage(CompressedMsg(bgr, "rgb8; jpeg compressed bgr8"), 64, &from_jpeg, &why))
      << why;
  ASSERT_EQ(from_rgb.size(), 64u * 64 * 3);
  EXPECT_EQ(from_bgr, from_rgb);
  EXPECT_EQ(from_png, from_rgb);
  ASSERT_EQ(from_jpeg.size(), from_rgb.size());
  double sum = 0;
  int worst = 0;
  for (size_t i = 0; i < from_rgb.size(); ++i) {
    const int d = std::abs(static_cast<int>(from_jpeg[i]) - static_cast<int>(from_rgb[i]));
    sum += d;
    worst = std::max(worst, d);
  }
  EXPECT_LT(sum / from_rgb.size(), 2.0);
  EXPECT_LE(worst, 16);
  // Rows padded beyond width * 3 (step) read the same.
  sensor_msgs::Image padded = ImageMsg(rgb, "rgb8");
  padded.step = static_cast<uint32_t>(rgb.cols * 3 + 8);
  padded.data.assign(static_cast<size_t>(padded.step) * rgb.rows, 0);
  for (int y = 0; y < rgb.rows; ++y)
    std::memcpy(&padded.data[y * padded.step], rgb.ptr(y), rgb.cols * 3);
  ASSERT_TRUE(DecodeImage(padded, 64, &from_padded, &why)) << why;
  EXPECT_EQ(from_padded, from_rgb);
  // The resize is INTER_AREA: a picture of 2x2 blocks gives the blocks' values exactly.
  cv::Mat blocks(128, 128, CV_8UC3);
  for (int y = 0; y < 128; ++y)
    for (int x = 0; x < 128; ++x)
      blocks.at<cv::Vec3b>(y, x) =
          cv::Vec3b(static_cast<uint8_t>(x / 2), static_cast<uint8_t>(y / 2), 7);
  std::vector<uint8_t> small;
  ASSERT_TRUE(DecodeImage(ImageMsg(blocks, "rgb8"), 64, &small, &why)) << why;
  EXPECT_EQ(small[(10 * 64 + 20) * 3 + 0], 20);
  EXPECT_EQ(small[(10 * 64 + 20) * 3 + 1], 10);
  EXPECT_EQ(small[(10 * 64 + 20) * 3 + 2], 7);
  // Averaged over each 4x4 block (INTER_AREA), not sampled: one column in four is bright.
  cv::Mat stripes(256, 256, CV_8UC3, cv::Scalar(0, 0, 0));
  for (int y = 0; y < 256; ++y)
    for (int x = 3; x < 256; x += 4) stripes.at<cv::Vec3b>(y, x) = cv::Vec3b(200, 200, 200);
  ASSERT_TRUE(DecodeImage(ImageMsg(stripes, "bgr8"), 64, &small, &why)) << why;
  for (uint8_t v : small) ASSERT_EQ(v, 50);
  // mono8: grey in all three channels.
  cv::Mat gray(96, 128, CV_8UC1, cv::Scalar(77));
  std::vector<uint8_t> from_mono;
  ASSERT_TRUE(DecodeImage(ImageMsg(gray, "mono8"), 32, &from_mono, &why)) << why;
  ASSERT_EQ(from_mono.size(), 32u * 32 * 3);
  for (uint8_t v : from_mono) ASSERT_EQ(v, 77);
}

TEST(RobotSpecImages, CorruptImagesAreRejectedWithAClearError) {
  const cv::Mat bgr = Picture();
  std::vector<uint8_t> out;
  std::string why;
  // A truncated jpeg.
  sensor_msgs::CompressedImage jpeg = CompressedMsg(bgr, "jpeg");
  jpeg.data.resize(jpeg.data.size() / 2);
  EXPECT_FALSE(DecodeImage(jpeg, 64, &out, &why));
  EXPECT_NE(why.find("jpeg of " + std::to_string(jpeg.data.size()) +
                     " bytes without its end-of-image marker"),
            std::string::npos)
      << why;
  // A jpeg whose body is garbage.
  jpeg = CompressedMsg(bgr, "jpeg");
  for (size_t i = 20; i + 2 < jpeg.data.size(); ++i) jpeg.data[i] = static_cast<uint8_t>(i * 37);
  EXPECT_FALSE(DecodeImage(jpeg, 64, &out, &why));
  EXPECT_NE(why.find("jpeg of " + std::to_string(jpeg.data.size()) + " bytes does not decode"),
            std::string::npos)
      << why;
  // Bytes that are no image, and a format that is neither jpeg nor png.
  sensor_msgs::CompressedImage junk;
  junk.format = "jpeg";
  junk.data = {1, 2, 3, 4, 5};
  EXPECT_FALSE(DecodeImage(junk, 64, &out, &why));
  EXPECT_NE(why.find("5 bytes that are neither jpeg nor png"), std::string::npos) << why;
  junk = CompressedMsg(bgr, "png");
  junk.format = "tiff";
  EXPECT_FALSE(DecodeImage(junk, 64, &out, &why));
  EXPECT_NE(why.find("format 'tiff' (supported: jpeg, png)"), std::string::npos) << why;
  // A wrong encoding, and data shorter than step * height.
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  sensor_msgs::Image img = ImageMsg(rgb, "rgba8");
  EXPECT_FALSE(DecodeImage(img, 64, &out, &why));
  EXPECT_NE(why.find("encoding 'rgba8' (supported: rgb8, bgr8, mono8)"), std::string::npos) << why;
  img = ImageMsg(rgb, "rgb8");
  img.data.resize(100);
  EXPECT_FALSE(DecodeImage(img, 64, &out, &why));
  EXPECT_NE(why.find("rgb8 128x96: step 384 and 100 bytes of data"), std::string::npos) << why;
  // A sample names the spec's camera and topic.
  const RobotSpec spec = LoadRobotSpec(CameraSpecPath());
  TopicSample s;
  EXPECT_FALSE(DecodeImageSample(spec.images[0], img, ros::Time(1.0), &s, &why));
  EXPECT_EQ(why.rfind("image 'camera' (topic camera/image, sensor_msgs/Image): rgb8 128x96", 0), 0u)
      << why;
}

class SpecBagImages : public ::testing::Test {
 protected:
  void SetUp() override {
    ros::Time::init();
    dir_ = fs::temp_directory_path() /
           ("msspr_robot_spec_image_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  // The shipped camera spec reading the synthetic bag's standard camera in `format`.
  static RobotSpec Spec(const std::string& format) {
    std::string text = ReadFile(CameraSpecPath());
    text =
        testing_util::ReplaceOnce(text, "    topic: camera/image\n", "    topic: robot_camera\n");
    if (format == "png" || format == "jpeg")
      text = testing_util::ReplaceOnce(text, "    type: sensor_msgs/Image   #",
                                       "    type: sensor_msgs/CompressedImage   #");
    return ParseRobotSpec(text, "camera_" + format + ".yaml");
  }
  fs::path dir_;
};

TEST_F(SpecBagImages, ImagesThroughTheSpecEqualTheNativeImages) {
  const auto eps = test::MakeSynthEpisodes(2, 12, 41);
  for (const std::string format : {"rgb8", "bgr8", "png", "jpeg"}) {
    SCOPED_TRACE(format);
    test::SynthBagOptions o;
    o.images = true;
    o.camera_format = format;
    o.camera_scale = format == "rgb8" ? 1 : 2;
    const std::string bag = Path(format + ".bag");
    test::WriteSynthBag(bag, eps, o);
    std::vector<BagEpisode> native, via_spec;
    DatasetBagReader nr(bag);
    nr.ForEachEpisode([&](BagEpisode&& ep) { native.push_back(std::move(ep)); });
    SpecBagReader sr(Spec(format), {bag});
    sr.ForEachEpisode([&](BagEpisode&& ep) { via_spec.push_back(std::move(ep)); });
    const SpecBagReport& r = sr.report();
    EXPECT_TRUE(r.problems.empty()) << r.problems[0];
    ASSERT_EQ(native.size(), 2u);
    ASSERT_EQ(via_spec.size(), 2u);
    for (size_t e = 0; e < 2; ++e) {
      ASSERT_EQ(via_spec[e].num_steps, native[e].num_steps);
      ASSERT_EQ(native[e].image_size, 64);
      ASSERT_EQ(via_spec[e].image_size, 64);
      EXPECT_TRUE(via_spec[e].complete()) << via_spec[e].problems[0];
      ASSERT_EQ(via_spec[e].images.size(), native[e].images.size());
      EXPECT_EQ(via_spec[e].has_image, native[e].has_image);
      int worst = 0;
      for (size_t i = 0; i < native[e].images.size(); ++i)
        worst = std::max(worst,
                         std::abs(static_cast<int>(via_spec[e].images[i]) - native[e].images[i]));
      EXPECT_LE(worst, format == "jpeg" ? 24 : 0);
      for (size_t i = 0; i < native[e].observations.size(); ++i)
        ASSERT_NEAR(via_spec[e].observations[i], native[e].observations[i], 1e-5) << i;
    }
    // The camera's row: 10 Hz, every tick covered.
    ASSERT_EQ(r.fields.size(), 3u);  // position, camera, action
    EXPECT_TRUE(r.fields[1].image);
    EXPECT_EQ(r.fields[1].name, "camera");
    EXPECT_EQ(r.fields[1].messages, 24u);
    EXPECT_NEAR(r.fields[1].rate_hz, 10.0, 1.0);
    EXPECT_EQ(r.fields[1].covered_ticks, 24u);
    EXPECT_EQ(r.complete_ticks, 24u);
  }
}

TEST_F(SpecBagImages, BadImagesAreCountedAndSplitTheEpisode) {
  const auto eps = test::MakeSynthEpisodes(1, 20, 42);
  for (const std::string format : {"bgr8", "jpeg"}) {
    SCOPED_TRACE(format);
    test::SynthBagOptions o;
    o.images = true;
    o.camera_format = format;
    o.bad_image_steps = {6, 7, 8, 9};  // 0.4 s of bad images (stale_after 0.25 s)
    const std::string bag = Path(format + ".bag");
    test::WriteSynthBag(bag, eps, o);
    SpecBagReader sr(Spec(format), {bag});
    std::vector<BagEpisode> got;
    sr.ForEachEpisode([&](BagEpisode&& ep) { got.push_back(std::move(ep)); });
    ASSERT_EQ(got.size(), 1u);
    const SpecBagReport& r = sr.report();
    EXPECT_EQ(r.fields[1].bad_images, 4u);
    EXPECT_EQ(r.fields[1].messages, 16u);
    // Ticks 6, 7 hold the image of tick 5 (within stale_after); 8 and 9 are stale.
    EXPECT_EQ(r.fields[1].stale_ticks, 2u);
    EXPECT_EQ(got[0].Segments(), (std::vector<std::pair<int, int>>{{0, 8}, {10, 20}}));
    bool named = false;
    for (const auto& p : r.problems)
      named |= p.find(bag +
                      ": topic robot_camera (image 'camera'): 4 bad images rejected (first: image "
                      "'camera'") != std::string::npos;
    EXPECT_TRUE(named) << (r.problems.empty() ? "no problems" : r.problems[0]);
  }
}

}  // namespace
}  // namespace msspr::ros_bridge
