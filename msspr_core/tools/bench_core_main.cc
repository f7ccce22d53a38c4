// msspr_bench_core: training throughput and inference latency of the core
// on synthetic data, written as JSON.
#include <sys/resource.h>
#include <torch/csrc/autograd/profiler_legacy.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "msspr_core/cli_args.h"
#include "msspr_core/cpu_info.h"
#include "msspr_core/isa_peaks.h"
#include "msspr_core/process_env.h"
#include "msspr_core/trainer.h"

namespace {

using namespace msspr::core;
namespace cli = msspr::cli;
using Clock = std::chrono::steady_clock;

const char kUsage[] =
    "usage: msspr_bench_core --out FILE.json [--device cpu|cuda] [--threads N] [--quick]\n"
    "                        [--precision fp32|bf16]\n"
    "       msspr_bench_core --config YAML[,YAML...] --out FILE.json [--steps N]\n"
    "                        [--warmup N] [--obs-dim D] [--action-dim A] [--episodes E]\n"
    "                        [--length L] [--device D] [--threads N] [--precision P]\n"
    "\n"
    "Times training steps (CPU and paper scale, states and pixels) and single-sample\n"
    "Policy::Act latency on synthetic data; writes JSON (also printed).\n"
    "  --quick      fewer timed steps (for smoke tests)\n"
    "  --precision  trainer.precision of every timed configuration (default: as configured)\n"
    "With --config: times that one configuration (applied on the mspr/cpu preset) on a\n"
    "synthetic dataset of E episodes of L steps (default 100 x 1001, obs 2, action 2: the\n"
    "point maze's shapes; pixels when network.obs_mode is pixels) and writes\n"
    "{\"ms_per_step\": ...}. Steps default to 200 after 20 warm-up steps.\n"
    "  --profile FILE   also record 5 more steps with LibTorch's autograd profiler\n"
    "                   (chrome trace; scripts/profile_summary.py sums it per op)\n"
    "Both JSONs carry the CPU, OpenBLAS's kernels and isa_peaks: one core's fp32 FMA and\n"
    "bfloat16 dot-product GFLOP/s (0.3 s after the timed work; -1 where the CPU lacks one).\n";

std::shared_ptr<const Dataset> SyntheticDataset(int obs_dim, int action_dim, bool images,
                                                int episodes, int length) {
  std::mt19937_64 rng(1);
  std::normal_distribution<float> normal;
  std::uniform_int_distribution<int> pixel(0, 255);
  const ImageShape shape = images ? ImageShape{64, 64, 3} : ImageShape{};
  DatasetBuilder b(images ? 0 : obs_dim, action_dim, shape);
  b.Reserve(int64_t{episodes} * length);
  for (int e = 0; e < episodes; ++e) {
    std::vector<float> obs(images ? 0 : length * obs_dim), act(length * action_dim);
    std::vector<uint8_t> img(length * shape.numel());
    for (auto& v : obs) v = normal(rng);
    for (auto& v : act) v = std::tanh(normal(rng));
    for (auto& v : img) v = static_cast<uint8_t>(pixel(rng));
    b.AddEpisode(obs, act, img);
  }
  return std::make_shared<const Dataset>(b.Build());
}

double PeakRssMb() {
  rusage u;
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024.0;
}

// One core's fp32 FMA and bfloat16 dot-product peaks, measured once (0.3 s)
// after the timed work, and printed, so that a figure says what the CPU's
// arithmetic allows (whether bf16 can beat fp32 without AMX).
const IsaPeaks& MeasuredIsaPeaks() {
  static const IsaPeaks peaks = [] {
    const IsaPeaks p = MeasureIsaPeaks(HostCpu());
    std::cerr << "msspr_bench_core: one core's peaks: fp32 FMA (" << p.fp32_isa << ") "
              << p.fp32_gflops << " GFLOP/s, bf16 dot (avx512_bf16) " << p.bf16_dot_gflops
              << " GFLOP/s (-1: the CPU lacks it)\n";
    return p;
  }();
  return peaks;
}

struct TrainResult {
  std::string name;
  int batch = 0;
  int steps = 0;
  double steps_per_s = 0;
  double ms_per_step = 0;
  bool pipelined = false;
};

TrainResult TimeTraining(const std::string& name, MsprOptions o,
                         std::shared_ptr<const Dataset> data, int warmup, int steps) {
  Trainer t(o, data);
  // As Trainer::Train runs them: losses are read back on logged steps only.
  const int log_every = std::max(1, o.trainer.log_every);
  for (int i = 0; i < warmup; ++i) t.Step(false);
  t.Sync();
  if (t.device().is_cuda()) torch::cuda::synchronize();
  const auto start = Clock::now();
  for (int i = 0; i < steps; ++i) t.Step((i + 1) % log_every == 0);
  t.Sync();
  if (t.device().is_cuda()) torch::cuda::synchronize();
  const double s = std::chrono::duration<double>(Clock::now() - start).count();
  TrainResult r;
  r.name = name;
  r.batch = o.trainer.batch_size;
  r.steps = steps;
  r.steps_per_s = steps / s;
  r.ms_per_step = 1000.0 * s / steps;
  r.pipelined = t.pipelined();
  std::cerr << "  " << name << ": batch " << r.batch << ", " << r.ms_per_step << " ms/step ("
            << r.steps_per_s << " steps/s)\n";
  return r;
}

struct LatencyResult {
  std::string name;
  double median_ms = 0;
  double p90_ms = 0;
};

LatencyResult TimeAct(const std::string& name, MsprOptions o, std::shared_ptr<const Dataset> data,
                      int reps) {
  o.trainer.batch_size = 2;
  Trainer t(o, data);
  Policy p = t.MakePolicy();
  torch::Tensor obs, goal;
  if (p.pixels()) {
    obs = torch::randint(0, 256, {64, 64, 3 * o.network.frame_stack}, torch::kUInt8);
    goal = torch::randint(0, 256, {64, 64, 3 * o.network.frame_stack}, torch::kUInt8);
  } else {
    obs = torch::randn({p.obs_dim()});
    goal = torch::randn({p.obs_dim()});
  }
  std::vector<double> ms;
  for (int i = 0; i < reps + 5; ++i) {
    const auto start = Clock::now();
    torch::Tensor a = p.Act(obs, goal).cpu();  // includes the copy back to the host
    const double d = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
    if (i >= 5) ms.push_back(d);
  }
  std::sort(ms.begin(), ms.end());
  LatencyResult r;
  r.name = name;
  r.median_ms = ms[ms.size() / 2];
  r.p90_ms = ms[ms.size() * 9 / 10];
  std::cerr << "  act " << name << ": median " << r.median_ms << " ms, p90 " << r.p90_ms << " ms\n";
  return r;
}

// Writes the JSON to `path` and prints it; 1 when the file cannot be written.
int WriteJson(const std::string& path, const std::string& json) {
  std::ofstream f(path);
  if (!(f << json)) {
    std::cerr << "msspr_bench_core: cannot write " << path << "\n";
    return 1;
  }
  std::cout << json;
  return 0;
}

// --config mode: one configuration, timed after warm-up.
int TimeConfig(const std::vector<std::string>& configs, const std::string& out,
               const std::string& device, const std::string& precision, int steps, int warmup,
               int obs_dim, int action_dim, int episodes, int length, const std::string& profile) {
  MsprOptions o = ResolveOptions("", "", configs, nullptr, "mspr", "cpu");
  o.trainer.device = device;
  if (!precision.empty()) o.trainer.precision = precision;
  o.trainer.precision = EffectivePrecision(o.trainer);
  const bool pixels = o.network.obs_mode == "pixels";
  auto data = SyntheticDataset(obs_dim, action_dim, pixels, episodes, length);
  const TrainResult r = TimeTraining("config", o, data, warmup, steps);
  if (!profile.empty()) {
    Trainer t(o, data);
    for (int i = 0; i < 3; ++i) t.Step();
    torch::autograd::profiler::RecordProfile guard(profile);
    for (int i = 0; i < 5; ++i) t.Step();
  }
  std::ostringstream j;
  j.precision(6);
  j << "{\"device\": \"" << device << "\", \"threads\": " << torch::get_num_threads()
    << ", \"precision\": \"" << o.trainer.precision
    << "\", \"pipelined\": " << (r.pipelined ? "true" : "false") << ", \"obs_mode\": \""
    << o.network.obs_mode << "\", \"batch\": " << r.batch
    << ", \"updates_per_step\": " << o.representation.updates_per_step
    << ", \"timed_steps\": " << r.steps << ", \"warmup_steps\": " << warmup
    << ", \"ms_per_step\": " << r.ms_per_step << ", \"peak_rss_mb\": " << PeakRssMb()
    << ", \"cpu\": " << HostCpu().ToJson() << ", \"openblas_core\": \"" << LoadedOpenBlasCore()
    << "\", \"isa_peaks\": " << MeasuredIsaPeaks().ToJson() << "}\n";
  return WriteJson(out, j.str());
}

struct BenchRequest {
  std::string out, device = "cpu", precision, profile;
  std::vector<std::string> configs;
  int threads = 0, steps = 200, warmup = 20, obs_dim = 2, action_dim = 2, episodes = 100,
      length = 1001;
  bool quick = false;
};

// Throws cli::CliError on a bad command line.
BenchRequest ParseBench(const cli::CliArgs& args) {
  BenchRequest r;
  if (!args.positional().empty())
    throw cli::CliError("unexpected argument '" + args.positional()[0] + "'");
  r.out = args.Get("out", "");
  if (r.out.empty()) throw cli::CliError("--out FILE.json is required");
  r.device = args.Get("device", "cpu");
  r.threads = static_cast<int>(args.GetInt("threads", 0, 0, 4096));
  r.quick = args.Has("quick");
  r.precision =
      args.Has("precision") ? args.GetChoice("precision", "fp32", {"fp32", "bf16", "auto"}) : "";
  // --config a.yaml,b.yaml: layered in order.
  std::stringstream list(args.Get("config", ""));
  for (std::string item; std::getline(list, item, ',');) {
    if (!item.empty()) r.configs.push_back(item);
  }
  r.profile = args.Get("profile", "");
  r.steps = static_cast<int>(args.GetInt("steps", r.steps, 1, 100000000));
  r.warmup = static_cast<int>(args.GetInt("warmup", r.warmup, 0, 100000000));
  r.obs_dim = static_cast<int>(args.GetInt("obs-dim", r.obs_dim, 1, 1000000));
  r.action_dim = static_cast<int>(args.GetInt("action-dim", r.action_dim, 1, 1000000));
  r.episodes = static_cast<int>(args.GetInt("episodes", r.episodes, 1, 100000000));
  r.length = static_cast<int>(args.GetInt("length", r.length, 2, 100000000));
  return r;
}

// A preset on the request's device and precision.
MsprOptions BenchPreset(const std::string& scale, const BenchRequest& r) {
  MsprOptions o = MakePreset("mspr", scale);
  o.trainer.device = r.device;
  if (!r.precision.empty()) o.trainer.precision = r.precision;
  return o;
}

// Where a CPU-scale step goes: ms of each update, timed alone.
std::vector<std::pair<std::string, double>> StepBreakdown(const MsprOptions& o,
                                                          std::shared_ptr<const Dataset> states,
                                                          bool quick) {
  std::vector<std::pair<std::string, double>> breakdown;
  Trainer t(o, std::move(states));
  t.Step();
  const int reps = quick ? 2 : 10;
  auto time_ms = [&](const std::function<void()>& f) {
    const auto start = Clock::now();
    for (int i = 0; i < reps; ++i) f();
    if (t.device().is_cuda()) torch::cuda::synchronize();
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count() / reps;
  };
  const TransitionBatch tb = t.SampleTransitions();
  const ChunkBatch cb = t.SampleChunks();
  const torch::Tensor noise = torch::randn({tb.action.size(0), tb.action.size(1)});
  breakdown.emplace_back("sample_and_gather", time_ms([&] {
                           t.SampleTransitions();
                           t.SampleChunks();
                         }));
  breakdown.emplace_back("representation_update", time_ms([&] { t.UpdateRepresentation(cb); }));
  breakdown.emplace_back("critic_update", time_ms([&] { t.UpdateCritic(tb, noise); }));
  breakdown.emplace_back("actor_update", time_ms([&] { t.UpdateActor(tb); }));
  for (const auto& kv : breakdown) {
    std::cerr << "  cpu_scale_states " << kv.first << ": " << kv.second << " ms\n";
  }
  return breakdown;
}

std::string SuiteJson(const BenchRequest& r, const std::string& precision,
                      const std::vector<TrainResult>& train,
                      const std::vector<std::pair<std::string, double>>& breakdown,
                      const std::vector<LatencyResult>& act, double total_s) {
  std::ostringstream j;
  j.precision(6);
  j << "{\n  \"device\": \"" << r.device << "\",\n  \"precision\": \"" << precision
    << "\",\n  \"threads\": " << torch::get_num_threads() << ",\n  \"cpu\": " << HostCpu().ToJson()
    << ",\n  \"openblas_core\": \"" << LoadedOpenBlasCore() << "\""
    << ",\n  \"isa_peaks\": " << MeasuredIsaPeaks().ToJson()
    << ",\n  \"state_dataset\": {\"obs_dim\": 29, \"action_dim\": 8},\n"
    << "  \"pixel_dataset\": {\"image\": [64, 64, 3], \"action_dim\": 8},\n  \"train\": [\n";
  for (size_t i = 0; i < train.size(); ++i) {
    const TrainResult& t = train[i];
    j << "    {\"name\": \"" << t.name << "\", \"batch\": " << t.batch
      << ", \"timed_steps\": " << t.steps << ", \"steps_per_s\": " << t.steps_per_s
      << ", \"ms_per_step\": " << t.ms_per_step
      << ", \"pipelined\": " << (t.pipelined ? "true" : "false") << "}"
      << (i + 1 < train.size() ? "," : "") << "\n";
  }
  j << "  ],\n  \"cpu_scale_states_breakdown_ms\": {";
  for (size_t i = 0; i < breakdown.size(); ++i) {
    j << (i ? ", " : "") << "\"" << breakdown[i].first << "\": " << breakdown[i].second;
  }
  j << "},\n  \"act_latency\": [\n";
  for (size_t i = 0; i < act.size(); ++i) {
    j << "    {\"name\": \"" << act[i].name << "\", \"median_ms\": " << act[i].median_ms
      << ", \"p90_ms\": " << act[i].p90_ms << "}" << (i + 1 < act.size() ? "," : "") << "\n";
  }
  j << "  ],\n  \"peak_rss_mb\": " << PeakRssMb() << ",\n  \"bench_seconds\": " << total_s
    << "\n}\n";
  return j.str();
}

// The default suite: CPU- and paper-scale steps from states and pixels, a step's
// breakdown, and Policy::Act's latency.
int RunSuite(const BenchRequest& r) {
  const auto t0 = Clock::now();
  // Antmaze-like state sizes; pixels as OGBench's visual tasks.
  auto states = SyntheticDataset(29, 8, false, 50, 200);
  auto pixels = SyntheticDataset(0, 8, true, 10, 100);
  const bool quick = r.quick;
  const int n = quick ? 2 : 10;
  std::vector<TrainResult> train;
  std::cerr << "msspr_bench_core: training steps on " << r.device << " ("
            << torch::get_num_threads() << " threads)\n";
  const MsprOptions cpu_state = BenchPreset("cpu", r);
  train.push_back(TimeTraining("cpu_scale_states", cpu_state, states, 2, n));
  // Algorithm 1 read literally: one representation update every K = 250 steps.
  MsprOptions cpu_state_sparse = cpu_state;
  cpu_state_sparse.representation.updates_per_step = 1.0 / 250.0;
  train.push_back(TimeTraining("cpu_scale_states_repr_every_250", cpu_state_sparse, states, 2, n));
  MsprOptions paper_state = BenchPreset("paper", r);
  paper_state.trainer.batch_size = 1024;
  train.push_back(TimeTraining("paper_scale_states", paper_state, states, 1, quick ? 1 : 4));
  MsprOptions cpu_pix = BenchPreset("cpu", r);
  cpu_pix.network.obs_mode = "pixels";
  cpu_pix.trainer.batch_size = 32;
  train.push_back(TimeTraining("cpu_scale_pixels", cpu_pix, pixels, 1, quick ? 1 : 3));
  MsprOptions paper_pix = BenchPreset("paper", r);
  paper_pix.network.obs_mode = "pixels";
  paper_pix.trainer.batch_size = 256;
  paper_pix.representation.weight_rew = 0.5;
  train.push_back(TimeTraining("paper_scale_pixels", paper_pix, pixels, 1, quick ? 1 : 2));

  const auto breakdown = StepBreakdown(cpu_state, states, quick);

  std::cerr << "msspr_bench_core: single-sample Policy::Act latency\n";
  std::vector<LatencyResult> act;
  const int reps = quick ? 20 : 200;
  act.push_back(TimeAct("state_cpu_scale", cpu_state, states, reps));
  act.push_back(TimeAct("state_paper_scale", paper_state, states, reps));
  act.push_back(TimeAct("image_cpu_scale", cpu_pix, pixels, reps / 2));
  act.push_back(TimeAct("image_paper_scale", paper_pix, pixels, reps / 2));
  const double total_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return WriteJson(
      r.out, SuiteJson(r, EffectivePrecision(cpu_state.trainer), train, breakdown, act, total_s));
}

}  // namespace

int main(int argc, char** argv) {
  ReexecWithToolEnvironment(argv);
  BenchRequest r;
  try {
    const cli::CliArgs args(argc, argv, {"help", "quick"},
                            {"out", "device", "threads", "precision", "config", "profile", "steps",
                             "warmup", "obs-dim", "action-dim", "episodes", "length"});
    if (args.Has("help")) {
      std::cout << kUsage;
      return 0;
    }
    r = ParseBench(args);
  } catch (const cli::CliError& e) {
    std::cerr << "msspr_bench_core: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try {
    if (r.threads > 0) torch::set_num_threads(r.threads);
    if (!r.configs.empty()) {
      return TimeConfig(r.configs, r.out, r.device, r.precision, r.steps, r.warmup, r.obs_dim,
                        r.action_dim, r.episodes, r.length, r.profile);
    }
    return RunSuite(r);
  } catch (const std::exception& e) {
    std::cerr << "msspr_bench_core: error: " << e.what() << "\n";
    return 1;
  }
}
