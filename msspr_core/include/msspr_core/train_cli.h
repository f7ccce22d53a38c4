// The msspr_train command line as a library function, so that the ROS layer's
// msspr_train (which also reads rosbags and evaluates in a simulator) and the
// core's standalone one share every flag and behaviour.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <set>
#include <string>

#include "msspr_core/dataset.h"
#include "msspr_core/options.h"
#include "msspr_core/trainer.h"

namespace msspr {
namespace core {

struct TrainCliExtensions {
  std::string program = "msspr_train";
  std::string data_help = "FILE.npz (observations, actions, terminals)";
  // Extra "--key value" options and their help lines.
  std::set<std::string> extra_options;
  std::string extra_usage;
  // Loads a dataset the core cannot read itself; `validation` selects the
  // validation split where the format has one. Returns nullptr to let the core
  // load the path as .npz. May throw with a message naming the file.
  std::function<std::shared_ptr<const Dataset>(const std::string& path, bool validation,
                                               const MsprOptions& options)>
      load_dataset;
  // When no --val is given: the validation data to use for this training data
  // (e.g. the "val" split of the same bags), or nullptr.
  std::function<std::shared_ptr<const Dataset>(const std::string& data_path,
                                               const MsprOptions& options)>
      default_validation;
  // An extra evaluator (e.g. success rates in a simulator), run with the core's
  // validation losses every trainer.eval_every steps; nullptr for none.
  std::function<Evaluator(Trainer& trainer, const std::map<std::string, std::string>& extra,
                          const std::string& out_dir)>
      make_evaluator;
  // Called with out_dir after each evaluation is logged and at the end (e.g.
  // to draw out_dir/learning_curve.png); nullptr for nothing.
  std::function<void(const std::string& out_dir)> after_eval;
};

// Parses argv, trains, writes out_dir/{metrics.csv, eval.csv, checkpoint.ckpt,
// policy.pt, options.yaml}. Returns the process exit code (0 ok, 1 error, 2
// usage), printing errors to stderr.
int RunTrainCli(int argc, char** argv, const TrainCliExtensions& ext = {});

}  // namespace core
}  // namespace msspr
