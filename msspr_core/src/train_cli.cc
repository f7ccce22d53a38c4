#include "msspr_core/train_cli.h"

#include <sys/stat.h>

#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "msspr_core/checkpoint.h"
#include "msspr_core/npz.h"

namespace msspr {
namespace core {

namespace {

const char kUsage[] =
    "usage: %PROGRAM% --data FILE --out DIR [options]\n"
    "\n"
    "Trains Ms.PR (multi-scale predictive representations) offline.\n"
    "\n"
    "  --data FILE        training dataset: %DATA%\n"
    "  --val FILE         validation dataset (.npz); its critic/representation losses are\n"
    "                     logged to eval.csv at every --eval-every\n"
    "  --out DIR          output directory: metrics.csv, eval.csv, checkpoint.ckpt, policy.pt,\n"
    "                     options.yaml\n"
    "  --preset NAME      mspr (default) | D | DI | DIR (ablations)\n"
    "  --scale NAME       paper (default) | cpu\n"
    "  --config YAML      options file applied on top of the preset (may repeat)\n"
    "  --obs-mode MODE    state | pixels (default: pixels when the dataset has only images)\n"
    "  --steps N          training steps (overrides trainer.steps)\n"
    "  --batch N          batch size (overrides trainer.batch_size)\n"
    "  --device DEV       cpu | cuda | cuda:N (default cpu)\n"
    "  --seed S           random seed (default 0)\n"
    "  --eval-every N     validation period in steps (0: never)\n"
    "  --checkpoint-every N  checkpoint period in steps (0: only at the end)\n"
    "  --log-every N      progress / metrics period in steps\n"
    "  --time-limit S     stop after S seconds of wall time (then the final evaluation,\n"
    "                     checkpoint and export); 0: none\n"
    "  --resume           continue from DIR/checkpoint.ckpt with its options\n"
    "  --print-options    print the resolved options as YAML and exit\n"
    "  --threads N        torch CPU threads (default: torch's choice; 1 is often fastest\n"
    "                     on shared cores)\n"
    "  --quiet            no progress output\n"
    "  --help             this text\n";

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

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

}  // namespace

int RunTrainCli(int argc, char** argv, const TrainCliExtensions& ext) {
  std::string data_path, val_path, out_dir, preset = "mspr", scale = "paper", device, obs_mode;
  std::vector<std::string> configs;
  long long time_limit = -1;
  long long threads = 0, steps = -1, batch = -1, seed = -1, eval_every = -1, ckpt_every = -1, log_every = -1;
  bool resume = false, print_options = false, quiet = false;
  std::map<std::string, std::string> extra;
  try {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw UsageError("missing value after " + a);
      return argv[++i];
    };
    auto number = [&]() -> long long {
      const std::string v = value();
      try {
        size_t used = 0;
        const long long n = std::stoll(v, &used);
        if (used != v.size()) throw std::invalid_argument(v);
        return n;
      } catch (const std::exception&) {
        throw UsageError("bad number '" + v + "' for " + a);
      }
    };
    if (a == "--help" || a == "-h") {
      std::cout << Usage(ext);
      return 0;
    } else if (a == "--data") data_path = value();
    else if (a == "--val") val_path = value();
    else if (a == "--out") out_dir = value();
    else if (a == "--preset") preset = value();
    else if (a == "--scale") scale = value();
    else if (a == "--config") configs.push_back(value());
    else if (a == "--obs-mode") obs_mode = value();
    else if (a == "--steps") steps = number();
    else if (a == "--batch") batch = number();
    else if (a == "--device") device = value();
    else if (a == "--seed") seed = number();
    else if (a == "--eval-every") eval_every = number();
    else if (a == "--checkpoint-every") ckpt_every = number();
    else if (a == "--log-every") log_every = number();
    else if (a == "--time-limit") time_limit = number();
    else if (a == "--resume") resume = true;
    else if (a == "--print-options") print_options = true;
    else if (a == "--quiet") quiet = true;
    else if (a == "--threads") threads = number();
    else if (a.rfind("--", 0) == 0 && ext.extra_options.count(a.substr(2))) extra[a.substr(2)] = value();
    else if (a.find(":=") != std::string::npos) continue;  // ROS remappings (rosrun, roslaunch)
    else throw UsageError("unknown argument '" + a + "' (see --help)");
  }
  } catch (const UsageError& e) {
    std::cerr << ext.program << ": " << e.what() << "\n";
    return 2;
  }
  auto usage_error = [&](const std::string& msg) {
    std::cerr << ext.program << ": " << msg << "\n";
    return 2;
  };

  try {
    if (threads > 0) torch::set_num_threads(static_cast<int>(threads));
    MsprOptions options;
    const std::string ckpt = out_dir + "/checkpoint.ckpt";
    if (resume) {
      if (out_dir.empty()) return usage_error("--resume needs --out DIR");
      if (!FileExists(ckpt)) return usage_error("--resume: no checkpoint " + ckpt);
      options = ReadCheckpointOptions(ckpt);
    } else {
      options = MakePreset(preset, scale);
      for (const std::string& c : configs) options = LoadOptionsFile(c, options);
    }
    if (steps >= 0) options.trainer.steps = steps;
    if (batch > 0) options.trainer.batch_size = static_cast<int>(batch);
    if (!device.empty()) options.trainer.device = device;
    if (seed >= 0 && !resume) options.trainer.seed = static_cast<uint64_t>(seed);
    if (eval_every >= 0) options.trainer.eval_every = static_cast<int>(eval_every);
    if (ckpt_every >= 0) options.trainer.checkpoint_every = static_cast<int>(ckpt_every);
    if (log_every > 0) options.trainer.log_every = static_cast<int>(log_every);
    if (time_limit >= 0) options.trainer.time_limit_s = static_cast<double>(time_limit);
    if (!obs_mode.empty()) options.network.obs_mode = obs_mode;
    if (print_options && data_path.empty()) {
      std::cout << OptionsToYaml(options);
      return 0;
    }
    if (data_path.empty())
      return usage_error(std::string("--data FILE is required (see --help)") +
                         (resume ? "; with --resume too: checkpoints do not hold the dataset" : ""));
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
    if (resume) {
      trainer.LoadCheckpoint(ckpt);
      std::cerr << ext.program << ": resumed " << ckpt << " at step " << trainer.step() << "\n";
    }
    {
      // The resolved options, for the record.
      std::string cmd = "mkdir -p '" + out_dir + "'";
      if (std::system(cmd.c_str()) != 0) throw std::runtime_error("cannot create " + out_dir);
      std::FILE* f = std::fopen((out_dir + "/options.yaml").c_str(), "w");
      if (f) {
        const std::string y = OptionsToYaml(trainer.options());
        std::fwrite(y.data(), 1, y.size(), f);
        std::fclose(f);
      }
    }

    std::shared_ptr<const Dataset> val;
    if (!val_path.empty())
      val = load(val_path, true);
    else if (ext.default_validation)
      val = ext.default_validation(data_path, trainer.options());
    if (val)
      std::cerr << ext.program << ": validation: " << val->size() << " steps, " << val->num_trajectories()
                << " trajectories\n";
    Evaluator sim_eval = ext.make_evaluator ? ext.make_evaluator(trainer, extra, out_dir) : Evaluator();
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
    trainer.Train(loop, evaluator);
    std::cerr << ext.program << ": done at step " << trainer.step() << "; wrote " << out_dir
              << "/checkpoint.ckpt and " << out_dir << "/policy.pt\n";
  } catch (const std::exception& e) {
    std::cerr << ext.program << ": error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

}  // namespace core
}  // namespace msspr
