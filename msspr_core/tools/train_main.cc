// msspr_train: trains Ms.PR offline from an OGBench .npz (or the core's
// .npz dataset file) and writes metrics, checkpoints and a policy export.
#include <sys/stat.h>

#include <cstdlib>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "msspr_core/checkpoint.h"
#include "msspr_core/npz.h"
#include "msspr_core/options.h"
#include "msspr_core/trainer.h"

namespace {

const char kUsage[] =
    "usage: msspr_train --data FILE.npz --out DIR [options]\n"
    "\n"
    "Trains Ms.PR (multi-scale predictive representations) offline.\n"
    "\n"
    "  --data FILE        training dataset (.npz: observations, actions, terminals)\n"
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
    "  --resume           continue from DIR/checkpoint.ckpt with its options\n"
    "  --print-options    print the resolved options as YAML and exit\n"
    "  --quiet            no progress output\n"
    "  --help             this text\n";

[[noreturn]] void Die(const std::string& msg) {
  std::cerr << "msspr_train: " << msg << "\n";
  std::exit(2);
}

bool FileExists(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace msspr::core;
  std::string data_path, val_path, out_dir, preset = "mspr", scale = "paper", device, obs_mode;
  std::vector<std::string> configs;
  long long steps = -1, batch = -1, seed = -1, eval_every = -1, ckpt_every = -1, log_every = -1;
  bool resume = false, print_options = false, quiet = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) Die("missing value after " + a);
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
        Die("bad number '" + v + "' for " + a);
      }
    };
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
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
    else if (a == "--resume") resume = true;
    else if (a == "--print-options") print_options = true;
    else if (a == "--quiet") quiet = true;
    else Die("unknown argument '" + a + "' (see --help)");
  }

  try {
    MsprOptions options;
    const std::string ckpt = out_dir + "/checkpoint.ckpt";
    if (resume) {
      if (out_dir.empty()) Die("--resume needs --out DIR");
      if (!FileExists(ckpt)) Die("--resume: no checkpoint " + ckpt);
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
    if (!obs_mode.empty()) options.network.obs_mode = obs_mode;
    if (print_options && data_path.empty()) {
      std::cout << OptionsToYaml(options);
      return 0;
    }
    if (data_path.empty()) Die("--data FILE is required (see --help)");
    if (out_dir.empty() && !print_options) Die("--out DIR is required (see --help)");

    auto data = std::make_shared<const Dataset>(LoadNpzDataset(data_path));
    std::cerr << "msspr_train: " << data_path << ": " << data->size() << " steps, "
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
      std::cerr << "msspr_train: resumed " << ckpt << " at step " << trainer.step() << "\n";
    }
    {
      // The resolved options, for the record.
      std::string cmd = "mkdir -p '" + out_dir + "'";
      if (std::system(cmd.c_str()) != 0) Die("cannot create " + out_dir);
      std::FILE* f = std::fopen((out_dir + "/options.yaml").c_str(), "w");
      if (f) {
        const std::string y = OptionsToYaml(trainer.options());
        std::fwrite(y.data(), 1, y.size(), f);
        std::fclose(f);
      }
    }

    Evaluator evaluator;
    std::shared_ptr<const Dataset> val;
    if (!val_path.empty()) {
      val = std::make_shared<const Dataset>(LoadNpzDataset(val_path));
      // Validation losses on the same fixed batches each time.
      const int b = std::min(trainer.options().trainer.batch_size, 1024);
      evaluator = [&trainer, val, b](Policy&, int64_t) -> EvalResult {
        EvalResult r;
        for (const auto& kv : trainer.ValidationLosses(*val, b, 12345).Named()) {
          r.emplace_back("val_" + kv.first, kv.second);
        }
        return r;
      };
    }
    TrainLoopOptions loop;
    loop.out_dir = out_dir;
    loop.quiet = quiet;
    trainer.Train(loop, evaluator);
    std::cerr << "msspr_train: done at step " << trainer.step() << "; wrote " << out_dir
              << "/checkpoint.ckpt and " << out_dir << "/policy.pt\n";
  } catch (const std::exception& e) {
    std::cerr << "msspr_train: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
