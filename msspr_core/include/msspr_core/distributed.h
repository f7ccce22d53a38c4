// Data-parallel training on torch.distributed's c10d: a TCPStore rendezvous
// (rank 0 hosts it) and a process group (Gloo on the CPU; NCCL for CUDA
// tensors when LibTorch has it, else Gloo through host copies). The trainer
// uses it to average gradients before every optimiser step, to agree on when
// to stop, and to collect every rank's random state into rank 0's
// checkpoint. Built when LibTorch ships c10d with Gloo (MSSPR_HAVE_C10D);
// otherwise Distributed's constructor throws, naming the missing support.
#pragma once

#include <torch/torch.h>

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace msspr {
namespace core {

// A failed rendezvous, a lost peer or a collective that timed out.
class DistributedError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct DistributedOptions {
  int world_size = 1;
  int rank = 0;
  std::string master_addr = "127.0.0.1";
  int master_port = 29500;
  double timeout_s = 600;  // rendezvous and every collective

  bool enabled() const { return world_size > 1; }
  // WORLD_SIZE, RANK, MASTER_ADDR, MASTER_PORT (torchrun's variables) on top
  // of `base`; throws DistributedError on a malformed value.
  static DistributedOptions FromEnvironment(DistributedOptions base);
  static DistributedOptions FromEnvironment() { return FromEnvironment(DistributedOptions()); }
  // Checks 0 <= rank < world_size, the port and the timeout; throws DistributedError.
  void Validate() const;
};

// Whether this build has c10d with Gloo.
bool DistributedAvailable();

class Distributed {
 public:
  // Rendezvous at master_addr:master_port (rank 0 listens there) and builds
  // the process group for tensors on `device`. Throws DistributedError,
  // naming the master, on a timeout or a refused connection.
  Distributed(const DistributedOptions& options, torch::Device device);
  ~Distributed();
  Distributed(const Distributed&) = delete;
  Distributed& operator=(const Distributed&) = delete;

  int rank() const { return options_.rank; }
  int world_size() const { return options_.world_size; }
  const DistributedOptions& options() const { return options_; }
  const std::string& backend() const { return backend_; }

  // Replaces each parameter's gradient by its mean over the ranks, in
  // buckets of at most bucket_bytes (flattened, one all-reduce each).
  // Parameters without a gradient (undefined: not reached by the backward)
  // are left out; every rank must call with the same parameters reached.
  void AverageGradients(const std::vector<torch::Tensor>& params, int64_t bucket_bytes = 25 << 20);
  // Sums `tensors` in place over the ranks (one all-reduce each).
  void AllReduceSum(std::vector<torch::Tensor>& tensors);
  // Copies rank `root`'s values into `tensors` on every rank.
  void Broadcast(std::vector<torch::Tensor>& tensors, int root = 0);
  // True on every rank when `flag` is true on any.
  bool Any(bool flag);
  void Barrier();
  // Time and volume of the all-reduces so far (gradients and flags).
  struct Stats {
    int64_t allreduces = 0;
    int64_t bytes = 0;
    double seconds = 0;
  };
  const Stats& stats() const { return stats_; }
  // Key-value exchange through the rendezvous store (Get waits for the key).
  void Set(const std::string& key, const std::string& value);
  std::string Get(const std::string& key);

 private:
  void AverageDefinedGradients(const std::vector<torch::Tensor>& params, int64_t bucket_bytes);

  struct Impl;
  DistributedOptions options_;
  torch::Device device_;
  std::string backend_;
  Stats stats_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace core
}  // namespace msspr
