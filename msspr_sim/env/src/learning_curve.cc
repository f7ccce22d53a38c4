#include "msspr_sim/learning_curve.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace msspr::sim {
namespace {

using Series = std::map<double, double>;  // step -> value

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> out;
  std::stringstream s(line);
  std::string cell;
  while (std::getline(s, cell, ',')) out.push_back(cell);
  return out;
}

double ParseNumber(const std::string& text, const std::string& path, int line_no) {
  try {
    size_t used = 0;
    const double v = std::stod(text, &used);
    if (used == text.size()) return v;
  } catch (const std::exception&) {
  }
  if (text == "nan" || text == "-nan") return std::numeric_limits<double>::quiet_NaN();
  throw std::runtime_error(path + ":" + std::to_string(line_no) + ": not a number: '" + text + "'");
}

// eval.csv: name -> series.
std::map<std::string, Series> ReadEval(const std::string& path) {
  std::map<std::string, Series> out;
  std::ifstream in(path);
  if (!in) return out;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line_no == 1 || line.empty()) continue;  // header
    const auto cells = SplitCsv(line);
    if (cells.size() != 3)
      throw std::runtime_error(path + ":" + std::to_string(line_no) + ": expected step,name,value");
    out[cells[1]][ParseNumber(cells[0], path, line_no)] = ParseNumber(cells[2], path, line_no);
  }
  return out;
}

// metrics.csv: the named columns' series.
std::map<std::string, Series> ReadMetrics(const std::string& path,
                                          const std::vector<std::string>& names) {
  std::map<std::string, Series> out;
  std::ifstream in(path);
  if (!in) return out;
  std::string line;
  if (!std::getline(in, line)) return out;
  const auto header = SplitCsv(line);
  const auto col = [&](const std::string& n) {
    return static_cast<int>(std::find(header.begin(), header.end(), n) - header.begin());
  };
  const int step_col = col("step");
  if (step_col >= static_cast<int>(header.size()))
    throw std::runtime_error(path + ": no 'step' column");
  int line_no = 1;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty()) continue;
    const auto cells = SplitCsv(line);
    if (cells.size() != header.size())
      throw std::runtime_error(path + ":" + std::to_string(line_no) + ": " +
                               std::to_string(cells.size()) + " cells, the header has " +
                               std::to_string(header.size()));
    const double step = ParseNumber(cells[step_col], path, line_no);
    for (const auto& n : names) {
      const int c = col(n);
      if (c >= static_cast<int>(header.size())) continue;
      const double v = ParseNumber(cells[c], path, line_no);
      if (std::isfinite(v)) out[n][step] = v;
    }
  }
  return out;
}

struct Panel {
  cv::Rect area;
  double x0, x1, y0, y1;
  cv::Point At(double x, double y) const {
    const double fx = x1 > x0 ? (x - x0) / (x1 - x0) : 0.5;
    const double fy = y1 > y0 ? (y - y0) / (y1 - y0) : 0.5;
    return {area.x + static_cast<int>(std::lround(fx * area.width)),
            area.y + area.height - static_cast<int>(std::lround(fy * area.height))};
  }
};

void DrawSeries(cv::Mat& img, const Panel& p, const Series& s, const cv::Scalar& color,
                int thickness, bool log_y) {
  std::vector<cv::Point> pts;
  for (const auto& [x, y] : s) {
    const double v = log_y ? std::log10(std::max(y, 1e-12)) : y;
    pts.push_back(p.At(x, v));
  }
  if (pts.size() == 1) cv::circle(img, pts[0], 3, color, cv::FILLED, cv::LINE_AA);
  if (pts.size() > 1) cv::polylines(img, pts, false, color, thickness, cv::LINE_AA);
}

std::string Fmt(const char* f, double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

}  // namespace

