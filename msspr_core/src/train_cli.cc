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
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "msspr_core/checkpoint.h"
#include "msspr_core/cli_args.h"
#include "msspr_core/cpu_info.h"
#include "msspr_core/npz.h"
#include "msspr_core/stop_signals.h"

namespace msspr {
namespace core {

namespace {

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
    "  --obs-mode MODE    state | pixels (default: pixels when the dataset has only images)\n"
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
// with --resume must repeat the saved value (README "Resuming").
// Neither changes what is learned: the run's length and schedule of side
// work, threads, output, the in-simulator evaluation (ROS msspr_train), and
// the precision of the update's matrix products (its objective stays; the
// weights and optimiser state are fp32 either way).
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

// DIR/run.yaml: what a run was started with (flags, absolute data paths), so
// that --resume --out DIR needs nothing else.
struct RunRecord {
  std::map<std::string, std::string> flags;  // name without "--" -> value
  std::vector<std::string> configs;          // --config, in order
};

RunRecord ReadRunRecord(const std::string& path) {
  RunRecord r;
  try {
    const YAML::Node root = YAML::LoadFile(path);
    if (root["flags"])
      for (const auto& kv : root["flags"])
        r.flags[kv.first.as<std::string>()] = kv.second.as<std::string>();
    if (root["config"])
      for (const auto& c : root["config"]) r.configs.push_back(c.as<std::string>());
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ": cannot read the run record: " + e.what());
  }
  return r;
}

void WriteTextAtomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "w");
  if (!f) throw std::runtime_error(tmp + ": cannot open for writing: " + std::strerror(errno));
  const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  if (std::fclose(f) != 0 || !ok) throw std::runtime_error(tmp + ": cannot write (disk full?)");
  if (std::rename(tmp.c_str(), path.c_str()) != 0)
    throw std::runtime_error(path + ": cannot rename " + tmp + " to it: " + std::strerror(errno));
}

// Where the latest segment ran: the figures in metrics.csv depend on it.
std::string HostRecord(const std::string& precision_why) {
  std::ostringstream s;
  s << "# msspr_train: the machine, threads and precision of the run's latest segment\n"
    << "cpu:\n"
    << HostCpu().ToYaml("  ") << "torch_threads: " << torch::get_num_threads() << "\n"
    << "precision: \"" << precision_why << "\"\n"
    << "libtorch: \"" << TORCH_VERSION << "\"\n";
  return s.str();
}

void WriteRunRecord(const std::string& path, const RunRecord& r) {
  YAML::Emitter out;
  out << YAML::Comment("msspr_train run record: msspr_train --resume --out DIR reads it")
      << YAML::BeginMap;
  out << YAML::Key << "flags" << YAML::Value << YAML::BeginMap;
  for (const auto& [k, v] : r.flags)
    out << YAML::Key << k << YAML::Value << YAML::DoubleQuoted << v;
  out << YAML::EndMap << YAML::Key << "config" << YAML::Value << YAML::BeginSeq;
  for (const auto& c : r.configs) out << YAML::DoubleQuoted << c;
  out << YAML::EndSeq << YAML::EndMap;
  WriteTextAtomically(path, std::string(out.c_str()) + "\n");
}

}  // namespace

