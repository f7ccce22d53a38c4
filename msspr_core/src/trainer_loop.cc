// The training loop: steps, progress, metrics.csv and eval.csv, periodic
// evaluation, checkpoints and policy exports, time limits and stop requests.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "msspr_core/progress.h"
#include "msspr_core/trainer.h"

namespace msspr {
namespace core {

namespace {

void MakeDirs(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw std::runtime_error(dir + ": cannot create directory: " + ec.message());
}

// Losses read back on a logged step, but those the step skipped by design
// (GcAgent::LossesSkippedByNextStep, e.g. Ms.PR's representation terms
// without a representation update).
void CheckFiniteLosses(const LossInfo& info, const std::vector<std::string>& skipped,
                       int64_t step) {
  std::string bad;
  for (const auto& [name, v] : info.Named()) {
    const bool was_skipped = std::find(skipped.begin(), skipped.end(), name) != skipped.end();
    if (!std::isfinite(v) && !was_skipped) bad += " " + name + "=" + std::to_string(v);
  }
  if (!bad.empty())
    throw std::runtime_error("training diverged: non-finite loss at step " + std::to_string(step) +
                             ":" + bad +
                             "; stopped without writing a checkpoint (the last good one is kept)");
}

void NotifyEvalWritten(const TrainLoopOptions& loop) {
  if (!loop.on_eval_written) return;
  try {
    loop.on_eval_written();
  } catch (const std::exception& e) {
    std::cerr << "warning: " << e.what() << " (training goes on)\n";
  }
}

}  // namespace

TrainEnd Trainer::Train(const TrainLoopOptions& loop, const Evaluator& evaluator) {
  const TrainerOptions& t = options_.trainer;
  const int64_t total = t.steps;
  std::unique_ptr<CsvWriter> metrics_csv, eval_csv;
  const LossInfo names = agent_->NoLosses();
  // Data-parallel: rank 0 alone writes, logs and evaluates.
  const bool writer = rank() == 0;
  const bool quiet = loop.quiet || !writer;
  if (!loop.out_dir.empty() && writer) {
    MakeDirs(loop.out_dir);
    // Rows logged after the step this run starts from (a killed run's tail) go.
    TruncateCsvRows(loop.out_dir + "/metrics.csv", step_);
    TruncateCsvRows(loop.out_dir + "/eval.csv", step_);
    std::vector<std::string> cols{"step", "wall_s", "steps_per_s"};
    for (const auto& kv : names.Named()) cols.push_back(kv.first);
    metrics_csv = std::make_unique<CsvWriter>(loop.out_dir + "/metrics.csv", cols);
    eval_csv = std::make_unique<CsvWriter>(loop.out_dir + "/eval.csv",
                                           std::vector<std::string>{"step", "name", "value"});
  }
  ProgressBar bar(step_, total);
  const int64_t first_step = step_;
  const auto start = std::chrono::steady_clock::now();
  auto run_eval = [&]() {
    if (!evaluator || !writer) return;
    Policy policy = MakePolicy();
    const EvalResult res = evaluator(policy, step_);
    std::string line = "eval step " + std::to_string(step_) + ":";
    for (const auto& kv : res) {
      line += " " + kv.first + "=" + std::to_string(kv.second);
      if (eval_csv)
        eval_csv->WriteRow({std::to_string(step_), kv.first, std::to_string(kv.second)});
    }
    if (!quiet) bar.Message(line);
    NotifyEvalWritten(loop);
  };
  LossInfo last;
  auto out_of_time = [&]() {
    const bool mine =
        t.time_limit_s > 0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >=
            t.time_limit_s;
    // Every rank stops at the same step: as soon as one is out of time.
    return (dist_ && t.time_limit_s > 0) ? dist_->Any(mine) : mine;
  };
  auto stop_requested = [&]() {
    if (!loop.stop_requested) return false;
    // Data-parallel ranks poll on the same steps, so that they stop together.
    if (!dist_) return loop.stop_requested->load();
    return step_ % 16 == 0 && dist_->Any(loop.stop_requested->load());
  };
  TrainEnd end = TrainEnd::kSteps;
  while (step_ < total) {
    if (out_of_time()) {
      if (!quiet)
        bar.Message("time limit of " + std::to_string(static_cast<int>(t.time_limit_s)) +
                    " s reached at step " + std::to_string(step_) + ": stopping");
      end = TrainEnd::kTimeLimit;
      break;
    }
    if (stop_requested()) {
      if (!quiet)
        bar.Message("stop requested at step " + std::to_string(step_) +
                    ": writing the checkpoint and the policy (no final evaluation)");
      end = TrainEnd::kStopRequested;
      break;
    }
    // Losses are read back (a device sync) only on logged steps and the
    // representation updates just before them.
    const int64_t next = step_ + 1;
    const bool logged = t.log_every > 0 && (next % t.log_every == 0 || next == total);
    const std::vector<std::string> skipped = agent_->LossesSkippedByNextStep();
    const LossInfo info = Step(logged || agent_->NeedsLosses(last));
    if (logged) CheckFiniteLosses(info, skipped, step_);
    // What the step skipped (e.g. Ms.PR's representation losses) from the last steps.
    const LossInfo merged = agent_->CarryOverLosses(info, last);
    last = merged;
    if (t.log_every > 0 && (step_ % t.log_every == 0 || step_ == total)) {
      if (!quiet) bar.Update(step_, agent_->ProgressValues(merged));
      if (metrics_csv) {
        const double wall =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::vector<double> row{static_cast<double>(step_), wall, bar.steps_per_second()};
        if (quiet) row[2] = wall > 0 ? (step_ - first_step) / wall : 0.0;
        for (const auto& kv : merged.Named()) row.push_back(kv.second);
        metrics_csv->Write(row);
      }
    }
    if (t.eval_every > 0 && step_ % t.eval_every == 0) run_eval();
    if (!loop.out_dir.empty() && t.checkpoint_every > 0 && step_ % t.checkpoint_every == 0) {
      SaveCheckpoint(loop.out_dir + "/checkpoint.ckpt");
    }
    if (writer && !loop.out_dir.empty() && t.export_every > 0 && step_ % t.export_every == 0) {
      ExportPolicy(loop.out_dir + "/policy_step" + std::to_string(step_) + ".pt");
      if (agent_->HasRawPolicy())
        ExportPolicy(loop.out_dir + "/policy_step" + std::to_string(step_) + "_raw.pt", true);
    }
  }
  if (!quiet) bar.Finish();
  if (evaluator && end != TrainEnd::kStopRequested &&
      (t.eval_every <= 0 || step_ % t.eval_every != 0))
    run_eval();
  if (!loop.out_dir.empty()) {
    SaveCheckpoint(loop.out_dir + "/checkpoint.ckpt");
    if (writer) ExportPolicy(loop.out_dir + "/policy.pt");
    if (writer && agent_->HasRawPolicy()) ExportPolicy(loop.out_dir + "/policy_raw.pt", true);
  }
  if (writer) NotifyEvalWritten(loop);
  if (dist_ && step_ > first_step) {
    const Distributed::Stats& st = dist_->stats();
    const double steps = static_cast<double>(step_ - first_step);
    std::fprintf(stderr,
                 "rank %d: all-reduce %.3f ms and %.2f MB per step (%s, %lld collectives)\n",
                 dist_->rank(), 1e3 * st.seconds / steps, st.bytes / steps / 1e6,
                 dist_->backend().c_str(), static_cast<long long>(st.allreduces));
  }
  return end;
}

}  // namespace core
}  // namespace msspr