bool SaveLearningCurvePlot(const std::string& eval_csv, const std::string& metrics_csv,
                           const std::string& png_path) {
  const auto eval = ReadEval(eval_csv);
  const std::vector<std::string> losses{"critic", "repr"};
  const auto metrics = ReadMetrics(metrics_csv, losses);
  std::map<std::string, Series> success;
  for (const auto& [name, s] : eval) {
    // Official tasks one by one, and the mean over custom tasks (--eval-tasks-file) as one line.
    if (name == "mean_success" || name == "mean_success_custom" ||
        name.rfind("success_task", 0) == 0)
      success[name] = s;
  }
  if (success.empty() && metrics.empty()) return false;

  double x_max = 1;
  using Group = std::map<std::string, Series>;
  for (const Group* group : std::initializer_list<const Group*>{&success, &metrics})
    for (const auto& kv : *group)
      if (!kv.second.empty()) x_max = std::max(x_max, kv.second.rbegin()->first);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& kv : metrics)
    for (const auto& [x, y] : kv.second) {
      lo = std::min(lo, std::log10(std::max(y, 1e-12)));
      hi = std::max(hi, std::log10(std::max(y, 1e-12)));
    }
  if (!std::isfinite(lo)) lo = -1, hi = 1;
  lo = std::floor(lo), hi = std::max(std::ceil(hi), lo + 1);

  const int width = 760, left = 60, right = 150, panel_h = 220, top = 34, gap = 50;
  cv::Mat img(top + 2 * panel_h + gap + 40, width, CV_8UC3, cv::Scalar(255, 255, 255));
  const auto font = cv::FONT_HERSHEY_SIMPLEX;
  const Panel sp{{left, top, width - left - right, panel_h}, 0, x_max, 0, 100};
  const Panel lp{{left, top + panel_h + gap, width - left - right, panel_h}, 0, x_max, lo, hi};
  const cv::Scalar grid(225, 225, 225), text(60, 60, 60);
  cv::putText(img, "success (%) by step", {left, top - 12}, font, 0.5, {0, 0, 0}, 1, cv::LINE_AA);
  cv::putText(img, "losses (log10) by step", {left, lp.area.y - 12}, font, 0.5, {0, 0, 0}, 1,
              cv::LINE_AA);
  for (int k = 0; k <= 4; ++k) {
    const cv::Point a = sp.At(0, 25 * k), b = sp.At(x_max, 25 * k);
    cv::line(img, a, b, grid, 1);
    cv::putText(img, std::to_string(25 * k), {left - 34, a.y + 4}, font, 0.4, text, 1, cv::LINE_AA);
  }
  for (double e = lo; e <= hi + 1e-9; e += 1) {
    const cv::Point a = lp.At(0, e), b = lp.At(x_max, e);
    cv::line(img, a, b, grid, 1);
    cv::putText(img, Fmt("1e%.0f", e), {left - 44, a.y + 4}, font, 0.4, text, 1, cv::LINE_AA);
  }
  for (int k = 0; k <= 4; ++k) {
    const double x = x_max * k / 4;
    for (const Panel* p : {&sp, &lp}) {
      const cv::Point a = p->At(x, p->y0);
      cv::line(img, a, {a.x, a.y + 4}, text, 1);
      cv::putText(img, Fmt("%.0f", x), {a.x - 16, a.y + 18}, font, 0.4, text, 1, cv::LINE_AA);
    }
  }
  const cv::Scalar task_colors[] = {{200, 120, 40}, {40, 160, 40},  {40, 40, 200}, {160, 60, 160},
                                    {20, 160, 200}, {120, 120, 20}, {90, 90, 90}};
  int legend_y = top + 10, i = 0;
  for (const auto& [name, s] : success) {
    if (name == "mean_success") continue;
    Series pct;
    for (const auto& [x, y] : s) pct[x] = 100 * y;
    const cv::Scalar c = task_colors[i++ % 7];
    DrawSeries(img, sp, pct, c, 1, false);
    const std::string label =
        name == "mean_success_custom" ? "custom" : name.substr(std::string("success_").size());
    cv::putText(img, label, {width - right + 12, legend_y}, font, 0.42, c, 1, cv::LINE_AA);
    legend_y += 18;
  }
  if (success.count("mean_success")) {
    Series pct;
    for (const auto& [x, y] : success.at("mean_success")) pct[x] = 100 * y;
    DrawSeries(img, sp, pct, {0, 0, 0}, 3, false);
    const double last = pct.rbegin()->second;
    cv::putText(img, "mean " + Fmt("%.0f%%", last), {width - right + 12, legend_y + 6}, font, 0.5,
                {0, 0, 0}, 1, cv::LINE_AA);
  }
  const cv::Scalar loss_colors[] = {{40, 40, 200}, {200, 120, 40}};
  for (size_t k = 0; k < losses.size(); ++k) {
    auto it = metrics.find(losses[k]);
    if (it == metrics.end()) continue;
    DrawSeries(img, lp, it->second, loss_colors[k], 1, true);
    cv::putText(img, losses[k], {width - right + 12, lp.area.y + 14 + 18 * static_cast<int>(k)},
                font, 0.45, loss_colors[k], 1, cv::LINE_AA);
  }
  // Written beside and renamed: a viewer never sees half a file.
  const std::string tmp = png_path + ".tmp.png";
  if (!cv::imwrite(tmp, img)) throw std::runtime_error(png_path + ": cannot write PNG");
  if (std::rename(tmp.c_str(), png_path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error(png_path + ": cannot rename " + tmp + " onto it");
  }
  return true;
}

}  // namespace msspr::sim
