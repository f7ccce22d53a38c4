// Camera images into the network's input (DecodeImage, DecodeImageSample): the one
// decoding and resizing that training and serving share.
#include <algorithm>
#include <cctype>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "msspr_bags/dataset_bag.h"  // kMaxImageSide
#include "msspr_robot_interface/robot_fields.h"

namespace msspr::ros_bridge {

namespace {

// The one conversion of every camera image: `src` (rgb8, bgr8 or gray) to rgb8
// size x size, INTER_AREA when it has another size.
bool ToNetworkImage(const cv::Mat& src, bool bgr, int size, std::vector<uint8_t>* rgb,
                    std::string* why) {
  if (src.empty() || src.depth() != CV_8U || (src.channels() != 1 && src.channels() != 3)) {
    *why = "not an 8-bit image of 1 or 3 channels";
    return false;
  }
  if (src.cols > static_cast<int>(kMaxImageSide) || src.rows > static_cast<int>(kMaxImageSide)) {
    *why = std::to_string(src.cols) + "x" + std::to_string(src.rows) + " is larger than " +
           std::to_string(kMaxImageSide) + " pixels a side";
    return false;
  }
  try {
    cv::Mat color;
    if (src.channels() == 1)
      cv::cvtColor(src, color, cv::COLOR_GRAY2RGB);
    else if (bgr)
      cv::cvtColor(src, color, cv::COLOR_BGR2RGB);
    else
      color = src;
    rgb->resize(static_cast<size_t>(size) * size * 3);
    cv::Mat out(size, size, CV_8UC3, rgb->data());
    if (color.cols == size && color.rows == size)
      color.copyTo(out);
    else
      cv::resize(color, out, cv::Size(size, size), 0, 0, cv::INTER_AREA);
    if (out.data != rgb->data()) {  // (never: out has the right size and type)
      *why = "resize did not write in place";
      return false;
    }
  } catch (const cv::Exception& e) {
    *why = std::string("OpenCV: ") + e.what();
    return false;
  }
  return true;
}

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

bool DecodeImage(const sensor_msgs::Image& msg, int size, std::vector<uint8_t>* rgb,
                 std::string* why) {
  int channels = 0;
  if (msg.encoding == "rgb8" || msg.encoding == "bgr8")
    channels = 3;
  else if (msg.encoding == "mono8")
    channels = 1;
  else {
    *why = "encoding '" + msg.encoding + "' (supported: rgb8, bgr8, mono8)";
    return false;
  }
  if (msg.width == 0 || msg.height == 0 || msg.width > kMaxImageSide ||
      msg.height > kMaxImageSide) {
    *why = "size " + std::to_string(msg.width) + "x" + std::to_string(msg.height) + " (1.." +
           std::to_string(kMaxImageSide) + " a side)";
    return false;
  }
  if (msg.step < msg.width * channels ||
      msg.data.size() < static_cast<size_t>(msg.step) * msg.height) {
    *why = msg.encoding + " " + std::to_string(msg.width) + "x" + std::to_string(msg.height) +
           ": step " + std::to_string(msg.step) + " and " + std::to_string(msg.data.size()) +
           " bytes of data (needs step >= " + std::to_string(msg.width * channels) +
           " and step * height bytes)";
    return false;
  }
  const cv::Mat src(static_cast<int>(msg.height), static_cast<int>(msg.width),
                    channels == 3 ? CV_8UC3 : CV_8UC1, const_cast<uint8_t*>(msg.data.data()),
                    msg.step);
  if (!ToNetworkImage(src, msg.encoding == "bgr8", size, rgb, why)) {
    *why = msg.encoding + ": " + *why;
    return false;
  }
  return true;
}

bool DecodeImage(const sensor_msgs::CompressedImage& msg, int size, std::vector<uint8_t>* rgb,
                 std::string* why) {
  // format: "jpeg", "png", or image_transport's "bgr8; jpeg compressed bgr8".
  const std::string format = Lower(msg.format);
  const bool jpeg_named =
      format.find("jpeg") != std::string::npos || format.find("jpg") != std::string::npos;
  const bool png_named = format.find("png") != std::string::npos;
  if (!format.empty() && !jpeg_named && !png_named) {
    *why = "format '" + msg.format + "' (supported: jpeg, png)";
    return false;
  }
  const auto& d = msg.data;
  const bool jpeg = d.size() >= 3 && d[0] == 0xFF && d[1] == 0xD8 && d[2] == 0xFF;
  const bool png = d.size() >= 8 && d[0] == 0x89 && d[1] == 'P' && d[2] == 'N' && d[3] == 'G';
  if (!jpeg && !png) {
    *why = "format '" + msg.format + "': " + std::to_string(d.size()) +
           " bytes that are neither jpeg nor png";
    return false;
  }
  if (jpeg) {
    // libjpeg decodes a truncated file with a warning (grey rows): require the end-of-image marker.
    bool eoi = false;
    for (size_t i = d.size() >= 34 ? d.size() - 34 : 0; i + 1 < d.size() && !eoi; ++i)
      eoi = d[i] == 0xFF && d[i + 1] == 0xD9;
    if (!eoi) {
      *why = "jpeg of " + std::to_string(d.size()) +
             " bytes without its end-of-image marker (truncated)";
      return false;
    }
  }
  cv::Mat decoded;
  try {
    decoded = cv::imdecode(
        cv::Mat(1, static_cast<int>(d.size()), CV_8UC1, const_cast<uint8_t*>(d.data())),
        cv::IMREAD_COLOR);
  } catch (const cv::Exception&) {
    decoded = cv::Mat();
  }
  if (decoded.empty()) {
    *why = std::string(jpeg ? "jpeg" : "png") + " of " + std::to_string(d.size()) +
           " bytes does not decode";
    return false;
  }
  if (!ToNetworkImage(decoded, /*bgr=*/true, size, rgb, why)) {
    *why = std::string(jpeg ? "jpeg: " : "png: ") + *why;
    return false;
  }
  return true;
}

template <class M>
bool DecodeImageSample(const SpecImage& im, const M& msg, const ros::Time& receipt,
                       TopicSample* out, std::string* why) {
  out->values.clear();
  out->receipt = receipt;
  out->stamp = msg.header.stamp;
  if (!DecodeImage(msg, im.size, &out->pixels, why)) {
    *why = "image '" + im.name + "' (topic " + im.topic + ", " + im.type + "): " + *why;
    return false;
  }
  return true;
}
template bool DecodeImageSample<sensor_msgs::Image>(const SpecImage&, const sensor_msgs::Image&,
                                                    const ros::Time&, TopicSample*, std::string*);
template bool DecodeImageSample<sensor_msgs::CompressedImage>(const SpecImage&,
                                                              const sensor_msgs::CompressedImage&,
                                                              const ros::Time&, TopicSample*,
                                                              std::string*);

}  // namespace msspr::ros_bridge
