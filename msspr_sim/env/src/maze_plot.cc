#include "msspr_sim/maze_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace msspr::sim {

namespace {

// Writes img as a PNG; throws std::runtime_error naming `who` and the path.
void WritePng(const cv::Mat& img, const std::string& png_path, const char* who) {
  bool ok = false;
  try {
    ok = cv::imwrite(png_path, img);
  } catch (const cv::Exception& e) {
    throw std::runtime_error(std::string(who) + ": cannot write " + png_path + ": " + e.what());
  }
  if (!ok) throw std::runtime_error(std::string(who) + ": cannot write " + png_path);
}

}  // namespace

void SaveTrajectoryPlot(const MazeMap& map,
                        const std::vector<std::vector<Eigen::Vector2d>>& trajectories,
                        const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>>& start_goals,
                        const std::vector<bool>& success, const std::string& png_path,
                        int pixels_per_cell) {
  if (pixels_per_cell < 4) throw std::invalid_argument("SaveTrajectoryPlot: pixels_per_cell < 4");
  const int ppc = pixels_per_cell;
  const double scale = ppc / kCellSize;  // pixels per metre
  // Image row 0 is the top of the map (row i = 0), as OGBench draws its maps.
  cv::Mat img(map.rows() * ppc, map.cols() * ppc, CV_8UC3, cv::Scalar(235, 235, 235));
  for (int i = 0; i < map.rows(); ++i) {
    for (int j = 0; j < map.cols(); ++j) {
      if (map.IsWall({i, j})) {
        cv::rectangle(img, cv::Rect(j * ppc, i * ppc, ppc, ppc), cv::Scalar(70, 70, 70),
                      cv::FILLED);
      }
    }
  }
  // World (x, y) -> pixel: cell (i, j) spans x in [4j - 6, 4j - 2].
  const auto to_px = [&](const Eigen::Vector2d& p) {
    return cv::Point2d((p.x() + 1.5 * kCellSize) * scale, (p.y() + 1.5 * kCellSize) * scale);
  };
  const int shift = 4;  // sub-pixel precision for anti-aliased drawing
  const auto fixed = [&](const cv::Point2d& p) {
    return cv::Point(static_cast<int>(std::lround(p.x * (1 << shift))),
                     static_cast<int>(std::lround(p.y * (1 << shift))));
  };
  const int thickness = std::max(1, ppc / 20);
  for (size_t k = 0; k < trajectories.size(); ++k) {
    cv::Scalar color(200, 90, 30);  // BGR: blue when success is unknown
    if (k < success.size()) color = success[k] ? cv::Scalar(40, 160, 40) : cv::Scalar(40, 40, 210);
    std::vector<cv::Point> pts;
    for (const Eigen::Vector2d& p : trajectories[k]) pts.push_back(fixed(to_px(p)));
    if (pts.size() >= 2) {
      cv::polylines(img, pts, false, color, thickness, cv::LINE_AA, shift);
    }
  }
  const int r = std::max(2, ppc / 8);
  for (const auto& [start, goal] : start_goals) {
    cv::circle(img, fixed(to_px(start)), r << shift, cv::Scalar(0, 0, 0), thickness, cv::LINE_AA,
               shift);
    const cv::Point2d g = to_px(goal);
    cv::line(img, fixed(g + cv::Point2d(-r, -r)), fixed(g + cv::Point2d(r, r)),
             cv::Scalar(0, 140, 255), thickness + 1, cv::LINE_AA, shift);
    cv::line(img, fixed(g + cv::Point2d(-r, r)), fixed(g + cv::Point2d(r, -r)),
             cv::Scalar(0, 140, 255), thickness + 1, cv::LINE_AA, shift);
  }
  WritePng(img, png_path, "SaveTrajectoryPlot");
}

