// The records msspr_train keeps in a run directory beside the training state: run.yaml (the
// flags and configs a run was started with, read back by --resume) and host.yaml (the machine,
// threads and precision of the latest segment), each written atomically.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace msspr {
namespace core {
namespace internal {

// Old spellings of flags, read as the new ones (the old one with a warning on the command
// line; silently in the run records written before the rename).
extern const std::map<std::string, std::string> kRenamedFlags;

// The current name of a flag (without "--") given in an old spelling; others as they are.
std::string CurrentFlagName(const std::string& key);

// DIR/run.yaml: what a run was started with (flags, absolute data paths), so
// that --resume --out DIR needs nothing else.
struct RunRecord {
  std::map<std::string, std::string> flags;  // name without "--" -> value
  std::vector<std::string> configs;          // --config, in order
};

// Reads a run record; throws std::runtime_error naming the file when it is unreadable.
RunRecord ReadRunRecord(const std::string& path);
// Writes it atomically (WriteTextAtomically).
void WriteRunRecord(const std::string& path, const RunRecord& r);

// Writes `text` to path through path.tmp and a rename, so that a kill leaves the old file or
// the new one; throws std::runtime_error naming the file on a failure.
void WriteTextAtomically(const std::string& path, const std::string& text);

// ", OpenBLAS kernels SkylakeX" (fp32 products run in them), or "".
std::string BlasNote();

// host.yaml: where the latest segment ran (the CPU, torch threads, the precision and why,
// LibTorch, OpenBLAS's kernels); the figures in metrics.csv depend on it.
std::string HostRecord(const std::string& precision_why);

}  // namespace internal
}  // namespace core
}  // namespace msspr
