// msspr_train (standalone core build): trains Ms.PR offline from OGBench .npz
// files. The catkin build's msspr_train adds ROS bags and in-simulator
// evaluation on top of the same command line (msspr_policy_node/training/train_main.cc).
#include "msspr_core/process_env.h"
#include "msspr_core/train_cli.h"

int main(int argc, char** argv) {
  msspr::core::ReexecWithToolEnvironment(argv);
  return msspr::core::RunTrainCli(argc, argv);
}