namespace {

// BGR colour of t in [0, 1].
cv::Vec3b ScaleColor(double t, ColorScale scale) {
  t = std::clamp(t, 0.0, 1.0);
  if (scale == ColorScale::kDiverging) {  // blue -> white -> red
    const double u = std::abs(2.0 * t - 1.0);
    const auto mix = [&](double from, double to) {
      return static_cast<uchar>(std::lround(from + (to - from) * u));
    };
    return t < 0.5 ? cv::Vec3b(mix(255, 180), mix(255, 60), mix(255, 30))
                   : cv::Vec3b(mix(255, 30), mix(255, 40), mix(255, 200));
  }
  cv::Mat one(1, 1, CV_8UC1, cv::Scalar(static_cast<int>(std::lround(255.0 * t)))), out;
  cv::applyColorMap(one, out, cv::COLORMAP_VIRIDIS);
  return out.at<cv::Vec3b>(0, 0);
}

std::string Short(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

}  // namespace

void SaveScalarFieldPlot(const MazeMap& map, const std::vector<Eigen::Vector2d>& points,
                         const std::vector<double>& values, double patch_m, double lo, double hi,
                         ColorScale scale, const Eigen::Vector2d& goal, const std::string& title,
                         const std::string& png_path, int pixels_per_cell) {
  if (points.size() != values.size())
    throw std::invalid_argument("SaveScalarFieldPlot: " + std::to_string(points.size()) +
                                " points but " + std::to_string(values.size()) + " values");
  if (!(lo < hi)) throw std::invalid_argument("SaveScalarFieldPlot: needs lo < hi");
  if (pixels_per_cell < 8) throw std::invalid_argument("SaveScalarFieldPlot: pixels_per_cell < 8");
  const int ppc = pixels_per_cell, top = 34, bar_w = 22, right = 90;
  const double ppm = ppc / kCellSize;
  const int mw = map.cols() * ppc, mh = map.rows() * ppc;
  cv::Mat img(mh + top + 8, mw + right, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::Mat maze = img(cv::Rect(0, top, mw, mh));
  for (int i = 0; i < map.rows(); ++i)
    for (int j = 0; j < map.cols(); ++j)
      cv::rectangle(maze, cv::Rect(j * ppc, i * ppc, ppc, ppc),
                    map.IsWall({i, j}) ? cv::Scalar(70, 70, 70) : cv::Scalar(225, 225, 225),
                    cv::FILLED);
  const auto to_px = [&](const Eigen::Vector2d& p) {
    return cv::Point2d((p.x() + 1.5 * kCellSize) * ppm, (p.y() + 1.5 * kCellSize) * ppm);
  };
  const double half = 0.5 * patch_m * ppm;
  for (size_t k = 0; k < points.size(); ++k) {
    if (!std::isfinite(values[k])) continue;
    const cv::Point2d c = to_px(points[k]);
    const cv::Vec3b col = ScaleColor((values[k] - lo) / (hi - lo), scale);
    cv::rectangle(maze,
                  cv::Rect(cv::Point(static_cast<int>(std::lround(c.x - half)),
                                     static_cast<int>(std::lround(c.y - half))),
                           cv::Point(static_cast<int>(std::lround(c.x + half)),
                                     static_cast<int>(std::lround(c.y + half)))),
                  cv::Scalar(col[0], col[1], col[2]), cv::FILLED);
  }
  // Walls again on top, so that patches never hide them.
  for (int i = 0; i < map.rows(); ++i)
    for (int j = 0; j < map.cols(); ++j)
      if (map.IsWall({i, j}))
        cv::rectangle(maze, cv::Rect(j * ppc, i * ppc, ppc, ppc), cv::Scalar(70, 70, 70),
                      cv::FILLED);
  const cv::Point2d g = to_px(goal);
  const int r = std::max(4, ppc / 6);
  cv::drawMarker(maze, cv::Point(static_cast<int>(g.x), static_cast<int>(g.y)), cv::Scalar(0, 0, 0),
                 cv::MARKER_STAR, 2 * r, 2, cv::LINE_AA);
  cv::circle(maze, cv::Point(static_cast<int>(g.x), static_cast<int>(g.y)), r,
             cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  // Colour bar: hi at the top.
  const int bx = mw + 10;
  for (int y = 0; y < mh; ++y) {
    const cv::Vec3b col = ScaleColor(1.0 - static_cast<double>(y) / std::max(1, mh - 1), scale);
    cv::line(img, cv::Point(bx, top + y), cv::Point(bx + bar_w, top + y),
             cv::Scalar(col[0], col[1], col[2]));
  }
  cv::rectangle(img, cv::Rect(bx, top, bar_w, mh), cv::Scalar(0, 0, 0), 1);
  const auto text = [&](const std::string& s, cv::Point at, double size) {
    cv::putText(img, s, at, cv::FONT_HERSHEY_SIMPLEX, size, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  };
  text(Short(hi), cv::Point(bx + bar_w + 4, top + 12), 0.4);
  text(Short(lo), cv::Point(bx + bar_w + 4, top + mh), 0.4);
  if (scale == ColorScale::kDiverging) text("0", cv::Point(bx + bar_w + 4, top + mh / 2 + 4), 0.4);
  text(title, cv::Point(6, 22), 0.55);
  WritePng(img, png_path, "SaveScalarFieldPlot");
}

}  // namespace msspr::sim
