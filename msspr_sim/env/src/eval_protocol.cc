#include "msspr_sim/eval_protocol.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

namespace msspr::sim {

namespace {

void MakeParentDirs(const std::string& path) {
  const std::filesystem::path dir = std::filesystem::path(path).parent_path();
  if (dir.empty()) return;
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec)
    throw std::runtime_error(path + ": cannot create directory " + dir.string() + ": " +
                             ec.message());
}

std::string Escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out;
}

}  // namespace

void FinalizeReport(EvalReport* report) {
  double sum = 0.0;
  for (const auto& t : report->tasks) sum += t.success;
  report->mean_success = report->tasks.empty() ? 0.0 : sum / report->tasks.size();
}

namespace {

// map: names the cells of maze tasks without starts and goals (null: none).
std::string ReportJson(const MazeMap* map, const EvalReport& r) {
  std::ostringstream j;
  j << std::fixed << std::setprecision(4);
  j << "{\n  \"env\": \"" << Escape(r.env) << "\",\n  \"agent\": \"" << Escape(r.agent) << "\",";
  if (!r.robot.empty()) j << "\n  \"robot\": \"" << Escape(r.robot) << "\",";
  if (!r.observation_mode.empty())
    j << "\n  \"observation_mode\": \"" << Escape(r.observation_mode) << "\",";
  j << "\n  \"episodes_per_task\": " << r.episodes_per_task << ",\n  \"max_steps\": " << r.max_steps
    << ",\n  \"seed\": " << r.seed << ",\n  \"tasks\": [\n";
  for (size_t i = 0; i < r.tasks.size(); ++i) {
    const auto& t = r.tasks[i];
    j << "    {\"task_id\": " << t.task_id;
    if (t.start.size() == 2 && t.goal.size() == 2) {
      j << ", \"start\": [" << t.start[0] << ", " << t.start[1] << "], \"goal\": [" << t.goal[0]
        << ", " << t.goal[1] << "]";
    } else if (map != nullptr && t.task_id >= 1 &&
               t.task_id <= static_cast<int>(map->Tasks().size())) {
      const auto& task = map->Tasks()[static_cast<size_t>(t.task_id - 1)];
      j << ", \"start_cell\": [" << task.start.i << ", " << task.start.j << "], \"goal_cell\": ["
        << task.goal.i << ", " << task.goal.j << "]";
    }
    j << ", \"success\": " << t.success << ", \"episodes\": " << t.episodes
      << ", \"mean_steps_successful\": " << t.mean_steps_successful << "}"
      << (i + 1 < r.tasks.size() ? "," : "") << "\n";
  }
  j << "  ],\n  \"mean_success\": " << r.mean_success
    << ",\n  \"stalled_episodes\": " << r.stalled_episodes
    << ",\n  \"wall_time_s\": " << r.wall_time_s << "\n}\n";
  return j.str();
}

// A puzzle board's states (0 / 1, row by row) as "110/101/011".
std::string BoardText(const std::vector<double>& states) {
  const size_t side = static_cast<size_t>(std::lround(std::sqrt(states.size())));
  std::string text;
  for (size_t k = 0; k < states.size(); ++k) {
    if (k > 0 && side > 0 && k % side == 0) text += '/';
    text += states[k] > 0.5 ? '1' : '0';
  }
  return text;
}

std::string ReportTable(const MazeMap* map, const EvalReport& r) {
  std::ostringstream t;
  t << "\n  " << r.env << " / " << r.agent << ": " << r.episodes_per_task << " episodes per task, "
    << r.max_steps << " steps at most\n  task  start -> goal     success   mean steps to goal\n";
  char line[160];
  for (const auto& x : r.tasks) {
    std::string cells = "";
    if (x.start.size() == 2 && x.goal.size() == 2) {
      std::snprintf(line, sizeof line, "(%.2f,%.2f)->(%.2f,%.2f)", x.start[0], x.start[1],
                    x.goal[0], x.goal[1]);
      cells = line;
    } else if (x.start.size() == x.goal.size() && x.start.size() > 2) {
      cells = BoardText(x.start) + "->" + BoardText(x.goal);  // the puzzles' boards
    } else if (map != nullptr && x.task_id >= 1 &&
               x.task_id <= static_cast<int>(map->Tasks().size())) {
      const auto& task = map->Tasks()[static_cast<size_t>(x.task_id - 1)];
      std::snprintf(line, sizeof line, "(%d,%d) -> (%d,%d)", task.start.i, task.start.j,
                    task.goal.i, task.goal.j);
      cells = line;
    }
    std::snprintf(line, sizeof line, "  %4d  %-16s %6.1f%%   %8.1f\n", x.task_id, cells.c_str(),
                  100 * x.success, x.mean_steps_successful);
    t << line;
  }
  std::snprintf(line, sizeof line, "  mean success: %.1f%%   (%.1f s)\n", 100 * r.mean_success,
                r.wall_time_s);
  t << line;
  return t.str();
}

}  // namespace

