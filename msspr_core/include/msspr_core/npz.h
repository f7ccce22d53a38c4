// OGBench dataset files: NumPy .npz archives (plain or zip-deflate
// compressed) holding `observations` [N, obs_dim] float32 (or uint8
// [N, 64, 64, 3] images), `actions` [N, action_dim] float32 and `terminals`
// [N] (1 on each trajectory's last step). The core's own dataset file is the
// same format with an optional extra `images` [N, H, W, C] uint8 array next
// to float `observations` (state + images, e.g. from a ROS bag). This header
// does not include torch.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "msspr_core/dataset.h"

namespace msspr {
namespace core {

// Thrown for unreadable or malformed files; the message names the file and,
// where it applies, the array key.
class NpzError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One array of an .npz, converted on request.
struct NpyInfo {
  std::string descr;  // numpy dtype string, e.g. "<f4", "|u1"
  bool fortran_order = false;
  std::vector<int64_t> shape;
  int64_t data_offset = 0;  // bytes of the .npy header before the data
  int64_t numel() const;    // -1 for a negative dimension or an overflow
};

// Lists the array names (without ".npy") of an .npz file.
std::vector<std::string> ListNpzKeys(const std::string& path);

// Reads one array as float32 / uint8 (converting from other numeric dtypes;
// uint8 only from uint8 or bool). Throws NpzError naming the file and key.
std::vector<float> ReadNpzFloat(const std::string& path, const std::string& key, NpyInfo* info);
std::vector<uint8_t> ReadNpzUint8(const std::string& path, const std::string& key, NpyInfo* info);

// Loads an OGBench (or core) dataset file. Float observations become
// states; uint8 observations [N, H, W, C] become images; an `images` array
// is read too when present. Throws NpzError naming the file and the key,
// also when a header disagrees with its entry's size (truncated or lying),
// and when observations or actions hold NaN or Inf (with their count).
Dataset LoadNpzDataset(const std::string& path);

// Writes `data` in the same format: `observations` (states if any, else
// images), `actions`, `terminals` float32, and `images` when the dataset has
// both. compress: zip-deflate (np.savez_compressed) instead of stored
// (np.savez). Written to a temporary file and renamed. Throws NpzError.
void SaveNpzDataset(const Dataset& data, const std::string& path, bool compress = false);

// One array to write: numpy dtype descr ("<f4", "<f8", "|u1", ...), C-order shape,
// and its bytes (not copied; alive until SaveNpzArrays returns).
struct NpyArray {
  std::string key;
  std::string descr;
  std::vector<int64_t> shape;
  const void* data = nullptr;
  uint64_t bytes = 0;
};
// Writes the arrays as an .npz (np.savez layout; compress: np.savez_compressed),
// to a temporary file renamed into place. Throws NpzError naming the file and the
// key, also when an array's bytes do not match its shape and dtype.
void SaveNpzArrays(const std::string& path, const std::vector<NpyArray>& arrays,
                   bool compress = false);

}  // namespace core
}  // namespace msspr
