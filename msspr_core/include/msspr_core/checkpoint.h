// The checkpoint container: a versioned header and a payload, written to a
// temporary file and renamed. No torch in this header.
//
// Layout: magic "MSSPRCKP" (8 bytes), format version (uint32 LE), kind
// length + kind ("trainer" or "policy"), header length (uint64 LE) + header
// (YAML text: options and metadata), payload length (uint64 LE) + payload
// (a LibTorch archive), CRC-32 of header and payload (uint32 LE).
#pragma once

#include <cstdint>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "msspr_core/options.h"

namespace msspr {
namespace core {

// Thrown for unreadable, truncated, corrupt or foreign checkpoint files; the
// message names the file.
class CheckpointError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

constexpr uint32_t kCheckpointFormatVersion = 1;

struct CheckpointFile {
  std::string kind;  // "trainer" or "policy"
  uint32_t version = 0;
  std::string header;   // YAML text
  std::string payload;  // LibTorch archive bytes
};

// What the header says: the options the run used and where it stands.
struct CheckpointHeader {
  MsprOptions options;
  int64_t step = 0;
  double repr_credit = 0.0;  // fractional representation updates carried over
  std::string sampler_rng;   // std::mt19937_64 state as text (trainer checkpoints)
  // Data-parallel runs: every rank's random state (sampler RNG and torch
  // generator, as Trainer writes them), index = rank; empty otherwise.
  std::vector<std::string> rank_states;
  // Free-form text entries the run was started with (e.g. "robot_spec": the
  // robot interface spec's YAML that msspr_train --robot used); see
  // SetCheckpointMetadata.
  std::map<std::string, std::string> metadata;
};
// Adds (or, with an empty value, removes) a metadata entry that every header
// this process writes carries from now on, beside the header's own entries
// (which win on a clash). Used by front ends whose data the core does not know.
void SetCheckpointMetadata(const std::string& key, const std::string& value);
std::string CheckpointHeaderToYaml(const CheckpointHeader& header);
// Throws CheckpointError naming `path` when the header is not valid.
CheckpointHeader ParseCheckpointHeader(const std::string& yaml, const std::string& path);

// Writes durably and atomically: a unique temporary file beside `path`
// (pid + random suffix), fsync, rename over `path`, fsync of the directory.
// keep_previous: the file being replaced stays as `path`.prev. Leftover
// temporaries of killed writers are removed. Throws CheckpointError.
void WriteCheckpointFile(const std::string& path, const CheckpointFile& file,
                         bool keep_previous = false);
// Reads and verifies (magic, version, lengths, CRC). When expected_kind is
// not empty the kind must match. Throws CheckpointError naming the file.
CheckpointFile ReadCheckpointFile(const std::string& path, const std::string& expected_kind = "");
// As ReadCheckpointFile; when `path` is missing, truncated or fails its CRC
// and `path`.prev exists, says so on stderr and reads that instead.
// used_path (optional) receives the file actually read.
CheckpointFile ReadCheckpointFileOrPrevious(const std::string& path,
                                            const std::string& expected_kind = "",
                                            std::string* used_path = nullptr);

// An exclusive flock on DIR/.lock for as long as the object lives (the kernel
// releases it when the process ends or is killed): one training run per
// output directory. Throws CheckpointError naming the directory when another
// process holds it.
class RunDirLock {
 public:
  explicit RunDirLock(const std::string& dir);
  ~RunDirLock();
  RunDirLock(const RunDirLock&) = delete;
  RunDirLock& operator=(const RunDirLock&) = delete;

 private:
  std::string path_;
  int fd_ = -1;
};

}  // namespace core
}  // namespace msspr
