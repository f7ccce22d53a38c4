// msspr_profile_step: where a training step of msspr_core goes (a diagnostic,
// mostly for GPU machines).
//
//   msspr_profile_step --config config/pointmaze_paper.yaml[,MORE.yaml] [--device cuda]
//                      [--precision fp32|bf16] [--steps N] [--out-dir DIR] [--graph] [--adam]
//
// On the synthetic point-maze dataset of msspr_bench_core --config (100 x 1001,
// obs 2, action 2) it prints, as JSON lines:
//  - wall ms/step of Step(false) (no loss read-back) and Step(true);
//  - ms of SampleTransitions + SampleChunks (host sampling, host-to-device copies);
//  - over N steps under the Kineto profiler (LibTorch >= 2.1 built with Kineto;
//    otherwise "profiler_error"): kernels per step, summed kernel time and GPU
//    busy time (union of kernel/copy intervals) per step, the CUDA runtime
//    calls per step (launches, copies, synchronisations) and the kernels that
//    take the most time; DIR/trace.json is the chrome trace;
//  - with --graph (a CUDA LibTorch and --device cuda): critic loss forward +
//    backward on a fixed batch, eager against a CUDA-graph replay of the same
//    work (at::cuda::CUDAGraph);
//  - with --adam: one Adam update of copies of the online networks' parameters
//    (random gradients) with torch::optim::Adam (a loop over the tensors), with the
//    trainer's ForeachAdamW (_foreach_* ops), and as at::_fused_adam_.
// The build defines MSSPR_PROFILE_CUDA when LibTorch has CUDA.
#include <torch/torch.h>
#include <torch/version.h>
#if MSSPR_PROFILE_CUDA
#include <ATen/cuda/CUDAGraph.h>
#include <c10/cuda/CUDAGuard.h>
#include <c10/cuda/CUDAStream.h>
#endif
#if TORCH_VERSION_MAJOR > 2 || (TORCH_VERSION_MAJOR == 2 && TORCH_VERSION_MINOR >= 1)
#define MSSPR_PROFILE_KINETO 1
#include <torch/csrc/autograd/profiler_kineto.h>
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "msspr_core/cli_args.h"
#include "msspr_core/foreach_adamw.h"
#include "msspr_core/trainer.h"
namespace {

using namespace msspr::core;
using Clock = std::chrono::steady_clock;

std::shared_ptr<const Dataset> SyntheticDataset(int obs_dim, int action_dim, int episodes,
                                                int length) {
  std::mt19937_64 rng(1);
  std::normal_distribution<float> normal;
  DatasetBuilder b(obs_dim, action_dim);
  for (int e = 0; e < episodes; ++e) {
    std::vector<float> obs(length * obs_dim), act(length * action_dim);
    for (auto& v : obs) v = normal(rng);
    for (auto& v : act) v = std::tanh(normal(rng));
    b.AddEpisode(obs, act);
  }
  return std::make_shared<const Dataset>(b.Build());
}

void Sync(const torch::Device& d) {
  if (d.is_cuda()) torch::cuda::synchronize();
}

template <class F>
double TimeMs(const torch::Device& d, int reps, F&& f) {
  Sync(d);
  const auto start = Clock::now();
  for (int i = 0; i < reps; ++i) f();
  Sync(d);
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count() / reps;
}

std::string Json(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '"' || c == '\\') o.push_back('\\');
    if (static_cast<unsigned char>(c) >= 0x20) o.push_back(c);
  }
  return o.size() > 120 ? o.substr(0, 120) : o;
}

