// The checkpoint container: a versioned header and a payload, written to a
// temporary file and renamed. No torch in this header.
//
// Layout: magic "MSSPRCKP" (8 bytes), format version (uint32 LE), kind
// length + kind ("trainer" or "policy"), header length (uint64 LE) + header
// (YAML text: options and metadata), payload length (uint64 LE) + payload
// (a LibTorch archive), CRC-32 of header and payload (uint32 LE).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

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
  std::string kind;     // "trainer" or "policy"
  uint32_t version = 0;
  std::string header;   // YAML text
  std::string payload;  // LibTorch archive bytes
};

// What the header says: the options the run used and where it stands.
struct CheckpointHeader {
  MsprOptions options;
  int64_t step = 0;
  double repr_credit = 0.0;   // fractional representation updates carried over
  std::string sampler_rng;    // std::mt19937_64 state as text (trainer checkpoints)
};
std::string CheckpointHeaderToYaml(const CheckpointHeader& header);
// Throws CheckpointError naming `path` when the header is not valid.
CheckpointHeader ParseCheckpointHeader(const std::string& yaml, const std::string& path);

// Writes atomically (path + ".tmp", then rename). Throws CheckpointError.
void WriteCheckpointFile(const std::string& path, const CheckpointFile& file);
// Reads and verifies (magic, version, lengths, CRC). When expected_kind is
// not empty the kind must match. Throws CheckpointError naming the file.
CheckpointFile ReadCheckpointFile(const std::string& path, const std::string& expected_kind = "");

}  // namespace core
}  // namespace msspr