std::string EvalReportJson(const MazeMap& map, const EvalReport& r) { return ReportJson(&map, r); }
std::string EvalReportJson(const EvalReport& r) { return ReportJson(nullptr, r); }
std::string EvalReportTable(const MazeMap& map, const EvalReport& r) {
  return ReportTable(&map, r);
}
std::string EvalReportTable(const EvalReport& r) { return ReportTable(nullptr, r); }

void WriteTextFile(const std::string& path, const std::string& text) {
  MakeParentDirs(path);
  std::ofstream f(path);
  f << text;
  f.close();
  if (!f) throw std::runtime_error(path + ": cannot write");
}

void SaveSuccessPlot(const EvalReport& r, const std::string& png_path) {
  const int n = static_cast<int>(r.tasks.size());
  const int bar = 60, gap = 20, left = 50, top = 40, height = 200;
  const int width = left + n * (bar + gap) + gap + 110;  // room for the mean label
  cv::Mat img(top + height + 50, width, CV_8UC3, cv::Scalar(255, 255, 255));
  const auto font = cv::FONT_HERSHEY_SIMPLEX;
  cv::putText(img, r.env + " / " + r.agent, {10, 20}, font, 0.45, {0, 0, 0}, 1, cv::LINE_AA);
  for (int k = 0; k <= 4; ++k) {  // grid at 0, 25, 50, 75, 100 %
    const int y = top + height - k * height / 4;
    cv::line(img, {left, y}, {width - 100, y}, {220, 220, 220}, 1);
    cv::putText(img, std::to_string(25 * k), {left - 32, y + 4}, font, 0.4, {80, 80, 80}, 1,
                cv::LINE_AA);
  }
  for (int i = 0; i < n; ++i) {
    const int x = left + gap + i * (bar + gap);
    const int h = static_cast<int>(r.tasks[i].success * height + 0.5);
    cv::rectangle(img, {x, top + height - h}, {x + bar, top + height}, {60, 160, 60}, cv::FILLED);
    char label[32];
    std::snprintf(label, sizeof label, "%.0f%%", 100 * r.tasks[i].success);
    cv::putText(img, label, {x + 8, top + height - h - 6}, font, 0.45, {0, 0, 0}, 1, cv::LINE_AA);
    cv::putText(img, "task " + std::to_string(r.tasks[i].task_id), {x + 4, top + height + 20}, font,
                0.45, {0, 0, 0}, 1, cv::LINE_AA);
  }
  const int ym = top + height - static_cast<int>(r.mean_success * height + 0.5);
  cv::line(img, {left, ym}, {width - 100, ym}, {40, 40, 200}, 2);
  char mean[48];
  std::snprintf(mean, sizeof mean, "mean %.0f%%", 100 * r.mean_success);
  cv::putText(img, mean, {width - 96, ym + 4}, font, 0.45, {40, 40, 200}, 1, cv::LINE_AA);
  MakeParentDirs(png_path);
  if (!cv::imwrite(png_path, img)) throw std::runtime_error(png_path + ": cannot write PNG");
}

}  // namespace msspr::sim
