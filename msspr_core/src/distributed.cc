#include "msspr_core/distributed.h"

#include <chrono>
#include <cstdlib>
#include <exception>

#if MSSPR_HAVE_C10D
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>
#if MSSPR_HAVE_NCCL
#include <torch/csrc/distributed/c10d/ProcessGroupNCCL.hpp>
#endif
#endif

namespace msspr {
namespace core {
namespace {

int EnvInt(const char* name, int fallback) {
  const char* v = std::getenv(name);
  if (!v || !*v) return fallback;
  char* end = nullptr;
  const long x = std::strtol(v, &end, 10);
  if (*end != '\0')
    throw DistributedError(std::string("environment ") + name + "='" + v + "' is not an integer");
  return static_cast<int>(x);
}

}  // namespace

DistributedOptions DistributedOptions::FromEnvironment(DistributedOptions base) {
  base.world_size = EnvInt("WORLD_SIZE", base.world_size);
  base.rank = EnvInt("RANK", base.rank);
  if (const char* a = std::getenv("MASTER_ADDR"); a && *a) base.master_addr = a;
  base.master_port = EnvInt("MASTER_PORT", base.master_port);
  return base;
}

void DistributedOptions::Validate() const {
  if (world_size < 1)
    throw DistributedError("world size must be >= 1, got " + std::to_string(world_size));
  if (rank < 0 || rank >= world_size)
    throw DistributedError("rank " + std::to_string(rank) + " is outside 0.." +
                           std::to_string(world_size - 1));
  if (master_port < 1 || master_port > 65535)
    throw DistributedError("master port " + std::to_string(master_port) + " is outside 1..65535");
  if (master_addr.empty()) throw DistributedError("no master address");
  if (!(timeout_s > 0)) throw DistributedError("distributed timeout must be > 0");
}

#if MSSPR_HAVE_C10D

bool DistributedAvailable() { return true; }

struct Distributed::Impl {
  c10::intrusive_ptr<c10d::Store> store;
  c10::intrusive_ptr<c10d::ProcessGroup> group;
  bool host_copies = false;  // CUDA tensors through a CPU Gloo group
};

namespace {

std::string Where(const DistributedOptions& o) {
  return "rank " + std::to_string(o.rank) + "/" + std::to_string(o.world_size) + " (master " +
         o.master_addr + ":" + std::to_string(o.master_port) + ")";
}

bool Loopback(const std::string& addr) {
  return addr == "localhost" || addr.rfind("127.", 0) == 0 || addr == "::1";
}

// Runs a collective; c10d's errors become DistributedErrors naming the rank.
template <class F>
void Guard(const DistributedOptions& o, const std::string& what, F&& f) {
  try {
    f();
  } catch (const c10::Error& e) {
    throw DistributedError(Where(o) + ": " + what +
                           " failed (a peer exited or timed out?): " + e.what_without_backtrace());
  } catch (const std::exception& e) {
    throw DistributedError(Where(o) + ": " + what +
                           " failed (a peer exited or timed out?): " + e.what());
  }
}

}  // namespace

Distributed::Distributed(const DistributedOptions& options, torch::Device device)
    : options_(options), device_(device), impl_(std::make_unique<Impl>()) {
  options_.Validate();
  const auto timeout = std::chrono::milliseconds(static_cast<int64_t>(options_.timeout_s * 1000));
  Guard(options_, "rendezvous", [&] {
    c10d::TCPStoreOptions so;
    so.port = static_cast<uint16_t>(options_.master_port);
    so.isServer = options_.rank == 0;
    so.numWorkers = options_.world_size;
    so.waitWorkers = true;
    so.timeout = timeout;
    impl_->store = c10::make_intrusive<c10d::TCPStore>(options_.master_addr, so);
#if MSSPR_HAVE_NCCL
    if (device_.is_cuda()) {
      auto opts = c10d::ProcessGroupNCCL::Options::create();
      opts->timeout = timeout;
      impl_->group = c10::make_intrusive<c10d::ProcessGroupNCCL>(impl_->store, options_.rank,
                                                                 options_.world_size, opts);
      backend_ = "nccl";
      return;
    }
#endif
    auto opts = c10d::ProcessGroupGloo::Options::create(timeout);
    if (const char* iface = std::getenv("GLOO_SOCKET_IFNAME"); iface && *iface) {
      opts->devices.push_back(c10d::ProcessGroupGloo::createDeviceForInterface(iface));
    } else if (Loopback(options_.master_addr)) {
      opts->devices.push_back(c10d::ProcessGroupGloo::createDeviceForHostname("127.0.0.1"));
    } else {
      opts->devices.push_back(c10d::ProcessGroupGloo::createDefaultDevice());
    }
    impl_->group = c10::make_intrusive<c10d::ProcessGroupGloo>(impl_->store, options_.rank,
                                                               options_.world_size, opts);
    impl_->host_copies = device_.is_cuda();
    backend_ = device_.is_cuda() ? "gloo (host copies)" : "gloo";
  });
}

Distributed::~Distributed() = default;

void Distributed::AllReduceSum(std::vector<torch::Tensor>& tensors) {
  for (torch::Tensor& t : tensors) {
    torch::Tensor x = impl_->host_copies ? t.to(torch::kCPU) : t;
    std::vector<torch::Tensor> one{x};
    const auto start = std::chrono::steady_clock::now();
    Guard(options_, "all-reduce", [&] { impl_->group->allreduce(one)->wait(); });
    stats_.seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    stats_.bytes += x.numel() * x.element_size();
    ++stats_.allreduces;
    if (impl_->host_copies) t.copy_(x);
  }
}

void Distributed::AverageGradients(const std::vector<torch::Tensor>& params, int64_t bucket_bytes) {
  torch::NoGradGuard no_grad;
  // Parameters that this backward did not reach (undefined gradients, the
  // same on every rank) stay out, as the optimisers skip them.
  std::vector<torch::Tensor> with_grad;
  for (const torch::Tensor& p : params)
    if (p.grad().defined()) with_grad.push_back(p);
  AverageDefinedGradients(with_grad, bucket_bytes);
}

void Distributed::AverageDefinedGradients(const std::vector<torch::Tensor>& params,
                                          int64_t bucket_bytes) {
  size_t i = 0;
  while (i < params.size()) {
    // One bucket: consecutive parameters of the same dtype, up to bucket_bytes.
    std::vector<torch::Tensor> grads;
    int64_t bytes = 0;
    const auto dtype = params[i].scalar_type();
    size_t j = i;
    for (; j < params.size() && params[j].scalar_type() == dtype; ++j) {
      const int64_t b = params[j].numel() * params[j].element_size();
      if (!grads.empty() && bytes + b > bucket_bytes) break;
      grads.push_back(params[j].grad().reshape({-1}));
      bytes += b;
    }
    std::vector<torch::Tensor> flat{torch::cat(grads)};
    AllReduceSum(flat);
    flat[0].div_(options_.world_size);
    int64_t offset = 0;
    for (size_t k = i; k < j; ++k) {
      const int64_t n = params[k].numel();
      params[k].mutable_grad().copy_(flat[0].narrow(0, offset, n).view(params[k].sizes()));
      offset += n;
    }
    i = j;
  }
}

void Distributed::Broadcast(std::vector<torch::Tensor>& tensors, int root) {
  for (torch::Tensor& t : tensors) {
    torch::Tensor x = impl_->host_copies ? t.to(torch::kCPU) : t;
    std::vector<torch::Tensor> one{x};
    c10d::BroadcastOptions bo;
    bo.rootRank = root;
    Guard(options_, "broadcast", [&] { impl_->group->broadcast(one, bo)->wait(); });
    if (impl_->host_copies) t.copy_(x);
  }
}

bool Distributed::Any(bool flag) {
  std::vector<torch::Tensor> t{
      torch::full({1}, flag ? 1.0f : 0.0f,
                  torch::TensorOptions().device(impl_->host_copies ? torch::kCPU : device_))};
  AllReduceSum(t);
  return t[0].item<float>() > 0.5f;
}

void Distributed::Barrier() {
  Guard(options_, "barrier", [&] { impl_->group->barrier()->wait(); });
}

void Distributed::Set(const std::string& key, const std::string& value) {
  Guard(options_, "store set",
        [&] { impl_->store->set(key, std::vector<uint8_t>(value.begin(), value.end())); });
}

std::string Distributed::Get(const std::string& key) {
  std::vector<uint8_t> v;
  Guard(options_, "store get of '" + key + "'", [&] { v = impl_->store->get(key); });
  return std::string(v.begin(), v.end());
}

#else  // !MSSPR_HAVE_C10D

bool DistributedAvailable() { return false; }

struct Distributed::Impl {};

Distributed::Distributed(const DistributedOptions& options, torch::Device device)
    : options_(options), device_(device) {
  throw DistributedError(
      "data-parallel training needs LibTorch with torch.distributed (c10d) and Gloo, and the Gloo "
      "headers "
      "(Debian: libgloo-dev); this msspr_core was built without them");
}
Distributed::~Distributed() = default;
void Distributed::AverageGradients(const std::vector<torch::Tensor>&, int64_t) {}
void Distributed::AverageDefinedGradients(const std::vector<torch::Tensor>&, int64_t) {}
void Distributed::AllReduceSum(std::vector<torch::Tensor>&) {}
void Distributed::Broadcast(std::vector<torch::Tensor>&, int) {}
bool Distributed::Any(bool flag) { return flag; }
void Distributed::Barrier() {}
void Distributed::Set(const std::string&, const std::string&) {}
std::string Distributed::Get(const std::string&) { return ""; }

#endif

}  // namespace core
}  // namespace msspr
