#include "msspr_core/progress.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <stdexcept>

namespace msspr {
namespace core {
namespace {

std::string FormatDuration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  const int64_t s = static_cast<int64_t>(seconds + 0.5);
  char buf[32];
  if (s >= 3600) {
    std::snprintf(buf, sizeof(buf), "%lld:%02lld:%02lld", static_cast<long long>(s / 3600),
                  static_cast<long long>((s / 60) % 60), static_cast<long long>(s % 60));
  } else {
    std::snprintf(buf, sizeof(buf), "%02lld:%02lld", static_cast<long long>(s / 60),
                  static_cast<long long>(s % 60));
  }
  return buf;
}

}  // namespace

ProgressBar::ProgressBar(int64_t first_step, int64_t total_steps, FILE* stream)
    : first_step_(first_step),
      total_(total_steps),
      stream_(stream),
      tty_(isatty(fileno(stream)) != 0),
      start_(std::chrono::steady_clock::now()) {}

void ProgressBar::Update(int64_t step, const std::vector<std::pair<std::string, double>>& metrics) {
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const int64_t done = step - first_step_;
  rate_ = elapsed > 0 ? done / elapsed : 0.0;
  const double eta = rate_ > 0 ? (total_ - step) / rate_ : NAN;
  std::ostringstream line;
  line.precision(4);
  if (tty_) {
    const int width = 24;
    const double frac = total_ > 0 ? static_cast<double>(step) / total_ : 1.0;
    const int fill = static_cast<int>(frac * width);
    line << "\r[" << std::string(fill, '#') << std::string(width - fill, '.') << "] ";
  }
  line << step << "/" << total_ << " " << std::fixed;
  line.precision(1);
  line << rate_ << " it/s eta " << FormatDuration(eta);
  line.unsetf(std::ios::fixed);
  line.precision(4);
  for (const auto& m : metrics) line << " " << m.first << "=" << m.second;
  if (tty_) {
    line << "\x1b[K";  // clear the rest of the line
    std::fputs(line.str().c_str(), stream_);
    line_open_ = true;
  } else {
    line << "\n";
    std::fputs(line.str().c_str(), stream_);
  }
  std::fflush(stream_);
}

void ProgressBar::Message(const std::string& text) {
  if (tty_ && line_open_) std::fputs("\n", stream_);
  line_open_ = false;
  std::fputs((text + "\n").c_str(), stream_);
  std::fflush(stream_);
}

void ProgressBar::Finish() {
  if (tty_ && line_open_) std::fputs("\n", stream_);
  line_open_ = false;
  std::fflush(stream_);
}

namespace {

// Replaces the file at `path` with `text` (a temporary file renamed over it).
void ReplaceFile(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << text;
    out.flush();
    if (!out) throw std::runtime_error(tmp + ": cannot write CSV file (disk full?)");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0)
    throw std::runtime_error(path + ": cannot replace it with " + tmp + ": " +
                             std::strerror(errno));
}

std::vector<std::string> SplitCsvLine(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) cells.push_back(cell);
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

// Rewrites `path` under the header `columns` when its own header differs.
void RemapCsvColumns(const std::string& path, const std::vector<std::string>& columns) {
  std::ifstream in(path);
  std::string header;
  if (!in || !std::getline(in, header)) return;
  std::string wanted;
  for (size_t i = 0; i < columns.size(); ++i) wanted += (i ? "," : "") + columns[i];
  if (header == wanted) return;
  const std::vector<std::string> old = SplitCsvLine(header);
  std::string text = wanted + "\n", line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    const std::vector<std::string> cells = SplitCsvLine(line);
    for (size_t i = 0; i < columns.size(); ++i) {
      std::string v = "nan";
      for (size_t j = 0; j < old.size() && j < cells.size(); ++j)
        if (old[j] == columns[i]) v = cells[j];
      text += (i ? "," : "") + v;
    }
    text += "\n";
  }
  in.close();
  ReplaceFile(path, text);
}

}  // namespace

CsvWriter::CsvWriter(const std::string& path, const std::vector<std::string>& columns)
    : path_(path), num_columns_(columns.size()) {
  struct stat st;
  const bool fresh = stat(path.c_str(), &st) != 0 || st.st_size == 0;
  if (!fresh) RemapCsvColumns(path, columns);
  out_.open(path, std::ios::app);
  if (!out_) throw std::runtime_error(path + ": cannot open CSV file for writing");
  if (fresh) WriteRow(columns);
}

void CsvWriter::Write(const std::vector<double>& values) {
  std::vector<std::string> s;
  s.reserve(values.size());
  for (double v : values) {
    std::ostringstream o;
    o.precision(9);
    o << v;
    s.push_back(o.str());
  }
  WriteRow(s);
}

void CsvWriter::WriteRow(const std::vector<std::string>& values) {
  if (values.size() != num_columns_) {
    throw std::runtime_error(path_ + ": CSV row has " + std::to_string(values.size()) +
                             " values, header has " + std::to_string(num_columns_));
  }
  for (size_t i = 0; i < values.size(); ++i) out_ << (i ? "," : "") << values[i];
  out_ << "\n";
  out_.flush();
  if (!out_) {
    throw std::runtime_error(
        path_ + ": cannot write CSV row (" +
        (errno ? std::string(std::strerror(errno)) : std::string("stream error")) +
        "; disk full?)");
  }
}

int64_t TruncateCsvRows(const std::string& path, int64_t max_step) {
  std::ifstream in(path);
  if (!in) return 0;  // no file: nothing to drop
  std::string header, line, kept;
  if (!std::getline(in, header)) return 0;
  kept = header + "\n";
  int64_t dropped = 0;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    char* end = nullptr;
    const double step = std::strtod(line.c_str(), &end);
    // A row cut short by a kill (no step, or no newline at the end) is dropped too.
    if (end == line.c_str() || step > static_cast<double>(max_step) || in.eof()) {
      ++dropped;
      continue;
    }
    kept += line + "\n";
  }
  in.close();
  if (dropped == 0) return 0;
  ReplaceFile(path, kept);
  return dropped;
}

}  // namespace core
}  // namespace msspr
