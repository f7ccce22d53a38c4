#include "msspr_sim/maze_plot.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace msspr::sim {

void SaveTrajectoryPlot(const MazeMap& map,
                        const std::vector<std::vector<Eigen::Vector2d>>& trajectories,
                        const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>>& start_goals,
                        const std::vector<bool>& success, const std::string& png_path,
                        int pixels_per_cell) {
  if (pixels_per_cell < 4) throw std::invalid_argument("SaveTrajectoryPlot: pixels_per_cell < 4");
  const int ppc = pixels_per_cell;
  const double scale = ppc / kCellSize;  // pixels per metre
  // Image row 0 is the top of the map (row i = 0), as in benchmark.md's maps.
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
  bool ok = false;
  try {
    ok = cv::imwrite(png_path, img);
  } catch (const cv::Exception& e) {
    throw std::runtime_error("SaveTrajectoryPlot: cannot write " + png_path + ": " + e.what());
  }
  if (!ok) throw std::runtime_error("SaveTrajectoryPlot: cannot write " + png_path);
}

}  // namespace msspr::sim
