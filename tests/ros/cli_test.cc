// Every command line tool answers bad flags and values with a usage error:
// exit status 2 and a message naming the flag, never std::terminate. No master
// is needed: the flags are checked before any ROS traffic.
#include <sys/wait.h>

#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace {

struct Result {
  int status = -1;  // exit status, or -1 when killed by a signal
  std::string output;
};

Result Run(const std::string& exe, const std::string& args) {
  // ROS_MASTER_URI points nowhere: a tool that tried to reach a master would fail, not hang.
  const std::string cmd = "ROS_MASTER_URI=http://127.0.0.1:1 timeout 60 " + exe + " " + args + " 2>&1";
  Result r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

void ExpectUsageError(const std::string& exe, const std::string& args, const std::string& says) {
  const Result r = Run(exe, args);
  EXPECT_EQ(r.status, 2) << exe << " " << args << "\n" << r.output;
  EXPECT_NE(r.output.find(says), std::string::npos) << exe << " " << args << "\n" << r.output;
  EXPECT_EQ(r.output.find("terminate"), std::string::npos) << r.output;
}

TEST(Cli, EvalRejectsBadFlags) {
  const std::string exe = MSSPR_EVAL_EXE;
  ExpectUsageError(exe, "--maze nowhere", "unknown maze name 'nowhere'");
  ExpectUsageError(exe, "--episodes ten", "--episodes expects an integer, got 'ten'");
  ExpectUsageError(exe, "--episodes 0", "--episodes 0 is out of range");
  ExpectUsageError(exe, "--tasks 1,9", "--tasks 9 is out of range");
  ExpectUsageError(exe, "--tasks 1,,2", "--tasks expects an integer");
  ExpectUsageError(exe, "--step-timeout nan", "--step-timeout expects a finite number");
  ExpectUsageError(exe, "--seed -4", "--seed -4 is out of range");
  ExpectUsageError(exe, "--frobnicate 3", "unknown option --frobnicate");
  ExpectUsageError(exe, "--tasks-file /nonexistent.yaml", "/nonexistent.yaml");
}

TEST(Cli, CollectRejectsBadFlags) {
  const std::string exe = MSSPR_COLLECT_EXE;
  ExpectUsageError(exe, "", "--out FILE.bag is required");
  ExpectUsageError(exe, "--out /tmp/x.bag --maze nowhere", "--maze 'nowhere' is not one of");
  ExpectUsageError(exe, "--out /tmp/x.bag --kind wander", "--kind 'wander' is not one of");
  ExpectUsageError(exe, "--out /tmp/x.bag --episodes -3", "--episodes -3 is out of range");
  ExpectUsageError(exe, "--out /tmp/x.bag --length 1", "--length 1 is out of range");
  ExpectUsageError(exe, "--out /tmp/x.bag --noise inf", "--noise expects a finite number");
  ExpectUsageError(exe, "--out", "--out needs a value");
}

TEST(Cli, BagInfoRejectsBadFlags) {
  const std::string exe = MSSPR_BAG_INFO_EXE;
  ExpectUsageError(exe, "", "usage: msspr_bag_info");
  ExpectUsageError(exe, "a.bag --max-problems many", "--max-problems expects an integer");
  // An unreadable bag is exit 2 too (README: 0 whole, 1 inconsistent, 2 unreadable).
  ExpectUsageError(exe, "/nonexistent.bag", "/nonexistent.bag");
}

TEST(Cli, TrainRejectsBadFlags) {
  const std::string exe = MSSPR_TRAIN_EXE;
  ExpectUsageError(exe, "--steps many --data x.npz --out /tmp/y", "--steps expects an integer, got 'many'");
  ExpectUsageError(exe, "--batch 0 --data x.npz --out /tmp/y", "--batch 0 is out of range");
  ExpectUsageError(exe, "--threads -1 --data x.npz --out /tmp/y", "--threads -1 is out of range");
  ExpectUsageError(exe, "--bogus", "unknown argument '--bogus'");
  ExpectUsageError(exe, "--seed", "missing value after --seed");
  ExpectUsageError(exe, "--resume", "--resume needs --out DIR");
  ExpectUsageError(exe, "--resume --out /nonexistent/run", "holds no run");
}

TEST(Cli, BenchToolsRejectBadFlags) {
  ExpectUsageError(MSSPR_BENCH_CORE_EXE, "--out x.json --threads lots", "--threads expects an integer");
  ExpectUsageError(MSSPR_BENCH_CORE_EXE, "--quick", "--out FILE.json is required");
  ExpectUsageError(MSSPR_BENCH_ENV_EXE, "--maze nowhere", "--maze 'nowhere' is not one of");
  ExpectUsageError(MSSPR_BENCH_LOCKSTEP_EXE, "--steps x", "--steps expects an integer");
  ExpectUsageError(MSSPR_BENCH_POLICY_EXE, "--samples 0", "--samples 0 is out of range");
  ExpectUsageError(MSSPR_BENCH_POLICY_EXE, "--rates 50,fast", "--rates expects a finite number");
}

}  // namespace