int RunTrainCli(int argc, char** argv, const TrainCliExtensions& ext) {
  static const std::set<std::string> kValued = {"data",         "val",
                                                "out",          "preset",
                                                "agent",        "scale",
                                                "obs-mode",     "steps",
                                                "batch",        "device",
                                                "precision",    "seed",
                                                "eval-every",   "checkpoint-every",
                                                "export-every", "log-every",
                                                "time-limit",   "threads",
                                                "world-size",   "rank",
                                                "master",       "dist-timeout"};
  RunRecord given;
  bool resume = false, print_options = false, quiet = false;
  auto usage_error = [&](const std::string& msg) {
    std::cerr << ext.program << ": " << msg << "\n";
    return 2;
  };
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      const std::string key = a.rfind("--", 0) == 0 ? a.substr(2) : "";
      if (a == "--help" || a == "-h") {
        std::cout << Usage(ext);
        return 0;
      } else if (a == "--resume")
        resume = true;
      else if (a == "--print-options")
        print_options = true;
      else if (a == "--quiet")
        quiet = true;
      else if (kValued.count(key) || key == "config" || ext.extra_options.count(key)) {
        if (i + 1 >= argc) throw cli::CliError("missing value after " + a);
        if (key == "config")
          given.configs.push_back(argv[++i]);
        else
          given.flags[key] = argv[++i];
      } else if (a.find(":=") != std::string::npos)
        continue;  // ROS remappings (rosrun, roslaunch)
      else
        throw cli::CliError("unknown argument '" + a + "' (see --help)");
    }
  } catch (const cli::CliError& e) {
    return usage_error(e.what());
  }
  // Data-parallel group: flags over torchrun's environment variables.
  DistributedOptions dist_options;
  try {
    dist_options = DistributedOptions::FromEnvironment();
    dist_options.timeout_s = 1800;
    if (given.flags.count("world-size"))
      dist_options.world_size =
          static_cast<int>(cli::ParseInt("world-size", given.flags["world-size"], 1, 4096));
    if (given.flags.count("rank"))
      dist_options.rank = static_cast<int>(cli::ParseInt("rank", given.flags["rank"], 0, 4095));
    if (given.flags.count("master")) {
      const std::string m = given.flags["master"];
      const size_t colon = m.rfind(':');
      if (colon == std::string::npos || colon == 0)
        throw cli::CliError("--master: expected HOST:PORT, got '" + m + "'");
      dist_options.master_addr = m.substr(0, colon);
      dist_options.master_port =
          static_cast<int>(cli::ParseInt("master port", m.substr(colon + 1), 1, 65535));
    }
    if (given.flags.count("dist-timeout"))
      dist_options.timeout_s = static_cast<double>(
          cli::ParseInt("dist-timeout", given.flags["dist-timeout"], 1, 1 << 30));
    dist_options.Validate();
  } catch (const cli::CliError& e) {
    return usage_error(e.what());
  } catch (const DistributedError& e) {
    return usage_error(e.what());
  }
  // Ranks other than 0 read the run directory but never write to it (no lock either).
  const bool follower = dist_options.enabled() && dist_options.rank != 0;
  if (follower) quiet = true;
  const std::string out_dir = given.flags.count("out") ? given.flags["out"] : "";
  const std::string ckpt = out_dir + "/checkpoint.ckpt", run_file = out_dir + "/run.yaml";
  std::unique_ptr<RunDirLock> lock;
  RunRecord run = given;  // the flags in force: saved ones, then allowed changes
  for (const char* k : {"data", "val"})
    if (run.flags.count(k)) run.flags[k] = Absolute(run.flags[k]);
  for (auto& c : run.configs) c = Absolute(c);
  bool have_checkpoint = false;
  try {
    // --resume of a directory that is not there: refused below, without creating it.
    if (!out_dir.empty() && !print_options && (!resume || std::filesystem::is_directory(out_dir))) {
      if (!follower) {
        std::filesystem::create_directories(out_dir);
        lock = std::make_unique<RunDirLock>(out_dir);  // held until we return
      }
      have_checkpoint = FileExists(ckpt) || FileExists(ckpt + ".prev");
    }
    if (resume) {
      if (out_dir.empty()) return usage_error("--resume needs --out DIR");
      const bool have_record = FileExists(run_file);
      if (!have_record && !have_checkpoint)
        return usage_error("--resume: " + out_dir +
                           " holds no run (no run.yaml, no checkpoint.ckpt)");
      if (have_record) {
        RunRecord saved = ReadRunRecord(run_file);
        for (const auto& [k, v] : run.flags) {
          if (kResumeMayChange.count(k) || k == "out") continue;
          auto it = saved.flags.find(k);
          if (it == saved.flags.end() || it->second != v)
            return usage_error(
                "--resume: --" + k + " " + given.flags[k] + " differs from the run in " + run_file +
                " (" + (it == saved.flags.end() ? "not given" : it->second) + ")" + kResumeRule);
        }
        if (!given.configs.empty() && run.configs != saved.configs)
          return usage_error("--resume: --config differs from the run in " + run_file +
                             kResumeRule);
        for (const auto& [k, v] : run.flags) saved.flags[k] = v;
        run = saved;
      }
    } else if (!follower && !out_dir.empty() && !print_options &&
               (have_checkpoint || FileExists(run_file))) {
      return usage_error(
          out_dir + " already holds a training run (" + (have_checkpoint ? ckpt : run_file) +
          "); continue it with --resume --out " + out_dir + ", or choose another --out");
    }
  } catch (const std::exception& e) {
    std::cerr << ext.program << ": error: " << e.what() << "\n";
    return 1;
  }
  auto flag = [&run](const std::string& k) {
    return run.flags.count(k) ? run.flags.at(k) : std::string();
  };
  long long threads = 0, steps = -1, batch = -1, seed = -1, eval_every = -1, ckpt_every = -1,
            export_every = -1, log_every = -1, time_limit = -1;
  try {
    auto number = [&](const std::string& k, long long lo, long long hi, long long* v) {
      if (run.flags.count(k)) *v = cli::ParseInt(k, run.flags.at(k), lo, hi);
    };
    number("steps", 0, 1LL << 40, &steps);
    number("batch", 1, 1 << 20, &batch);
    number("seed", 0, LLONG_MAX, &seed);
    number("eval-every", 0, INT_MAX, &eval_every);
    number("checkpoint-every", 0, INT_MAX, &ckpt_every);
    number("export-every", 0, INT_MAX, &export_every);
    number("log-every", 1, INT_MAX, &log_every);
    number("time-limit", 0, 1LL << 40, &time_limit);
    number("threads", 0, 4096, &threads);
  } catch (const cli::CliError& e) {
    return usage_error(e.what());
  }
  const std::string data_path = flag("data"), val_path = flag("val"), device = flag("device"),
                    obs_mode = flag("obs-mode"), precision = flag("precision");
  if (!precision.empty() && precision != "fp32" && precision != "bf16" && precision != "auto")
    return usage_error("--precision must be fp32, bf16 or auto, got '" + precision + "'");
  std::map<std::string, std::string> extra;
  for (const auto& k : ext.extra_options)
    if (run.flags.count(k)) extra[k] = run.flags.at(k);

  try {
    if (threads > 0) torch::set_num_threads(static_cast<int>(threads));
    MsprOptions options;
    const bool from_checkpoint = resume && have_checkpoint;
    if (from_checkpoint) {
      options = ReadCheckpointOptions(ckpt);
    } else {
      std::vector<std::string> notes;
      std::string preset = run.flags.count("preset") ? run.flags["preset"] : "";
      if (run.flags.count("agent")) {
        const std::string agent = run.flags["agent"];
        const std::vector<std::string> agents = AgentNames();
        if (std::find(agents.begin(), agents.end(), agent) == agents.end())
          return usage_error("--agent: unknown agent '" + agent +
                             "' (expected mspr, gcbc, gcivl, gciql, qrl, crl or hiql)");
        const std::vector<std::string> mspr_presets{"mspr", "D", "DI", "DIR"};
        const bool preset_is_mspr =
            std::find(mspr_presets.begin(), mspr_presets.end(), preset) != mspr_presets.end();
        if (!preset.empty() && (agent == "mspr" ? !preset_is_mspr : preset != agent))
          return usage_error("--agent " + agent + " conflicts with --preset " + preset);
        if (agent != "mspr") preset = agent;
      }
      options = ResolveOptions(preset, run.flags.count("scale") ? run.flags["scale"] : "",
                               run.configs, &notes);
      for (const std::string& n : notes) std::cerr << "msspr_train: " << n << "\n";
    }
    if (steps >= 0) options.trainer.steps = steps;
    if (batch > 0) options.trainer.batch_size = static_cast<int>(batch);
    if (!device.empty()) options.trainer.device = device;
    if (!precision.empty()) options.trainer.precision = precision;
    if (seed >= 0 && !from_checkpoint) options.trainer.seed = static_cast<uint64_t>(seed);
    if (eval_every >= 0) options.trainer.eval_every = static_cast<int>(eval_every);
    if (ckpt_every >= 0) options.trainer.checkpoint_every = static_cast<int>(ckpt_every);
    if (export_every >= 0) options.trainer.export_every = static_cast<int>(export_every);
    if (log_every > 0) options.trainer.log_every = static_cast<int>(log_every);
    if (time_limit >= 0) options.trainer.time_limit_s = static_cast<double>(time_limit);
    if (!obs_mode.empty()) options.network.obs_mode = obs_mode;
    // "auto" is decided here, on this machine; options.yaml and the checkpoint
    // record the result.
    std::string precision_why;
    options.trainer.precision = EffectivePrecision(options.trainer, &precision_why);
    if (print_options && data_path.empty()) {
      std::cout << OptionsToYaml(options);
      return 0;
    }
    if (data_path.empty())
      return usage_error(std::string("--data FILE is required (see --help)") +
                         (resume ? "; " + run_file + " has none either" : ""));
    if (out_dir.empty() && !print_options) return usage_error("--out DIR is required (see --help)");

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
    if (obs_mode.empty() && !data->has_states()) options.network.obs_mode = "pixels";

    Trainer trainer(options, data);
    if (print_options) {
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
    if (!follower) WriteRunRecord(run_file, run);
    if (from_checkpoint) {
      trainer.LoadCheckpoint(ckpt);
      std::cerr << ext.program << ": resumed " << ckpt << " at step " << trainer.step() << "\n";
    } else if (resume) {
      std::cerr << ext.program << ": resumed " << out_dir
                << " before its first checkpoint: from step 0\n";
    }
    // The resolved options, for the record.
    if (!follower) {
      WriteTextAtomically(out_dir + "/options.yaml", OptionsToYaml(trainer.options()));
      WriteTextAtomically(out_dir + "/host.yaml", HostRecord(precision_why));
    }
    std::cerr << ext.program << ": precision " << trainer.options().trainer.precision << " ("
              << precision_why << "), " << torch::get_num_threads() << " torch thread(s) on "
              << HostCpu().Summary() << "\n";

    // Rank 0 alone validates and evaluates.
    std::shared_ptr<const Dataset> val;
    if (!follower && !val_path.empty())
      val = load(val_path, true);
    else if (!follower && ext.default_validation)
      val = ext.default_validation(data_path, trainer.options());
    if (val)
      std::cerr << ext.program << ": validation: " << val->size() << " steps, "
                << val->num_trajectories() << " trajectories\n";
    Evaluator sim_eval =
        ext.make_evaluator && !follower ? ext.make_evaluator(trainer, extra, out_dir) : Evaluator();
    Evaluator evaluator;
    if (val || sim_eval) {
      // Validation losses on the same fixed batches each time, then the extra evaluator.
      const int b = std::min(trainer.options().trainer.batch_size, 1024);
      evaluator = [&trainer, val, b, sim_eval](Policy& policy, int64_t step) -> EvalResult {
        EvalResult r;
        if (val)
          for (const auto& kv : trainer.ValidationLosses(*val, b, 12345).Named())
            r.emplace_back("val_" + kv.first, kv.second);
        if (sim_eval)
          for (auto& kv : sim_eval(policy, step)) r.push_back(std::move(kv));
        return r;
      };
    }
    TrainLoopOptions loop;
    loop.out_dir = out_dir;
    loop.quiet = quiet;
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
      std::cerr << ext.program << ": rank " << dist_options.rank << " done at step "
                << trainer.step() << "\n";
    else
      std::cerr << ext.program << ": done at step " << trainer.step() << "; wrote " << out_dir
                << "/checkpoint.ckpt and " << out_dir << "/policy.pt\n";
  } catch (const cli::CliError& e) {
    return usage_error(e.what());
  } catch (const std::exception& e) {
    std::cerr << ext.program << ": error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace core
}  // namespace msspr
