// msspr_average_policies: the element-wise mean of the weights of several
// Ms.PR policy exports of one run (msspr_core::AveragePolicies).
#include <iostream>
#include <string>
#include <vector>

#include "msspr_core/checkpoint.h"
#include "msspr_core/cli_args.h"
#include "msspr_core/policy.h"

namespace {

namespace cli = msspr::cli;

const char kUsage[] =
    "usage: msspr_average_policies --out OUT.pt POLICY.pt [POLICY.pt ...]\n"
    "\n"
    "Writes a policy export whose weights (encoders, goal head, actor, critic) are the\n"
    "mean of the given Ms.PR exports or trainer checkpoints, e.g. one run's last few\n"
    "policy_step<N>.pt. The inputs must share their network options; OUT's header holds\n"
    "the first input's options and the largest step. msspr_policy_node, msspr_eval and\n"
    "msspr_eval_inprocess read OUT like any export. To average while training instead:\n"
    "trainer.policy_ema (msspr_core/README.md).\n";

}  // namespace

int main(int argc, char** argv) {
  std::string out;
  std::vector<std::string> inputs;
  try {
    const cli::CliArgs args(argc, argv, {"help"}, {"out"});
    if (args.Has("help")) {
      std::cout << kUsage;
      return 0;
    }
    out = args.Get("out", "");
    if (out.empty()) throw cli::CliError("--out OUT.pt is required");
    inputs = args.positional();
    if (inputs.empty()) throw cli::CliError("no input policies");
    for (const std::string& in : inputs) {
      if (in == out) throw cli::CliError("--out " + out + " is also an input");
    }
  } catch (const cli::CliError& e) {
    std::cerr << "msspr_average_policies: " << e.what() << "\n" << kUsage;
    return 2;
  }
  try {
    msspr::core::AveragePolicies(inputs, out);
    std::cerr << "msspr_average_policies: wrote " << out << ", the mean of " << inputs.size()
              << " policies\n";
  } catch (const std::exception& e) {
    std::cerr << "msspr_average_policies: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
