// Every command line tool answers bad flags and values with a usage error:
// exit status 2 and a message naming the flag, never std::terminate. No master
// is needed: the flags are checked before any ROS traffic.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli_test_util.h"

namespace {

using Result = msspr::test::ToolOutput;

Result Run(const std::string& exe, const std::string& args) {
  return msspr::test::RunTool(exe + " " + args, 60);
}

void ExpectUsageError(const std::string& exe, const std::string& args, const std::string& says) {
  const Result r = Run(exe, args);
  EXPECT_EQ(r.status, 2) << exe << " " << args << "\n" << r.text;
  EXPECT_NE(r.text.find(says), std::string::npos) << exe << " " << args << "\n" << r.text;
  EXPECT_EQ(r.text.find("terminate"), std::string::npos) << r.text;
}

// (arguments, what the message must say) for one tool.
void ExpectUsageErrors(const std::string& exe,
                       const std::vector<std::pair<std::string, std::string>>& cases) {
  for (const auto& [args, says] : cases) ExpectUsageError(exe, args, says);
}

TEST(Cli, EvalRejectsBadFlags) {
  ExpectUsageErrors(MSSPR_EVAL_EXE,
                    {{"--maze nowhere", "--maze 'nowhere' is not one of: arena, giant"},
                     {"--episodes ten", "--episodes expects an integer, got 'ten'"},
                     {"--episodes 0", "--episodes 0 is out of range"},
                     {"--tasks 1,9", "--tasks 9 is out of range"},
                     {"--tasks 1,,2", "--tasks expects an integer"},
                     {"--step-timeout nan", "--step-timeout expects a finite number"},
                     {"--seed -4", "--seed -4 is out of range"},
                     {"--frobnicate 3", "unknown option --frobnicate"},
                     {"--tasks-file /nonexistent.yaml", "/nonexistent.yaml"},
                     {"--sims 0", "--sims 0 is out of range"},
                     {"--sims two", "--sims expects an integer, got 'two'"},
                     {"--sims 2 --sim-ns 9sim", "namespace '9sim0', not a valid ROS name"},
                     {"--wait -1", "--wait -1 is out of range"}});
}

TEST(Cli, CollectRejectsBadFlags) {
  ExpectUsageErrors(MSSPR_COLLECT_EXE,
                    {{"", "--out FILE.bag is required"},
                     {"--out /tmp/x.bag --maze nowhere", "--maze 'nowhere' is not one of"},
                     {"--out /tmp/x.bag --env pointmaze-large --maze medium",
                      "--env pointmaze-large and --maze medium name two mazes"},
                     {"--out /tmp/x.bag --env pointmaze-nowhere",
                      "--env 'pointmaze-nowhere' is not one of: pointmaze, pointmaze-"},
                     {"--out /tmp/x.bag --kind wander", "--kind 'wander' is not one of"},
                     {"--out /tmp/x.bag --episodes -3", "--episodes -3 is out of range"},
                     {"--out /tmp/x.bag --length 1", "--length 1 is out of range"},
                     {"--out /tmp/x.bag --noise inf", "--noise expects a finite number"},
                     {"--out", "--out needs a value"}});
}

TEST(Cli, BagInfoRejectsBadFlags) {
  // An unreadable bag is exit 2 too (README: 0 whole, 1 inconsistent, 2 unreadable).
  ExpectUsageErrors(MSSPR_BAG_INFO_EXE,
                    {{"", "usage: msspr_bag_info"},
                     {"a.bag --max-problems many", "--max-problems expects an integer"},
                     {"/nonexistent.bag", "/nonexistent.bag"}});
}

TEST(Cli, TrainRejectsBadFlags) {
  ExpectUsageErrors(
      MSSPR_TRAIN_EXE,
      {{"--steps many --data x.npz --out /tmp/y", "--steps expects an integer, got 'many'"},
       {"--batch 0 --data x.npz --out /tmp/y", "--batch 0 is out of range"},
       {"--threads -1 --data x.npz --out /tmp/y", "--threads -1 is out of range"},
       {"--precision fp16 --data x.npz --out /tmp/y",
        "--precision must be fp32, bf16 or auto, got 'fp16'"},
       {"--bogus", "unknown argument '--bogus'"},
       {"--seed", "missing value after --seed"},
       {"--resume", "--resume needs --out DIR"},
       {"--resume --out /nonexistent/run", "holds no run"}});
  EXPECT_FALSE(std::filesystem::exists("/nonexistent/run")) << "a refused --resume creates nothing";
}

// --observation-mode, and --obs-mode, its old spelling, which still works with a warning.
TEST(Cli, TrainReadsTheObservationModeUnderBothSpellings) {
  const Result now = msspr::test::RunTool(
      std::string(MSSPR_TRAIN_EXE) + " --print-options --observation-mode pixels", 60);
  EXPECT_EQ(now.status, 0) << now.text;
  EXPECT_NE(now.text.find("obs_mode: pixels"), std::string::npos) << now.text;
  EXPECT_EQ(now.text.find("deprecated"), std::string::npos) << now.text;
  const Result old =
      msspr::test::RunTool(std::string(MSSPR_TRAIN_EXE) + " --print-options --obs-mode pixels", 60);
  EXPECT_EQ(old.status, 0) << old.text;
  EXPECT_NE(old.text.find("obs_mode: pixels"), std::string::npos) << old.text;
  EXPECT_NE(old.text.find("--obs-mode is deprecated; use --observation-mode"), std::string::npos)
      << old.text;
}

TEST(Cli, ValueMapAndMakeTasksRejectBadFlags) {
  ExpectUsageErrors(
      MSSPR_VALUE_MAP_EXE,
      {{"--maze medium", "--policy is required"},
       {"--policy p.pt --goal 1", "--goal expects X,Y"},
       {"--policy p.pt --goal -4,0", "is inside a wall"},
       {"--policy p.pt --goal-task 6", "--goal-task 6 is out of range"},
       {"--policy p.pt --goal 0,0 --goal-task 1", "not both"},
       {"--policy p.pt --rollouts 0", "--rollouts 0 is out of range"},
       {"--policy p.pt --env cube-single --goal-task 1",
        "--goal-task is for the point maze, not --env cube-single"},
       {"--policy p.pt --shifts 0,4", "--shifts is for --env cube-single"},
       {"--policy p.pt --env cube-single --shifts 0,-4", "--shifts -4 is out of range"},
       {"--policy p.pt --env cube-double", "--env 'cube-double' is not one of"}});
  ExpectUsageErrors(MSSPR_MAKE_TASKS_EXE, {{"--maze nowhere", "--maze 'nowhere' is not one of"},
                                           {"--n 0", "--n 0 is out of range"},
                                           {"--noise 3", "--noise 3 is out of range"}});
}

// msspr_value_map --env cube-single on the shipped cube checkpoint: its table and JSON; a
// trained critic values a goal whose cube sits 8 cm off below one it sits on (the arm alike).
TEST(Cli, ValueMapCubeGoalShiftsWritesTheTableAndJson) {
  const std::string dir = ::testing::TempDir() + "/value_goal_shifts_cli";
  const Result r =
      msspr::test::RunTool(std::string(MSSPR_VALUE_MAP_EXE) +
                               " --env cube-single --policy " MSSPR_SOURCE_DIR
                               "/msspr_policy_node/checkpoints/cube-single-state.pt"
                               " --shifts 0,8 --pairs 2 --directions 2 --threads 1 --out " +
                               dir,
                           120);
  ASSERT_EQ(r.status, 0) << r.text;
  EXPECT_NE(r.text.find("(20 values a shift; gamma 0.99;"), std::string::npos) << r.text;
  std::ifstream f(dir + "/value_goal_shifts.json");
  const std::string js((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  for (const char* key : {"\"shifts_cm\": [0.000000, 8.000000]", "\"same_arm\": {\"mean_value\": [",
                          "\"other_arm\": {\"mean_value\": [", "\"samples_per_shift\": 20"})
    EXPECT_NE(js.find(key), std::string::npos) << key << " in " << js;
  const size_t at = js.find("\"same_arm\": {\"mean_value\": [") + 29;
  const double v0 = std::stod(js.substr(at)), v8 = std::stod(js.substr(js.find(", ", at) + 2));
  EXPECT_GT(v0, -5.0) << js;
  EXPECT_LT(v8, v0 - 20.0) << js;
}

TEST(Cli, EvalInprocessRejectsBadFlagsAndWritesResults) {
  ExpectUsageErrors(MSSPR_EVAL_INPROCESS_EXE,
                    {{"--episodes 3", "--policy is required"},
                     {"--policy p.pt --tasks 1,6", "--tasks 6 is out of range"},
                     {"--policy p.pt --tasks 1 --tasks-file t.yaml", "not both"},
                     {"--policy p.pt --tasks-file /nonexistent/t.yaml", "/nonexistent/t.yaml"}});
  const std::string out = ::testing::TempDir() + "/eval_inprocess.json";
  std::remove(out.c_str());
  const Result r = ::Run(MSSPR_EVAL_INPROCESS_EXE,
                         std::string("--policy ") + MSSPR_TEST_CHECKPOINT +
                             " --tasks 1,2 --episodes 2 --max-steps 600 --threads 1 --out " + out);
  ASSERT_EQ(r.status, 0) << r.text;
  EXPECT_NE(r.text.find("mean success"), std::string::npos) << r.text;
  FILE* f = std::fopen(out.c_str(), "r");
  ASSERT_NE(f, nullptr) << out;
  std::string js(4096, '\0');
  js.resize(std::fread(js.data(), 1, js.size(), f));
  std::fclose(f);
  EXPECT_NE(js.find("\"task_id\": 2"), std::string::npos) << js;
  EXPECT_NE(js.find("\"episodes_per_task\": 2"), std::string::npos) << js;
}

TEST(Cli, BenchToolsRejectBadFlags) {
  ExpectUsageErrors(MSSPR_BENCH_CORE_EXE,
                    {{"--out x.json --threads lots", "--threads expects an integer"},
                     {"--quick", "--out FILE.json is required"}});
  ExpectUsageErrors(MSSPR_BENCH_ENV_EXE, {{"--maze nowhere", "--maze 'nowhere' is not one of"}});
  ExpectUsageErrors(MSSPR_BENCH_LOCKSTEP_EXE, {{"--steps x", "--steps expects an integer"}});
  ExpectUsageErrors(MSSPR_BENCH_POLICY_EXE,
                    {{"--samples 0", "--samples 0 is out of range"},
                     {"--rates 50,fast", "--rates expects a finite number"}});
}

// The "Core: NAME" lines OpenBLAS prints at each load with OPENBLAS_VERBOSE=2:
// one per process, so a re-executed tool prints two.
std::vector<std::string> OpenBlasCores(const std::string& text) {
  std::vector<std::string> cores;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("Core: ", 0) == 0) cores.push_back(line.substr(6));
  return cores;
}

// OpenBLAS 0.3.21 falls back to its generic Prescott kernels on Intel models it
// does not know (4-5x slower fp32 products); the tools then re-execute with the
// CPU's own kernels, and leave a choice the user made alone.
TEST(Cli, ToolsRunTheCpusOpenBlasKernelsNotTheGenericFallback) {
  std::ifstream f("/proc/cpuinfo");
  std::stringstream cpuinfo;
  cpuinfo << f.rdbuf();
  const bool avx2 = cpuinfo.str().find(" avx2") != std::string::npos;
  const std::string tool = std::string(MSSPR_BENCH_CORE_EXE) + " --help";
  const Result r =
      ::Run("env -u OPENBLAS_CORETYPE OMP_WAIT_POLICY=PASSIVE OPENBLAS_VERBOSE=2", tool);
  ASSERT_EQ(r.status, 0) << r.text;
  const std::vector<std::string> cores = OpenBlasCores(r.text);
  ASSERT_FALSE(cores.empty()) << "no OpenBLAS loaded?\n" << r.text;
  if (cores.front() == "Prescott" && avx2) {
    ASSERT_EQ(cores.size(), 2u) << r.text;
    EXPECT_NE(cores.back(), "Prescott") << r.text;
    EXPECT_NE(r.text.find("[msspr] OpenBLAS picked its generic Prescott kernels"),
              std::string::npos)
        << r.text;
  } else {
    EXPECT_EQ(cores.size(), 1u) << "re-executed with nothing to change\n" << r.text;
  }
  const Result chosen =
      ::Run("env OPENBLAS_CORETYPE=Haswell OMP_WAIT_POLICY=PASSIVE OPENBLAS_VERBOSE=2", tool);
  EXPECT_EQ(OpenBlasCores(chosen.text), std::vector<std::string>{"Haswell"}) << chosen.text;
}

// msspr_train --print-options (msspr_compare's call for every run of a grid) only prints the
// resolved options: it runs once, never re-executed for the OpenMP and OpenBLAS settings.
TEST(Cli, TrainPrintOptionsRunsOnceWithoutReexecuting) {
  const Result r = ::Run("env -u OPENBLAS_CORETYPE -u OMP_WAIT_POLICY OPENBLAS_VERBOSE=2",
                         std::string(MSSPR_TRAIN_EXE) + " --print-options");
  ASSERT_EQ(r.status, 0) << r.text;
  EXPECT_EQ(OpenBlasCores(r.text).size(), 1u) << "re-executed?\n" << r.text;
  EXPECT_NE(r.text.find("precision: "), std::string::npos) << r.text;
}

// The remaining tools: --help prints the usage and exits 0; an unknown flag and a bad or
// missing value exit 2 naming them.
TEST(Cli, TheOtherToolsAnswerHelpAndRejectBadFlags) {
  const std::vector<std::pair<std::string, std::string>> tools = {
      {MSSPR_AVERAGE_POLICIES_EXE, "msspr_average_policies"},
      {MSSPR_BENCH_CUBE_EXE, "msspr_bench_cube"},
      {MSSPR_COLLECT_NPZ_EXE, "msspr_collect_npz"},
      {MSSPR_EVAL_ANT_EXPERT_EXE, "msspr_eval_ant_expert"},
      {MSSPR_EVAL_ORACLE_EXE, "msspr_eval_oracle"},
      {MSSPR_PROBE_LATENTS_EXE, "msspr_probe_latents"},
      {MSSPR_PROFILE_STEP_EXE, "msspr_profile_step"},
      {MSSPR_TRAIN_EXPERT_EXE, "msspr_train_expert"}};
  for (const auto& [exe, name] : tools) {
    const Result help = ::Run(exe, "--help");
    EXPECT_EQ(help.status, 0) << name << "\n" << help.text;
    EXPECT_NE(help.text.find("usage: " + name), std::string::npos) << help.text;
    ExpectUsageError(exe, "--bogus", "unknown option --bogus");
  }
  ExpectUsageError(MSSPR_AVERAGE_POLICIES_EXE, "a.pt", "--out OUT.pt is required");
  ExpectUsageError(MSSPR_BENCH_CUBE_EXE, "", "--urdf is required");
  ExpectUsageError(MSSPR_COLLECT_NPZ_EXE, "--out /tmp/x.npz --episodes many",
                   "--episodes expects an integer, got 'many'");
  ExpectUsageError(MSSPR_EVAL_ANT_EXPERT_EXE, "--episodes 0", "--episodes 0 is out of range");
  ExpectUsageError(MSSPR_EVAL_ORACLE_EXE, "", "--env is required");
  ExpectUsageError(MSSPR_EVAL_ORACLE_EXE, "--env cube-single",
                   "--env 'cube-single' is not one of: cube-double, puzzle-3x3, puzzle-4x4, scene");
  ExpectUsageError(MSSPR_PROBE_LATENTS_EXE, "", "--policy and --data are required");
  ExpectUsageError(MSSPR_PROFILE_STEP_EXE, "--steps 0", "--steps 0 is out of range");
  const std::string out = "/tmp/msspr_cli_train_expert_refused";
  ExpectUsageError(MSSPR_TRAIN_EXPERT_EXE, "--out " + out + " --steps many",
                   "--steps expects an integer, got 'many'");
  EXPECT_FALSE(std::filesystem::exists(out)) << "a refused command line creates nothing";
}

}  // namespace
