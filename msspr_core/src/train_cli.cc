#include "msspr_core/train_cli.h"

#include <signal.h>
#include <sys/stat.h>
#include <torch/version.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "msspr_core/checkpoint.h"
#include "msspr_core/cli_args.h"
#include "msspr_core/cpu_info.h"
#include "msspr_core/npz.h"
#include "msspr_core/process_env.h"
#include "msspr_core/stop_signals.h"
#include "run_record.h"

namespace msspr {
namespace core {

namespace {

using internal::BlasNote;
using internal::CurrentFlagName;
using internal::HostRecord;
using internal::kRenamedFlags;
using internal::ReadRunRecord;
using internal::RunRecord;
using internal::WriteRunRecord;
using internal::WriteTextAtomically;

const char kUsage[] =
    "usage: %PROGRAM% --data FILE --out DIR [options]\n"
    "\n"
    "Trains Ms.PR (multi-scale predictive representations) offline, or one of OGBench's\n"
    "baseline agents (--agent).\n"
    "\n"
    "  --data FILE        training dataset: %DATA%\n"
    "  --val FILE         validation dataset (.npz); its critic/representation losses are\n"
    "                     logged to eval.csv at every --eval-every\n"
    "  --out DIR          output directory: metrics.csv, eval.csv, checkpoint.ckpt, policy.pt,\n"
    "                     options.yaml, host.yaml (the CPU, threads and precision)\n"
    "  --agent NAME       mspr (default) | gcbc | gcivl | gciql | qrl | crl | hiql: the baselines\n"
    "                     with OGBench's pointmaze hyperparameters (the preset of that name;\n"
    "                     config/agents/ has the other environments' settings)\n"
    "  --preset NAME      mspr (default) | D | DI | DIR (ablations) | a baseline agent's name;\n"
    "                     wins over a config's preset:\n"
    "  --scale NAME       paper (default) | cpu; wins over a config's scale:\n"
    "  --config YAML      options file applied on top of the preset (may repeat; later files\n"
    "                     override earlier ones key by key)\n"
    "  --observation-mode MODE  state | pixels: what the network reads (default: pixels when\n"
    "                     the dataset has only images; --obs-mode is the old spelling)\n"
    "  --steps N          training steps (overrides trainer.steps)\n"
    "  --batch N          batch size (overrides trainer.batch_size)\n"
    "  --device DEV       cpu | cuda | cuda:N (default cpu)\n"
    "  --precision P      fp32 | bf16 | auto: the update's matrix products (overrides\n"
    "                     trainer.precision; auto: bf16 on a CPU with bfloat16 arithmetic,\n"
    "                     AVX512-BF16 or AMX, else fp32; may change on --resume)\n"
    "  --seed S           random seed (default 0)\n"
    "  --eval-every N     validation period in steps (0: never)\n"
    "  --checkpoint-every N  checkpoint period in steps (0: only at the end)\n"
    "  --export-every N   also export DIR/policy_step<N>.pt every N steps (learning curves)\n"
    "  --log-every N      progress / metrics period in steps\n"
    "  --time-limit S     stop after S seconds of wall time (then the final evaluation,\n"
    "                     checkpoint and export); 0: none\n"
    "  --resume           continue the run in DIR (its data, flags and checkpoint.ckpt); only\n"
    "                     --steps, --time-limit, --eval-every, --checkpoint-every,\n"
    "                     --export-every, --log-every, --threads, --precision, --quiet and the\n"
    "                     --eval-* flags may differ from the saved run (DIR/run.yaml)\n"
    "  --print-options    print the resolved options as YAML and exit\n"
    "  --threads N        torch CPU threads (default: torch's choice; 1 is often fastest\n"
    "                     on shared cores)\n"
    "  --quiet            no progress output\n"
    "  --world-size N     data-parallel training over N processes (torch.distributed c10d:\n"
    "                     Gloo on CPU, NCCL on CUDA where LibTorch has it); default $WORLD_SIZE or "
    "1\n"
    "  --rank R           this process's rank, 0..N-1 (default $RANK or 0); rank 0 alone writes\n"
    "                     DIR's files, logs and evaluates; every rank gets the same --out DIR\n"
    "  --master HOST:PORT rendezvous of the group, rank 0 listens there (default\n"
    "                     $MASTER_ADDR:$MASTER_PORT or 127.0.0.1:29500)\n"
    "  --dist-timeout S   seconds before a missing peer or a stuck collective is an error (1800)\n"
    "  --help             this text\n"
    "\n"
    "SIGINT (Ctrl-C) or SIGTERM while training: the run stops after the current step, writes\n"
    "DIR/checkpoint.ckpt and DIR/policy.pt (no final evaluation) and exits with 128 + the\n"
    "signal number (130, 143); --resume continues from that step. A second signal ends the\n"
    "process at once (the last periodic checkpoint stays good). A SIGINT the shell ignores\n"
    "(a background job) stays ignored.\n";

bool FileExists(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0;
}

std::string Usage(const TrainCliExtensions& ext) {
  std::string u = kUsage;
  auto replace = [&u](const std::string& key, const std::string& value) {
    for (size_t p = u.find(key); p != std::string::npos; p = u.find(key, p + value.size()))
      u.replace(p, key.size(), value);
  };
  replace("%PROGRAM%", ext.program);
  replace("%DATA%", ext.data_help);
  return u + ext.extra_usage;
}

// Flags that may differ from the saved run on --resume; any other flag given
// with --resume must repeat the saved value (docs/training.md "Checkpoints, resuming and
// stopping"). Neither changes what is learned: the run's length and schedule of side work, threads,
// output, the in-simulator evaluation (ROS msspr_train), and the precision of the update's matrix
// products (its objective stays; the weights and optimiser state are fp32 either way).
const std::set<std::string> kResumeMayChange = {
    "steps",     "time-limit",     "eval-every", "checkpoint-every", "export-every", "log-every",
    "threads",   "precision",      "quiet",      "eval-episodes",    "eval-tasks",   "eval-seed",
    "eval-maze", "eval-max-steps", "rank",       "master",           "dist-timeout"};
const char kResumeRule[] =
    "; on --resume only --steps, --time-limit, --eval-every, --checkpoint-every, --log-every, "
    "--export-every, --threads, --precision, --quiet and the --eval-* flags may change";

std::string Absolute(const std::string& list) {  // each of "a,b,c", made absolute
  std::string out, item;
  std::stringstream ss(list);
  while (std::getline(ss, item, ',')) {
    if (item.empty()) continue;
    out += (out.empty() ? "" : ",") + std::filesystem::absolute(item).lexically_normal().string();
  }
  return out;
}

// A usage error: the program prints the message and exits with 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// What the command line asks for.
struct CliRequest {
  RunRecord given;  // the valued flags and --config files as given
  bool help = false, resume = false, print_options = false, quiet = false;
};

// Reads argv; throws cli::CliError for an unknown argument or a missing value.
CliRequest ParseCommandLine(int argc, char** argv, const TrainCliExtensions& ext) {
  static const std::set<std::string> kValued = {"data",
                                                "val",
                                                "out",
                                                "preset",
                                                "agent",
                                                "scale",
                                                "observation-mode",
                                                "steps",
                                                "batch",
                                                "device",
                                                "precision",
                                                "seed",
                                                "eval-every",
                                                "checkpoint-every",
                                                "export-every",
                                                "log-every",
                                                "time-limit",
                                                "threads",
                                                "world-size",
                                                "rank",
                                                "master",
                                                "dist-timeout"};
  CliRequest req;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    std::string key = a.rfind("--", 0) == 0 ? a.substr(2) : "";
    if (kRenamedFlags.count(key)) {
      std::cerr << "msspr_train: warning: --" << key << " is deprecated; use --"
                << CurrentFlagName(key) << "\n";
      key = CurrentFlagName(key);
    }
    if (a == "--help" || a == "-h") {
      req.help = true;
      return req;
    } else if (a == "--resume") {
      req.resume = true;
    } else if (a == "--print-options") {
      req.print_options = true;
    } else if (a == "--quiet") {
      req.quiet = true;
    } else if (kValued.count(key) || key == "config" || ext.extra_options.count(key)) {
      if (i + 1 >= argc) throw cli::CliError("missing value after " + a);
      if (key == "config")
        req.given.configs.push_back(argv[++i]);
      else
        req.given.flags[key] = argv[++i];
    } else if (a.find(":=") == std::string::npos) {  // (ROS remappings: rosrun, roslaunch)
      throw cli::CliError("unknown argument '" + a + "' (see --help)");
    }
  }
  return req;
}

// The data-parallel group: flags over torchrun's environment variables. Throws
// cli::CliError or DistributedError.
DistributedOptions ParseDistributed(const std::map<std::string, std::string>& flags) {
  DistributedOptions d = DistributedOptions::FromEnvironment();
  d.timeout_s = 1800;
  auto has = [&](const char* k) { return flags.count(k) > 0; };
  if (has("world-size"))
    d.world_size = static_cast<int>(cli::ParseInt("world-size", flags.at("world-size"), 1, 4096));
  if (has("rank")) d.rank = static_cast<int>(cli::ParseInt("rank", flags.at("rank"), 0, 4095));
  if (has("master")) {
    const std::string m = flags.at("master");
    const size_t colon = m.rfind(':');
    if (colon == std::string::npos || colon == 0)
      throw cli::CliError("--master: expected HOST:PORT, got '" + m + "'");
    d.master_addr = m.substr(0, colon);
    d.master_port = static_cast<int>(cli::ParseInt("master port", m.substr(colon + 1), 1, 65535));
  }
  if (has("dist-timeout"))
    d.timeout_s =
        static_cast<double>(cli::ParseInt("dist-timeout", flags.at("dist-timeout"), 1, 1 << 30));
  d.Validate();
  return d;
}

// The run directory: its lock (held until the run returns) and the flags in force,
// the saved run's on --resume with the allowed changes. Throws UsageError for a
// --resume that does not fit the saved run, or an --out that holds another run.
struct RunDir {
  std::string out_dir, ckpt, run_file;
  std::unique_ptr<RunDirLock> lock;
  RunRecord run;
  bool have_checkpoint = false;
};

RunDir OpenRunDir(const CliRequest& req, bool follower) {
  RunDir d;
  const RunRecord& given = req.given;
  d.out_dir = given.flags.count("out") ? given.flags.at("out") : "";
  d.ckpt = d.out_dir + "/checkpoint.ckpt";
  d.run_file = d.out_dir + "/run.yaml";
  d.run = given;
  for (const char* k : {"data", "val"})
    if (d.run.flags.count(k)) d.run.flags[k] = Absolute(d.run.flags[k]);
  for (auto& c : d.run.configs) c = Absolute(c);
  // --resume of a directory that is not there: refused below, without creating it.
  if (!d.out_dir.empty() && !req.print_options &&
      (!req.resume || std::filesystem::is_directory(d.out_dir))) {
    if (!follower) {  // ranks other than 0 read the directory but never write to it
      std::filesystem::create_directories(d.out_dir);
      d.lock = std::make_unique<RunDirLock>(d.out_dir);
    }
    d.have_checkpoint = FileExists(d.ckpt) || FileExists(d.ckpt + ".prev");
  }
  if (req.resume) {
    if (d.out_dir.empty()) throw UsageError("--resume needs --out DIR");
    const bool have_record = FileExists(d.run_file);
    if (!have_record && !d.have_checkpoint)
      throw UsageError("--resume: " + d.out_dir +
                       " holds no run (no run.yaml, no checkpoint.ckpt)");
    if (have_record) {
      RunRecord saved = ReadRunRecord(d.run_file);
      for (const auto& [k, v] : d.run.flags) {
        if (kResumeMayChange.count(k) || k == "out") continue;
        auto it = saved.flags.find(k);
        if (it == saved.flags.end() || it->second != v)
          throw UsageError("--resume: --" + k + " " + given.flags.at(k) +
                           " differs from the run in " + d.run_file + " (" +
                           (it == saved.flags.end() ? "not given" : it->second) + ")" +
                           kResumeRule);
      }
      if (!given.configs.empty() && d.run.configs != saved.configs)
        throw UsageError("--resume: --config differs from the run in " + d.run_file + kResumeRule);
      for (const auto& [k, v] : d.run.flags) saved.flags[k] = v;
      d.run = saved;
    }
  } else if (!follower && !d.out_dir.empty() && !req.print_options &&
             (d.have_checkpoint || FileExists(d.run_file))) {
    throw UsageError(
        d.out_dir + " already holds a training run (" + (d.have_checkpoint ? d.ckpt : d.run_file) +
        "); continue it with --resume --out " + d.out_dir + ", or choose another --out");
  }
  return d;
}

// The numeric flags in force (-1: not given; threads 0: torch's choice). Throws cli::CliError.
struct NumericFlags {
  long long threads = 0, steps = -1, batch = -1, seed = -1, eval_every = -1, ckpt_every = -1,
            export_every = -1, log_every = -1, time_limit = -1;
};

NumericFlags ParseNumbers(const std::map<std::string, std::string>& flags) {
  NumericFlags n;
  auto number = [&](const std::string& k, long long lo, long long hi, long long* v) {
    if (flags.count(k)) *v = cli::ParseInt(k, flags.at(k), lo, hi);
  };
  number("steps", 0, 1LL << 40, &n.steps);
  number("batch", 1, 1 << 20, &n.batch);
  number("seed", 0, LLONG_MAX, &n.seed);
  number("eval-every", 0, INT_MAX, &n.eval_every);
  number("checkpoint-every", 0, INT_MAX, &n.ckpt_every);
  number("export-every", 0, INT_MAX, &n.export_every);
  number("log-every", 1, INT_MAX, &n.log_every);
  number("time-limit", 0, 1LL << 40, &n.time_limit);
  number("threads", 0, 4096, &n.threads);
  return n;
}

// The options of the run: the checkpoint's on a resume from one, else the preset
// (--agent / --preset), --scale and the --config files; then the flags over them.
// "auto" precision is decided here, on this machine (options.yaml and the
// checkpoint record the result; *precision_why says why). Throws UsageError.
MsprOptions RunOptions(const RunRecord& run, bool from_checkpoint, const std::string& ckpt,
                       const NumericFlags& n, std::string* precision_why) {
  auto flag = [&run](const std::string& k) {
    return run.flags.count(k) ? run.flags.at(k) : std::string();
  };
  MsprOptions options;
  if (from_checkpoint) {
    options = ReadCheckpointOptions(ckpt);
  } else {
    std::vector<std::string> notes;
    std::string preset = flag("preset");
    if (const std::string agent = flag("agent"); !agent.empty()) {
      const std::vector<std::string> agents = AgentNames();
      if (std::find(agents.begin(), agents.end(), agent) == agents.end())
        throw UsageError("--agent: unknown agent '" + agent +
                         "' (expected mspr, gcbc, gcivl, gciql, qrl, crl or hiql)");
      const std::vector<std::string> mspr_presets{"mspr", "D", "DI", "DIR"};
      const bool preset_is_mspr =
          std::find(mspr_presets.begin(), mspr_presets.end(), preset) != mspr_presets.end();
      if (!preset.empty() && (agent == "mspr" ? !preset_is_mspr : preset != agent))
        throw UsageError("--agent " + agent + " conflicts with --preset " + preset);
      if (agent != "mspr") preset = agent;
    }
    options = ResolveOptions(preset, flag("scale"), run.configs, &notes);
    for (const std::string& note : notes) std::cerr << "msspr_train: " << note << "\n";
  }
  TrainerOptions& t = options.trainer;
  if (n.steps >= 0) t.steps = n.steps;
  if (n.batch > 0) t.batch_size = static_cast<int>(n.batch);
  if (!flag("device").empty()) t.device = flag("device");
  if (!flag("precision").empty()) t.precision = flag("precision");
  if (n.seed >= 0 && !from_checkpoint) t.seed = static_cast<uint64_t>(n.seed);
  if (n.eval_every >= 0) t.eval_every = static_cast<int>(n.eval_every);
  if (n.ckpt_every >= 0) t.checkpoint_every = static_cast<int>(n.ckpt_every);
  if (n.export_every >= 0) t.export_every = static_cast<int>(n.export_every);
  if (n.log_every > 0) t.log_every = static_cast<int>(n.log_every);
  if (n.time_limit >= 0) t.time_limit_s = static_cast<double>(n.time_limit);
  if (!flag("observation-mode").empty()) options.network.obs_mode = flag("observation-mode");
  t.precision = EffectivePrecision(t, precision_why);
  return options;
}

// Validation losses on the same fixed batches each time, then the extra (simulator)
// evaluator; empty when there is neither.
Evaluator CombinedEvaluator(Trainer& trainer, std::shared_ptr<const Dataset> val,
                            Evaluator sim_eval) {
  if (!val && !sim_eval) return Evaluator();
  const int b = std::min(trainer.options().trainer.batch_size, 1024);
  return [&trainer, val, b, sim_eval](Policy& policy, int64_t step) -> EvalResult {
    EvalResult r;
    if (val)
      for (const auto& kv : trainer.ValidationLosses(*val, b, 12345).Named())
        r.emplace_back("val_" + kv.first, kv.second);
    if (sim_eval)
      for (auto& kv : sim_eval(policy, step)) r.push_back(std::move(kv));
    return r;
  };
}

// Loads, trains and reports a run whose directory and options are settled.
// Returns the exit status; throws cli::CliError, UsageError and std::exception.
int TrainRun(const CliRequest& req, const RunDir& dir, const DistributedOptions& dist_options,
             const TrainCliExtensions& ext) {
  const bool follower = dist_options.enabled() && dist_options.rank != 0;
  const RunRecord& run = dir.run;
  auto flag = [&run](const std::string& k) {
    return run.flags.count(k) ? run.flags.at(k) : std::string();
  };
  const NumericFlags n = ParseNumbers(run.flags);
  const std::string precision = flag("precision");
  if (!precision.empty() && precision != "fp32" && precision != "bf16" && precision != "auto")
    throw UsageError("--precision must be fp32, bf16 or auto, got '" + precision + "'");
  std::map<std::string, std::string> extra;
  for (const auto& k : ext.extra_options)
    if (run.flags.count(k)) extra[k] = run.flags.at(k);
  if (n.threads > 0) torch::set_num_threads(static_cast<int>(n.threads));
  const bool from_checkpoint = req.resume && dir.have_checkpoint;
  std::string precision_why;
  MsprOptions options = RunOptions(run, from_checkpoint, dir.ckpt, n, &precision_why);
  const std::string data_path = flag("data"), val_path = flag("val");
  if (req.print_options && data_path.empty()) {
    std::cout << OptionsToYaml(options);
    // Where trainer.precision came from ("auto: ..." when resolved on this CPU).
    std::cerr << ext.program << ": precision " << options.trainer.precision << " (" << precision_why
              << ")\n";
    return 0;
  }
  if (data_path.empty())
    throw UsageError(std::string("--data FILE is required (see --help)") +
                     (req.resume ? "; " + dir.run_file + " has none either" : ""));
  if (dir.out_dir.empty() && !req.print_options)
    throw UsageError("--out DIR is required (see --help)");

  auto load = [&](const std::string& path, bool validation) -> std::shared_ptr<const Dataset> {
    if (ext.load_dataset) {
      auto d = ext.load_dataset(path, validation, options);
      if (d) return d;
    }
    return std::make_shared<const Dataset>(LoadNpzDataset(path));
  };
  auto data = load(data_path, false);
  std::cerr << ext.program << ": " << data_path << ": " << data->size() << " steps, "
            << data->num_trajectories() << " trajectories, obs_dim " << data->obs_dim()
            << (data->has_images() ? ", images" : "") << ", action_dim " << data->action_dim()
            << "\n";
  if (flag("observation-mode").empty() && !data->has_states()) options.network.obs_mode = "pixels";

  Trainer trainer(options, data);
  if (req.print_options) {
    std::cout << OptionsToYaml(trainer.options());
    return 0;
  }
  if (dist_options.enabled()) {
    auto dist = std::make_shared<Distributed>(dist_options,
                                              torch::Device(trainer.options().trainer.device));
    trainer.SetDistributed(dist);
    std::cerr << ext.program << ": rank " << dist->rank() << " of " << dist->world_size() << " ("
              << dist->backend() << ", master " << dist_options.master_addr << ":"
              << dist_options.master_port << "): batch " << trainer.local_batch() << " of "
              << trainer.options().trainer.batch_size << "\n";
  }
  // Once the data has loaded: from here on --resume --out DIR needs nothing else.
  if (!follower) WriteRunRecord(dir.run_file, run);
  if (from_checkpoint) {
    trainer.LoadCheckpoint(dir.ckpt);
    std::cerr << ext.program << ": resumed " << dir.ckpt << " at step " << trainer.step() << "\n";
  } else if (req.resume) {
    std::cerr << ext.program << ": resumed " << dir.out_dir
              << " before its first checkpoint: from step 0\n";
  }
  // The resolved options, for the record.
  if (!follower) {
    WriteTextAtomically(dir.out_dir + "/options.yaml", OptionsToYaml(trainer.options()));
    WriteTextAtomically(dir.out_dir + "/host.yaml", HostRecord(precision_why));
  }
  std::cerr << ext.program << ": precision " << trainer.options().trainer.precision << " ("
            << precision_why << "), " << torch::get_num_threads() << " torch thread(s) on "
            << HostCpu().Summary() << BlasNote() << "\n";

  // Rank 0 alone validates and evaluates.
  std::shared_ptr<const Dataset> val;
  if (!follower && !val_path.empty())
    val = load(val_path, true);
  else if (!follower && ext.default_validation)
    val = ext.default_validation(data_path, trainer.options());
  if (val)
    std::cerr << ext.program << ": validation: " << val->size() << " steps, "
              << val->num_trajectories() << " trajectories\n";
  Evaluator sim_eval = ext.make_evaluator && !follower
                           ? ext.make_evaluator(trainer, extra, dir.out_dir)
                           : Evaluator();
  const Evaluator evaluator = CombinedEvaluator(trainer, val, sim_eval);
  TrainLoopOptions loop;
  loop.out_dir = dir.out_dir;
  loop.quiet = req.quiet || follower;
  const std::string out_dir = dir.out_dir;
  if (ext.after_eval) loop.on_eval_written = [&ext, out_dir] { ext.after_eval(out_dir); };
  StopOnSignals signals;
  loop.stop_requested = signals.flag();
  if (trainer.Train(loop, evaluator) == TrainEnd::kStopRequested) {
    const int sig = signals.signal();
    std::cerr << ext.program << ": "
              << (sig == SIGINT    ? "SIGINT"
                  : sig == SIGTERM ? "SIGTERM"
                                   : "a signal")
              << ": stopped at step " << trainer.step() << "; "
              << (follower
                      ? ""
                      : "wrote " + out_dir + "/checkpoint.ckpt and " + out_dir + "/policy.pt; ")
              << "continue with --resume --out " << out_dir << "\n";
    return 128 + (sig > 0 ? sig : SIGTERM);
  }
  if (follower)
    std::cerr << ext.program << ": rank " << dist_options.rank << " done at step " << trainer.step()
              << "\n";
  else
    std::cerr << ext.program << ": done at step " << trainer.step() << "; wrote " << out_dir
              << "/checkpoint.ckpt and " << out_dir << "/policy.pt\n";
  return 0;
}

}  // namespace

int RunTrainCli(int argc, char** argv, const TrainCliExtensions& ext) {
  auto usage_error = [&](const std::string& msg) {
    std::cerr << ext.program << ": " << msg << "\n";
    return 2;
  };
  auto error = [&](const std::string& msg) {
    std::cerr << ext.program << ": error: " << msg << "\n";
    return 1;
  };
  CliRequest req;
  DistributedOptions dist_options;
  try {
    req = ParseCommandLine(argc, argv, ext);
    if (req.help) {
      std::cout << Usage(ext);
      return 0;
    }
    dist_options = ParseDistributed(req.given.flags);
  } catch (const cli::CliError& e) {
    return usage_error(e.what());
  } catch (const DistributedError& e) {
    return usage_error(e.what());
  }
  const bool follower = dist_options.enabled() && dist_options.rank != 0;
  RunDir dir;
  try {
    dir = OpenRunDir(req, follower);
  } catch (const UsageError& e) {
    return usage_error(e.what());
  } catch (const std::exception& e) {
    return error(e.what());
  }
  try {
    return TrainRun(req, dir, dist_options, ext);
  } catch (const UsageError& e) {
    return usage_error(e.what());
  } catch (const cli::CliError& e) {
    return usage_error(e.what());
  } catch (const std::exception& e) {
    return error(e.what());
  }
}

}  // namespace core
}  // namespace msspr
