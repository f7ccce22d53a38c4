// Training progress on the terminal and in CSV files. No torch.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace msspr {
namespace core {

// Prints progress: on a TTY one self-overwriting line with a bar, steps/s,
// ETA and the latest metrics; otherwise (log files, pipes) a plain line per
// call. `stream` defaults to stderr.
class ProgressBar {
 public:
  ProgressBar(int64_t first_step, int64_t total_steps, FILE* stream = stderr);
  // Reports the state after `step` steps; metrics are printed in order.
  void Update(int64_t step, const std::vector<std::pair<std::string, double>>& metrics);
  // Prints a message on its own line (keeps the bar intact on a TTY).
  void Message(const std::string& text);
  // Ends the bar's line on a TTY.
  void Finish();
  double steps_per_second() const { return rate_; }

 private:
  int64_t first_step_;
  int64_t total_;
  FILE* stream_;
  bool tty_;
  bool line_open_ = false;
  double rate_ = 0.0;
  std::chrono::steady_clock::time_point start_;
};

// Appends rows to a CSV file with a fixed header written when the file is
// new or empty (so a resumed run keeps appending to the same file). A file
// with other columns (a run resumed by a version that logs more or fewer) is
// rewritten first under the new header, each old row's values under their
// column's name ("nan" where it had none; columns gone are dropped). Throws
// std::runtime_error naming the file when it cannot be opened or a row
// cannot be written (disk full, I/O error).
class CsvWriter {
 public:
  CsvWriter(const std::string& path, const std::vector<std::string>& columns);
  // values must match the columns; written with full precision and flushed.
  void Write(const std::vector<double>& values);
  void WriteRow(const std::vector<std::string>& values);

 private:
  std::string path_;
  size_t num_columns_;
  std::ofstream out_;
};

// Drops the rows of a CSV file (first column: step) whose step is above
// max_step, and a last row cut short (no final newline), keeping the header:
// a resumed run then appends without duplicates. Returns the rows dropped;
// a missing file is not an error. Throws std::runtime_error naming the file.
int64_t TruncateCsvRows(const std::string& path, int64_t max_step);

}  // namespace core
}  // namespace msspr
