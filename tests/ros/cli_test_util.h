// Shared helper of the tests that run a command line tool to its end: its exit
// status and its output (stdout and stderr), with no master reachable.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace msspr::test {

struct ToolOutput {
  int status = -1;   // exit status, or -1 when it could not start or was killed by a signal
  std::string text;  // stdout and stderr
};

// Runs CMD under `timeout TIMEOUT_S`. ROS_MASTER_URI points nowhere: a tool that
// tried to reach a master would fail, not hang.
inline ToolOutput RunTool(const std::string& cmd, int timeout_s) {
  ToolOutput r;
  const std::string line = "ROS_MASTER_URI=http://127.0.0.1:1 timeout " +
                           std::to_string(timeout_s) + " " + cmd + " 2>&1";
  FILE* p = popen(line.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.text.append(buf, n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

}  // namespace msspr::test
