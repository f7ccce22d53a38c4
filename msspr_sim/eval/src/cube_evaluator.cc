#include "msspr_eval/cube_evaluator.h"

#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "msspr_core/frame_stack.h"
#include "msspr_core/policy.h"
#include "msspr_eval/batched_episodes.h"
#include "msspr_sim/cube_env.h"
#include "msspr_sim/cube_oracle.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/package_files.h"
#include "msspr_sim/random_util.h"

namespace msspr::agent {

CubeEvalResult EvaluateOnCube(core::Policy& policy, const CubeEvalOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  constexpr int kObs = sim::CubeEnv::kObservationSize, kAct = sim::CubeEnv::kActionSize;
  const bool pixels = policy.pixels();
  const auto& net = policy.options().network;
  if (pixels && (net.image_width != net.image_height || net.image_channels != 3))
    throw std::invalid_argument("EvaluateOnCube: pixels policies need square RGB images");
  if (!pixels && policy.obs_dim() != kObs)
    throw std::invalid_argument("EvaluateOnCube: the policy expects " +
                                std::to_string(policy.obs_dim()) +
                                "-dimensional observations, cube-single gives 28");
  if (policy.action_dim() != kAct)
    throw std::invalid_argument("EvaluateOnCube: the policy has " +
                                std::to_string(policy.action_dim()) +
                                " action dimensions, cube-single takes 5");
  const int n_tasks = static_cast<int>(sim::CubeSingleTasks().size());
  for (int t : options.tasks)
    if (t < 1 || t > n_tasks)
      throw std::invalid_argument("EvaluateOnCube: task " + std::to_string(t) +
                                  " is not a task of cube-single (1 to " + std::to_string(n_tasks) +
                                  ")");
  if (options.episodes < 1 || options.max_steps < 1 || options.episodes_at_once < 1)
    throw std::invalid_argument(
        "EvaluateOnCube: episodes, max_steps and episodes_at_once must be at least 1");

  sim::CubeEnvOptions eo;
  eo.urdf_path = options.urdf_path.empty() ? sim::DefaultArmUrdf() : options.urdf_path;
  eo.max_episode_steps = options.max_steps;
  eo.scene.pixel_style = pixels;  // the look of the sim's pixels mode (no physics change)
  // Pixels: one rendering env draws every episode's frames (RenderStateOf) and,
  // reset to the same task and seed, its goal image, as the sim node renders them.
  const int size = net.image_height;
  std::unique_ptr<sim::CubeEnv> renderer;
  std::optional<core::FrameStacker> stacker;
  if (pixels) {
    sim::CubeEnvOptions ro = eo;
    ro.enable_rendering = true;
    ro.image_size = size;
    renderer = std::make_unique<sim::CubeEnv>(ro);
    stacker.emplace(size, size, 3, std::max(1, net.frame_stack));
  }
  struct Slot {
    std::unique_ptr<sim::CubeEnv> env;
    sim::CubeEnv::Observation obs;
    bool done = false, success = false;
    int steps = 0;
    sim::CubeEpisodeTracker cube;              // the cube's rise and where it ends
    std::optional<core::FrameStacker> frames;  // the episode's last frames (pixels)
    std::vector<uint8_t> goal_frames;          // the goal's image, stacked (pixels)
  };
  std::vector<uint8_t> frame(pixels ? stacker->frame_bytes() : 0);
  const auto inputs = [&](const std::vector<Slot*>& active, torch::Tensor* obs,
                          torch::Tensor* goal) {
    if (pixels) return StackedImageInputs(active, *stacker, size, obs, goal);
    StateInputs(active, kObs, obs, goal);
  };
  std::vector<EpisodeResult> episodes;
  RunEpisodesInGroups<Slot>(
      policy, options.tasks, options.episodes, options.episodes_at_once, options.max_steps,
      [&](int t, int e) {
        Slot s;
        s.env = std::make_unique<sim::CubeEnv>(eo);
        const uint64_t seed = sim::EvalEpisodeSeed(options.seed, t, e);
        s.obs = s.env->ResetToTask(t, seed);
        if (pixels) {
          renderer->ResetToTask(t, seed);
          if (renderer->goal_observation() != s.env->goal_observation())
            throw std::runtime_error("EvaluateOnCube: the rendering env's goal of task " +
                                     std::to_string(t) + " differs from the episode's");
          s.goal_frames = stacker->Repeat(renderer->goal_image().data());
          renderer->RenderStateOf(*s.env, frame.data());
          s.frames.emplace(*stacker);
          s.frames->Reset(frame.data());
        }
        s.success = s.done = s.env->Success();
        s.cube.Start(s.obs.data(), s.env->goal_observation().data());
        return s;
      },
      inputs,
      [&](Slot& s, const auto& a) {
        sim::CubeEnv::Action u;
        for (int k = 0; k < kAct; ++k) u[k] = std::clamp<double>(a[k], -1.0, 1.0);
        s.success = s.env->Step(u);
        s.obs = s.env->GetObservation();
        s.cube.Observe(s.obs.data());
        ++s.steps;
        s.done = s.success || s.steps >= options.max_steps;
        if (pixels && !s.done) {
          renderer->RenderStateOf(*s.env, frame.data());
          s.frames->Push(frame.data());
        }
      },
      [&](const Slot& s) {
        episodes.push_back({s.success, s.steps, std::vector<double>(s.obs.begin(), s.obs.end())});
        episodes.back().cube = s.cube.Finish(s.success);
      });
  CubeEvalResult r = SummarizeTaskEpisodes(options.tasks, options.episodes, std::move(episodes));
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

std::vector<sim::CubeOutcome> CubeOutcomes(const CubeEvalResult& result) {
  std::vector<sim::CubeOutcome> out;
  for (const EpisodeResult& e : result.episodes)
    if (e.cube) out.push_back(*e.cube);
  return out;
}

sim::EvalReport MakeCubeEvalReport(const CubeEvalResult& result, const CubeEvalOptions& options,
                                   const std::string& agent) {
  sim::EvalReport report = MakeTaskReport(result, sim::EnvLabel(sim::EnvId::kCubeSingle), agent,
                                          options.episodes, options.max_steps, options.seed);
  for (auto& t :
       report.tasks) {  // the cube's start and goal xy (m), as msspr_eval --env cube-single
    const auto& ct = sim::CubeSingleTasks()[static_cast<size_t>(t.task_id - 1)];
    t.start = {ct.start.x(), ct.start.y()};
    t.goal = {ct.goal.x(), ct.goal.y()};
  }
  return report;
}

void WriteCubeResultsJson(const CubeEvalResult& result, const CubeEvalOptions& options,
                          const std::string& agent, const std::string& path) {
  sim::WriteTextFile(path, sim::EvalReportJson(MakeCubeEvalReport(result, options, agent)));
}

sim::CubeEnv::Observation CarryOverGoal(sim::CubeEnv& env, int task, uint64_t seed, double height) {
  env.ResetToTask(task, seed);
  const Eigen::Vector3d cube = env.GoalPosition();
  env.SetCube(cube, 0.0);
  env.PlacePinch(cube + Eigen::Vector3d(0, 0, 0.12), 0.0);
  // The oracle's step toward a pinch pose (yaw 0) and grip (0 open, 1 closed).
  const auto toward = [&env](const Eigen::Vector3d& target, double grip) {
    sim::CubePlanSample x;
    x << target, 0.0, grip;
    env.Step(sim::ActionTowardSample(x, env.PinchPosition(), env.PinchYaw(), env.Opening(),
                                     env.options().action_scale));
  };
  for (int t = 0; t < 20; ++t) toward(cube, 0.0);
  for (int t = 0; t < 8; ++t) toward(cube, 1.0);
  for (int t = 0; t < 15; ++t) toward(cube + Eigen::Vector3d(0, 0, height), 1.0);
  return env.GetObservation();
}

CubeGoalShiftResult ProbeCubeGoalShifts(core::Policy& policy, const CubeGoalShiftOptions& options) {
  constexpr int kObs = sim::CubeEnv::kObservationSize, kAct = sim::CubeEnv::kActionSize;
  if (!policy.has_value())
    throw std::invalid_argument("ProbeCubeGoalShifts: the " + policy.agent_name() +
                                " agent has no value to probe");
  if (policy.pixels() || policy.obs_dim() != kObs || policy.action_dim() != kAct)
    throw std::invalid_argument(
        "ProbeCubeGoalShifts: needs a state policy of cube-single (28-D states, 5-D actions); "
        "this one reads " +
        (policy.pixels() ? std::string("pixels") : std::to_string(policy.obs_dim()) + "-D states") +
        " and gives " + std::to_string(policy.action_dim()) + "-D actions");
  if (options.shifts_cm.empty() || options.pairs_per_task < 1 || options.directions < 1)
    throw std::invalid_argument(
        "ProbeCubeGoalShifts: give at least one shift, pair per task and direction");
  for (double d : options.shifts_cm)
    if (!(d >= 0.0 && d <= 100.0))
      throw std::invalid_argument("ProbeCubeGoalShifts: a shift must be 0 to 100 cm, got " +
                                  std::to_string(d));

  sim::CubeEnvOptions eo;
  eo.urdf_path = options.urdf_path.empty() ? sim::DefaultArmUrdf() : options.urdf_path;
  sim::CubeEnv env(eo);
  const int n_tasks = static_cast<int>(sim::CubeSingleTasks().size());
  // Each goal (the goal observation of a reset) with a state of another arm (that of
  // another reset) and a state carrying the cube above it.
  struct Case {
    sim::CubeEnv::Observation goal, other, carrying;
  };
  std::vector<Case> pairs;
  for (int t = 1; t <= n_tasks; ++t)
    for (int j = 0; j < options.pairs_per_task; ++j) {
      const uint64_t base = sim::Mix64(options.seed * 1000003ULL + static_cast<uint64_t>(t)) +
                            3 * static_cast<uint64_t>(j);
      Case c;
      env.ResetToTask(t, base);
      c.other = env.goal_observation();
      env.ResetToTask(t, base + 1);
      c.goal = env.goal_observation();
      c.carrying = CarryOverGoal(env, t, base + 2);
      pairs.push_back(c);
    }

  CubeGoalShiftResult r;
  r.shifts_cm = options.shifts_cm;
  r.gamma = policy.options().agent.gamma;
  r.samples = static_cast<int>(pairs.size()) * options.directions;
  std::vector<Eigen::Vector3d> directions;  // unit vectors in the table's plane
  for (int k = 0; k < options.directions; ++k) {
    const double angle = 2.0 * M_PI * k / options.directions;
    directions.emplace_back(std::cos(angle), std::sin(angle), 0.0);
  }
  // The variants: the state each takes from a case, and where its values go.
  const sim::CubeEnv::Observation Case::*const states[] = {&Case::goal, &Case::other,
                                                           &Case::carrying};
  CubeGoalShiftValues* const outs[] = {&r.same_arm, &r.other_arm, &r.carrying};
  torch::NoGradGuard no_grad;
  for (int variant = 0; variant < 3; ++variant) {
    CubeGoalShiftValues& out = *outs[variant];
    for (double shift : options.shifts_cm) {
      auto obs = torch::empty({r.samples, kObs}, torch::kFloat32);
      auto goal = torch::empty({r.samples, kObs}, torch::kFloat32);
      float* po = obs.data_ptr<float>();
      float* pg = goal.data_ptr<float>();
      for (const Case& c : pairs)
        for (const Eigen::Vector3d& dir : directions) {
          const sim::CubeEnv::Observation& state = c.*states[variant];
          std::copy(state.begin(), state.end(), po);
          std::copy(c.goal.begin(), c.goal.end(), pg);
          sim::ShiftCubeInObservation(pg, dir * (shift / 100.0));
          po += kObs;
          pg += kObs;
        }
      const auto actions = policy.Act(obs, goal);
      const auto v = std::get<0>(policy.Q(obs, actions, goal).min(-1))
                         .to(torch::kCPU, torch::kFloat64)
                         .contiguous();
      if (variant == 2) {
        const auto a = actions.to(torch::kCPU, torch::kFloat64).contiguous();
        const double* pa = a.data_ptr<double>();
        double steer = 0.0;
        for (int i = 0; i < r.samples; ++i) {  // sample i: direction i % directions
          const Eigen::Vector3d& dir = directions[static_cast<size_t>(i % options.directions)];
          const double ax = pa[i * kAct], ay = pa[i * kAct + 1], n = std::hypot(ax, ay);
          steer += n > 0.0 ? (ax * dir.x() + ay * dir.y()) / n : 0.0;
        }
        out.steer.push_back(shift > 0.0 ? steer / r.samples
                                        : std::numeric_limits<double>::quiet_NaN());
      }
      const double* pv = v.data_ptr<double>();
      double sum = 0.0, sq = 0.0;
      for (int i = 0; i < r.samples; ++i) sum += pv[i];
      const double m = sum / r.samples;
      for (int i = 0; i < r.samples; ++i) sq += (pv[i] - m) * (pv[i] - m);
      out.mean.push_back(m);
      out.sd.push_back(r.samples > 1 ? std::sqrt(sq / (r.samples - 1)) : 0.0);
      const double x = 1.0 + (1.0 - r.gamma) * std::min(m, 0.0);
      out.steps.push_back(x > 0.0 ? std::max(0.0, std::log(x) / std::log(r.gamma))
                                  : std::numeric_limits<double>::infinity());
    }
  }
  return r;
}

}  // namespace msspr::agent