#if MSSPR_PROFILE_KINETO
// Kineto over `steps` steps: kernels, GPU busy time, runtime calls, the top kernels.
void ProfileSteps(Trainer& t, const torch::Device& dev, int steps, const std::string& out_dir,
                  std::ostream& j) {
  try {
    // Kineto: CPU ops, CUDA runtime calls and GPU activity over `steps` steps.
    namespace prof = torch::autograd::profiler;
    using torch::profiler::impl::ActivityType;
    const torch::profiler::impl::ProfilerConfig cfg(torch::profiler::impl::ProfilerState::KINETO);
    std::set<ActivityType> acts{ActivityType::CPU};
    if (dev.is_cuda()) acts.insert(ActivityType::CUDA);
    prof::prepareProfiler(cfg, acts);
    Sync(dev);
    prof::enableProfiler(cfg, acts);
    const auto p0 = Clock::now();
    for (int i = 0; i < steps; ++i) t.Step(false);
    Sync(dev);
    const double wall_ms = std::chrono::duration<double, std::milli>(Clock::now() - p0).count();
    std::unique_ptr<prof::ProfilerResult> res = prof::disableProfiler();
    int64_t gpu_events = 0, gpu_sum_ns = 0;
    std::vector<std::pair<uint64_t, uint64_t>> spans;
    std::map<std::string, std::pair<int64_t, int64_t>> kernels, runtime;  // name -> count, ns
    int64_t cpu_ops = 0;
    for (const auto& e : res->events()) {
      const std::string name = e.name();
      if (e.deviceType() == c10::DeviceType::CUDA) {
        ++gpu_events;
        gpu_sum_ns += e.durationNs();
        spans.emplace_back(e.startNs(), e.startNs() + e.durationNs());
        auto& k = kernels[name];
        ++k.first;
        k.second += e.durationNs();
      } else if (name.rfind("cuda", 0) == 0 || name.rfind("cu", 0) == 0) {
        auto& r = runtime[name];
        ++r.first;
        r.second += e.durationNs();
      } else {
        ++cpu_ops;
      }
    }
    std::sort(spans.begin(), spans.end());
    uint64_t busy = 0, cur_s = 0, cur_e = 0;
    for (const auto& s : spans) {
      if (s.first > cur_e) {
        busy += cur_e - cur_s;
        cur_s = s.first;
        cur_e = s.second;
      } else {
        cur_e = std::max(cur_e, s.second);
      }
    }
    busy += cur_e - cur_s;
    j << ", \"profiled_steps\": " << steps << ", \"profiled_wall_ms_per_step\": " << wall_ms / steps
      << ", \"gpu_activities_per_step\": " << static_cast<double>(gpu_events) / steps
      << ", \"gpu_kernel_sum_ms_per_step\": " << gpu_sum_ns / 1e6 / steps
      << ", \"gpu_busy_ms_per_step\": " << busy / 1e6 / steps
      << ", \"cpu_events_per_step\": " << static_cast<double>(cpu_ops) / steps;
    j << ", \"runtime_calls_per_step\": {";
    bool first = true;
    for (const auto& kv : runtime) {
      j << (first ? "" : ", ") << "\"" << Json(kv.first) << "\": ["
        << static_cast<double>(kv.second.first) / steps << ", " << kv.second.second / 1e6 / steps
        << "]";
      first = false;
    }
    j << "}, \"top_kernels_ms_per_step\": [";
    std::vector<std::pair<int64_t, std::string>> top;
    for (const auto& kv : kernels) top.emplace_back(kv.second.second, kv.first);
    std::sort(top.rbegin(), top.rend());
    for (size_t i = 0; i < std::min<size_t>(12, top.size()); ++i) {
      j << (i ? ", " : "") << "[\"" << Json(top[i].second) << "\", "
        << static_cast<double>(kernels[top[i].second].first) / steps << ", "
        << top[i].first / 1e6 / steps << "]";
    }
    j << "]";
    if (!out_dir.empty()) res->save(out_dir + "/trace.json");
  } catch (const std::exception& e) {
    std::string msg = e.what();
    j << ", \"profiler_error\": \"" << Json(msg.substr(0, msg.find('\n'))) << "\"";
  }
}
#endif

#if MSSPR_PROFILE_CUDA
// The critic's forward and backward on one fixed batch, eager and as a CUDA-graph replay.
void CriticGraph(Trainer& t, const torch::Device& dev, std::ostream& j) {
  const TransitionBatch tb = t.SampleTransitions();
  const torch::Tensor noise = torch::randn({tb.action.size(0), tb.action.size(1)}).to(dev);
  auto fwd_bwd = [&] {
    torch::Tensor loss = t.CriticLoss(tb, noise);
    loss.backward();
  };
  const double eager = TimeMs(dev, 50, fwd_bwd);
  j << ", \"critic_fwd_bwd_eager_ms\": " << eager;
  try {
    c10::cuda::CUDAStream side = c10::cuda::getStreamFromPool();
    at::cuda::CUDAGraph g;
    {
      c10::cuda::CUDAStreamGuard guard(side);
      for (int i = 0; i < 3; ++i) fwd_bwd();
      side.synchronize();
      g.capture_begin();
      fwd_bwd();
      g.capture_end();
    }
    const double replay = TimeMs(dev, 50, [&] { g.replay(); });
    j << ", \"critic_fwd_bwd_graph_replay_ms\": " << replay;
  } catch (const std::exception& e) {
    std::string msg = e.what();
    msg = msg.substr(0, msg.find('\n'));
    j << ", \"critic_graph_error\": \"" << Json(msg) << "\"";
  }
}
#endif

