// The training loop: steps, progress, metrics.csv and eval.csv, periodic
// evaluation, checkpoints and policy exports, time limits and stop requests.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "msspr_core/progress.h"
#include "msspr_core/trainer.h"
#include "trainer_internal.h"

namespace msspr {
namespace core {
using namespace trainer_internal;

namespace {

void MakeDirs(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw std::runtime_error(dir + ": cannot create directory: " + ec.message());
}

// Losses read back on a logged step; the representation terms count only when
// a representation update ran in that step (they are NaN by design otherwise).
void CheckFiniteLosses(const LossInfo& info, bool repr_updated, int64_t step) {
  std::string bad;
  for (const auto& [name, v] : info.Named()) {
    const bool repr_term = name != "critic" && name != "q" && name != "actor" && name != "bc";
    if (!std::isfinite(v) && (repr_updated || !repr_term))
      bad += " " + name + "=" + std::to_string(v);
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
  const LossInfo names = EmptyLossInfo();
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
    const bool repr_updated = agent_ || ReprUpdateDue(options_.representation.updates_per_step);
    const LossInfo info = Step(logged || (!agent_ && std::isnan(last.repr)));
    if (logged) CheckFiniteLosses(info, repr_updated, step_);
    // Keep the last representation losses on steps without a representation update.
    LossInfo merged = info;
    if (!agent_ && std::isnan(info.repr)) {
      merged.repr = last.repr;
      merged.dyn = last.dyn;
      merged.rew = last.rew;
      merged.inv = last.inv;
      merged.goal_dyn = last.goal_dyn;
      merged.goal_act = last.goal_act;
    }
    last = merged;
    if (t.log_every > 0 && (step_ % t.log_every == 0 || step_ == total)) {
      if (!quiet) {
        if (agent_) {
          // The agent's first four values (its main losses).
          auto named = merged.Named();
          if (named.size() > 4) named.resize(4);
          bar.Update(step_, named);
        } else {
          bar.Update(step_, {{"critic", merged.critic},
                             {"actor", merged.actor},
                             {"repr", merged.repr},
                             {"q", merged.q_mean}});
        }
      }
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
      if (ema_repr_)
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
    if (writer && ema_repr_) ExportPolicy(loop.out_dir + "/policy_raw.pt", true);
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