// One Adam update of copies of the online networks' parameters: per-tensor loop,
// _foreach ops, fused.
void AdamVariants(Trainer& t, const torch::Device& dev) {
  std::ostringstream j;
  j.precision(5);
  std::vector<torch::Tensor> params, grads;
  for (const auto& p : t.repr()->parameters()) params.push_back(p.detach().clone());
  for (const auto& p : t.critic()->parameters()) params.push_back(p.detach().clone());
  for (const auto& p : t.actor()->parameters()) params.push_back(p.detach().clone());
  int64_t numel = 0;
  for (auto& p : params) {
    p.requires_grad_(true);
    p.mutable_grad() = torch::randn_like(p) * 1e-3;
    grads.push_back(p.grad());
    numel += p.numel();
  }
  j << "{\"adam_tensors\": " << params.size() << ", \"adam_numel\": " << numel;
  torch::optim::Adam loop_opt(params, torch::optim::AdamOptions(3e-4));
  j << ", \"adam_loop_ms\": " << TimeMs(dev, 50, [&] { loop_opt.step(); });
  torch::NoGradGuard no_grad;
  std::vector<torch::Tensor> m, v, steps_t;
  for (const auto& p : params) {
    m.push_back(torch::zeros_like(p));
    v.push_back(torch::zeros_like(p));
    steps_t.push_back(torch::zeros({}, p.options()));
  }
  const double lr = 3e-4, b1 = 0.9, b2 = 0.999, eps = 1e-8;
  // The trainer's optimiser (multi-tensor ops), without weight decay as the others.
  ForeachAdamW foreach_opt(params, torch::optim::AdamWOptions(lr).weight_decay(0));
  j << ", \"adam_foreach_ms\": " << TimeMs(dev, 50, [&] { foreach_opt.step(); });
  try {
    const double fused_ms = TimeMs(dev, 50, [&] {
      at::_fused_adam_(params, grads, m, v, {}, steps_t, lr, b1, b2, 0.0, eps, false, false);
    });
    j << ", \"adam_fused_ms\": " << fused_ms;
  } catch (const std::exception& e) {
    std::string msg = e.what();
    j << ", \"adam_fused_error\": \"" << Json(msg.substr(0, msg.find('\n'))) << "\"";
  }
  j << "}";
  std::cout << j.str() << std::endl;
}

}  // namespace

constexpr const char* kUsage = R"(usage: msspr_profile_step [options]
Times and profiles training steps of msspr_core on a synthetic point-maze dataset; JSON lines.
  --config YAML[,YAML...]  configuration layered on the mspr/cpu preset
  --device DEV             cpu, cuda, cuda:N (default cuda)
  --precision P            fp32 | bf16 (default: as configured)
  --steps N                profiled steps (default 20)
  --out-dir DIR            write DIR/trace.json (the profiler's chrome trace)
  --graph                  critic forward + backward, eager against a CUDA-graph replay
  --adam                   one Adam update: per-tensor loop, _foreach ops, fused
)";

int main(int argc, char** argv) {
  std::vector<std::string> configs;
  std::string device, precision, out_dir;
  int steps = 20;
  bool graph = false, adam = false;
  try {
    msspr::cli::CliArgs args(argc, argv, {"help", "graph", "adam"},
                             {"config", "device", "precision", "steps", "out-dir"});
    if (args.Has("help")) {
      std::cout << kUsage;
      return 0;
    }
    if (!args.positional().empty())
      throw msspr::cli::CliError("unexpected argument '" + args.positional()[0] + "'");
    std::stringstream list(args.Get("config", ""));
    for (std::string item; std::getline(list, item, ',');)
      if (!item.empty()) configs.push_back(item);
    device = args.Get("device", "cuda");
    precision = args.Get("precision", "");
    if (!precision.empty()) precision = args.GetChoice("precision", "", {"fp32", "bf16"});
    steps = static_cast<int>(args.GetInt("steps", 20, 1, 1000000));
    out_dir = args.Get("out-dir", "");
    graph = args.Has("graph");
    adam = args.Has("adam");
  } catch (const std::exception& e) {
    std::cerr << "msspr_profile_step: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try {
    MsprOptions o = ResolveOptions("", "", configs, nullptr, "mspr", "cpu");
    o.trainer.device = device;
    if (!precision.empty()) o.trainer.precision = precision;
    auto data = SyntheticDataset(2, 2, 100, 1001);
    Trainer t(o, data);
    const torch::Device dev = t.device();
    for (int i = 0; i < 20; ++i) t.Step(false);

    std::ostringstream j;
    j.precision(5);
    j << "{\"device\": \"" << device << "\", \"precision\": \"" << o.trainer.precision
      << "\", \"batch\": " << o.trainer.batch_size
      << ", \"updates_per_step\": " << o.representation.updates_per_step;
    j << ", \"ms_step_no_info\": " << TimeMs(dev, 50, [&] { t.Step(false); });
    j << ", \"ms_step_info\": " << TimeMs(dev, 50, [&] { t.Step(true); });
    j << ", \"ms_sample_transitions_and_chunks\": " << TimeMs(dev, 50, [&] {
      t.SampleTransitions();
      t.SampleChunks();
    });

#if MSSPR_PROFILE_KINETO
    ProfileSteps(t, dev, steps, out_dir, j);
#else
    (void)steps;
    (void)out_dir;
    j << ", \"profiler_error\": \"needs LibTorch >= 2.1 (Kineto event API)\"";
#endif
    j << "}";
    std::cout << j.str() << std::endl;
    j.str("");
    j << "{\"graph\": " << (graph ? "true" : "false");
#if MSSPR_PROFILE_CUDA
    if (graph && dev.is_cuda()) CriticGraph(t, dev, j);
#else
    if (graph) j << ", \"critic_graph_error\": \"LibTorch without CUDA\"";
#endif
    j << "}";
    std::cout << j.str() << std::endl;
    if (adam) AdamVariants(t, dev);
  } catch (const std::exception& e) {
    std::cerr << "profile_step: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
