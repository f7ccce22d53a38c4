#include "msspr_eval/maze_evaluator.h"

#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>

#include "msspr_core/frame_stack.h"
#include "msspr_core/policy.h"
#include "msspr_eval/batched_episodes.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/eval_protocol.h"
#include "msspr_sim/maze_map.h"
#include "msspr_sim/maze_plot.h"
#include "msspr_sim/point_maze.h"

namespace msspr::agent {

namespace {

// One episode to run: an official task's reset (task > 0) or an exact start.
struct EpisodeSpec {
  int task = 0;
  uint64_t seed = 0;
  Eigen::Vector2d start = Eigen::Vector2d::Zero(), goal = Eigen::Vector2d::Zero();
};

struct EpisodeOutcome {
  bool success = false;
  int steps = 0;
  double q0 = 0;  // the critic at the first observation (want_q0)
  Eigen::Vector2d start, goal, end;
  std::vector<Eigen::Vector2d> path;  // keep_paths
};

// One running episode.
struct Slot {
  std::unique_ptr<sim::PointMaze> env;
  bool done = false, success = false;
  int steps = 0;
  std::optional<core::FrameStacker> frames;  // the episode's last frame_stack renders (pixels)
  std::vector<uint8_t> goal_frames;          // the goal's render, stacked (pixels)
  std::vector<Eigen::Vector2d> path;
  Eigen::Vector2d start;
};

// Checks that the policy fits the point maze; throws std::invalid_argument.
void CheckPolicyFitsMaze(const core::Policy& policy, const char* who) {
  if (!policy.pixels() && policy.obs_dim() != sim::PointMaze::kObsDim)
    throw std::invalid_argument(std::string(who) + ": the policy expects " +
                                std::to_string(policy.obs_dim()) +
                                "-dimensional observations, the point maze gives 2");
  if (policy.action_dim() != sim::PointMaze::kActionDim)
    throw std::invalid_argument(std::string(who) + ": the policy has " +
                                std::to_string(policy.action_dim()) +
                                " action dimensions, the point maze takes 2");
  const auto& net = policy.options().network;
  if (policy.pixels() && (net.image_width != net.image_height || net.image_channels != 3))
    throw std::invalid_argument(std::string(who) + ": pixels policies need square RGB images");
}

// Runs the episodes side by side (one policy call per control step);
// pixels policies get renders from one rendering context on this thread.
std::vector<EpisodeOutcome> RunEpisodes(core::Policy& policy, const std::string& maze,
                                        int max_steps, bool keep_paths, bool want_q0,
                                        const std::vector<EpisodeSpec>& specs) {
  const bool pixels = policy.pixels();
  const auto& net = policy.options().network;
  const int stack = std::max(1, net.frame_stack);
  const int size = net.image_height;
  std::unique_ptr<sim::PointMaze> renderer;
  if (pixels) {
    sim::PointMazeOptions ro;
    ro.maze = maze;
    ro.enable_rendering = true;
    ro.image_size = size;
    renderer = std::make_unique<sim::PointMaze>(ro);
  }
  std::optional<core::FrameStacker> stacker;  // the frame-stack layout of training (pixels)
  if (pixels) stacker.emplace(size, size, 3, stack);
  auto render = [&](const Eigen::Vector2d& xy) {
    const auto img = renderer->RenderAt(xy);
    if (img.size() != stacker->frame_bytes())
      throw std::runtime_error("EvaluateOnMaze: a render of " + std::to_string(img.size()) +
                               " bytes, expected " + std::to_string(stacker->frame_bytes()));
    return img;
  };
  auto push_frame = [&](Slot& s, const Eigen::Vector2d& xy, bool fill) {
    const auto img = render(xy);
    if (fill)
      s.frames->Reset(img.data());  // the first frame stands in for the ones before it
    else
      s.frames->Push(img.data());
  };
  sim::PointMazeOptions eo;
  eo.maze = maze;
  eo.max_episode_steps = max_steps;
  std::vector<Slot> slots;
  slots.reserve(specs.size());
  for (const auto& spec : specs) {
    Slot s;
    s.env = std::make_unique<sim::PointMaze>(eo);
    s.start = spec.task > 0 ? s.env->ResetToTask(spec.task, spec.seed)
                            : s.env->Reset(spec.start, spec.goal);
    if (keep_paths) s.path.push_back(s.start);
    if (pixels) {
      s.frames.emplace(*stacker);
      push_frame(s, s.start, /*fill=*/true);
      s.goal_frames = stacker->Repeat(render(s.env->goal()).data());
    }
    s.success = s.env->success();
    s.done = s.success;
    slots.push_back(std::move(s));
  }
  // The policy's inputs for a set of slots.
  auto inputs = [&](const std::vector<Slot*>& batch, torch::Tensor* obs, torch::Tensor* goal) {
    const int64_t B = static_cast<int64_t>(batch.size());
    if (pixels) {
      StackedImageInputs(batch, *stacker, size, obs, goal);
    } else {
      *obs = torch::empty({B, 2}, torch::kFloat32);
      *goal = torch::empty({B, 2}, torch::kFloat32);
      auto o = obs->accessor<float, 2>();
      auto g = goal->accessor<float, 2>();
      for (int64_t b = 0; b < B; ++b) {
        const auto s = batch[b]->env->state(), gl = batch[b]->env->goal();
        o[b][0] = static_cast<float>(s.x());
        o[b][1] = static_cast<float>(s.y());
        g[b][0] = static_cast<float>(gl.x());
        g[b][1] = static_cast<float>(gl.y());
      }
    }
  };

  torch::InferenceMode guard;
  std::vector<EpisodeOutcome> out(specs.size());
  if (want_q0) {  // V(s0, g) = min_k Q_k(s0, pi(s0, g), g), in chunks
    const size_t chunk = pixels ? 256 : 4096;
    for (size_t b0 = 0; b0 < slots.size(); b0 += chunk) {
      std::vector<Slot*> batch;
      for (size_t k = b0; k < std::min(slots.size(), b0 + chunk); ++k) batch.push_back(&slots[k]);
      torch::Tensor obs, goal;
      inputs(batch, &obs, &goal);
      const torch::Tensor q =
          std::get<0>(policy.Q(obs, policy.Act(obs, goal), goal).min(-1)).to(torch::kCPU);
      auto qa = q.accessor<float, 1>();
      for (size_t k = 0; k < batch.size(); ++k) out[b0 + k].q0 = qa[static_cast<int64_t>(k)];
    }
  }
  StepEpisodesBatched(policy, slots, max_steps, inputs, [&](Slot& s, const auto& a) {
    const auto next = s.env->Step(Eigen::Vector2d(a[0], a[1]));
    ++s.steps;
    if (keep_paths) s.path.push_back(next);
    if (s.env->success()) {
      s.success = true;
      s.done = true;
    } else if (s.steps >= max_steps) {
      s.done = true;
    } else if (pixels) {
      push_frame(s, next, /*fill=*/false);
    }
  });
  for (size_t k = 0; k < slots.size(); ++k) {
    out[k].success = slots[k].success;
    out[k].steps = slots[k].steps;
    out[k].start = slots[k].start;
    out[k].goal = slots[k].env->goal();
    out[k].end = slots[k].env->state();
    out[k].path = std::move(slots[k].path);
  }
  return out;
}

}  // namespace

MazeEvalResult EvaluateOnMaze(core::Policy& policy, const MazeEvalOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const sim::MazeMap map = sim::MazeMap::FromName(options.maze);
  const bool custom = !options.custom_tasks.empty();
  if (!custom)
    for (int t : options.tasks)
      if (t < 1 || t > static_cast<int>(map.Tasks().size()))
        throw std::invalid_argument("EvaluateOnMaze: task " + std::to_string(t) +
                                    " is not a task of " + options.maze);
  for (const auto& t : options.custom_tasks)
    for (const auto& p : {t.start, t.goal})
      if (map.IsWall(map.XYToCell(p)))
        throw std::invalid_argument("EvaluateOnMaze: custom task " + std::to_string(t.id) +
                                    ": start or goal is inside a wall of " + options.maze);
  CheckPolicyFitsMaze(policy, "EvaluateOnMaze");

  MazeEvalResult r;
  if (custom) {
    for (const auto& t : options.custom_tasks) r.tasks.push_back(t.id);
  } else {
    r.tasks = options.tasks;
  }
  const size_t nt = r.tasks.size();
  std::vector<EpisodeSpec> specs;
  for (size_t ti = 0; ti < nt; ++ti)
    for (int e = 0; e < options.episodes; ++e) {
      EpisodeSpec spec;
      if (custom) {
        spec.start = options.custom_tasks[ti].start;
        spec.goal = options.custom_tasks[ti].goal;
      } else {
        spec.task = options.tasks[ti];
        spec.seed = sim::EvalEpisodeSeed(options.seed, options.tasks[ti], e);
      }
      specs.push_back(spec);
    }
  auto episodes =
      RunEpisodes(policy, options.maze, options.max_steps, options.keep_paths, false, specs);

  r.success.assign(nt, 0.0);
  r.mean_steps_success.assign(nt, 0.0);
  std::vector<int> ok(nt, 0);
  if (options.keep_paths) {
    r.paths.resize(nt);
    r.start_goal.resize(nt);
    r.episode_success.resize(nt);
  }
  for (size_t k = 0; k < episodes.size(); ++k) {
    auto& ep = episodes[k];
    r.episodes.push_back({ep.success, ep.steps, {ep.end.x(), ep.end.y()}});
    const size_t ti = k / static_cast<size_t>(options.episodes);
    if (ep.success) {
      ++ok[ti];
      r.mean_steps_success[ti] += ep.steps;
    }
    if (options.keep_paths) {
      r.start_goal[ti].emplace_back(ep.start, ep.goal);
      r.paths[ti].push_back(std::move(ep.path));
      r.episode_success[ti].push_back(ep.success);
    }
  }
  for (size_t ti = 0; ti < nt; ++ti) {
    r.success[ti] = options.episodes ? double(ok[ti]) / options.episodes : 0.0;
    if (ok[ti]) r.mean_steps_success[ti] /= ok[ti];
    r.mean_success += r.success[ti] / nt;
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

ValueMapResult ComputeValueMap(core::Policy& policy, const ValueMapOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const sim::MazeMap map = sim::MazeMap::FromName(options.maze);
  CheckPolicyFitsMaze(policy, "ComputeValueMap");
  if (map.IsWall(map.XYToCell(options.goal)))
    throw std::invalid_argument("ComputeValueMap: the goal is inside a wall of " + options.maze);
  if (options.per_cell < 1 || options.rollouts < 1 || options.max_steps < 1)
    throw std::invalid_argument(
        "ComputeValueMap: per_cell, rollouts and max_steps must be at least 1");
  const double half_free = sim::kCellSize / 2 - sim::kAgentRadius;
  if (!(options.start_noise >= 0) || options.start_noise > half_free)
    throw std::invalid_argument("ComputeValueMap: start_noise must be in [0, " +
                                std::to_string(half_free) + "]");
  // Grid points inside each free cell, kept where the sphere (plus noise) fits
  // without touching a wall cell.
  std::vector<Eigen::Vector2d> grid;
  const int n = options.per_cell;
  for (const sim::Cell& c : map.FreeCells()) {
    const Eigen::Vector2d centre = map.CellCenter(c);
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        const Eigen::Vector2d off((b + 0.5) / n - 0.5, (a + 0.5) / n - 0.5);  // in cells
        Eigen::Vector2d p = centre + sim::kCellSize * off;
        // Pull points next to a wall in, so that the agent fits.
        const double lim = half_free - options.start_noise;
        for (int d = 0; d < 2; ++d) {
          const int di = d == 1 ? (off[d] < 0 ? -1 : 1) : 0,
                    dj = d == 0 ? (off[d] < 0 ? -1 : 1) : 0;
          if (map.IsWall({c.i + di, c.j + dj}))
            p[d] = centre[d] + std::clamp(p[d] - centre[d], -lim, lim);
        }
        grid.push_back(p);
      }
  }
  std::mt19937_64 rng(options.seed * 0x9E3779B97F4A7C15ULL + 0x5A17ULL);
  std::uniform_real_distribution<double> noise(-options.start_noise, options.start_noise);
  std::vector<EpisodeSpec> specs;
  for (const auto& p : grid)
    for (int k = 0; k < options.rollouts; ++k) {
      EpisodeSpec spec;
      spec.start = p + Eigen::Vector2d(noise(rng), noise(rng));
      spec.goal = options.goal;
      specs.push_back(spec);
    }
  const auto episodes = RunEpisodes(policy, options.maze, options.max_steps, false, true, specs);

  ValueMapResult r;
  r.gamma = policy.options().agent.gamma;
  r.episodes = static_cast<int>(episodes.size());
  const double g = r.gamma;
  for (size_t i = 0; i < grid.size(); ++i) {
    ValueMapPoint pt;
    pt.xy = grid[i];
    for (int k = 0; k < options.rollouts; ++k) {
      const auto& ep = episodes[i * options.rollouts + k];
      pt.predicted += ep.q0 / options.rollouts;
      pt.true_value += -(1.0 - std::pow(g, ep.steps)) / (1.0 - g) / options.rollouts;
      pt.success += (ep.success ? 1.0 : 0.0) / options.rollouts;
    }
    r.points.push_back(pt);
  }
  const double np = static_cast<double>(r.points.size());
  double mp = 0, mt = 0;
  for (const auto& p : r.points) {
    r.mean_abs_error += std::abs(p.predicted - p.true_value) / np;
    r.bias += (p.predicted - p.true_value) / np;
    r.mean_success += p.success / np;
    mp += p.predicted / np;
    mt += p.true_value / np;
  }
  double sxy = 0, sxx = 0, syy = 0;
  for (const auto& p : r.points) {
    sxy += (p.predicted - mp) * (p.true_value - mt);
    sxx += (p.predicted - mp) * (p.predicted - mp);
    syy += (p.true_value - mt) * (p.true_value - mt);
  }
  r.correlation = (sxx > 0 && syy > 0) ? sxy / std::sqrt(sxx * syy) : 0.0;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

void WriteValueMap(const ValueMapResult& result, const ValueMapOptions& options,
                   const std::string& agent, const std::string& dir) {
  const sim::MazeMap map = sim::MazeMap::FromName(options.maze);
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw std::runtime_error(dir + ": cannot create the directory: " + ec.message());
  std::vector<Eigen::Vector2d> xy;
  std::vector<double> pred, truth, err;
  double lo = 0, hi = -1e300, emax = 1e-9;
  for (const auto& p : result.points) {
    xy.push_back(p.xy);
    pred.push_back(p.predicted);
    truth.push_back(p.true_value);
    err.push_back(p.predicted - p.true_value);
    lo = std::min({lo, p.predicted, p.true_value});
    hi = std::max({hi, p.predicted, p.true_value});
    emax = std::max(emax, std::abs(p.predicted - p.true_value));
  }
  hi = std::max(hi, lo + 1e-6);
  const double patch = sim::kCellSize / options.per_cell;
  char title[160];
  std::snprintf(title, sizeof title, "predicted V(s,g): %s", agent.c_str());
  sim::SaveScalarFieldPlot(map, xy, pred, patch, lo, hi, sim::ColorScale::kSequential, options.goal,
                           title, dir + "/value_predicted.png");
  std::snprintf(title, sizeof title, "true V (Monte Carlo, %d rollouts), success %.0f%%",
                options.rollouts, 100 * result.mean_success);
  sim::SaveScalarFieldPlot(map, xy, truth, patch, lo, hi, sim::ColorScale::kSequential,
                           options.goal, title, dir + "/value_true.png");
  std::snprintf(title, sizeof title, "predicted - true: MAE %.2f, corr %.2f", result.mean_abs_error,
                result.correlation);
  sim::SaveScalarFieldPlot(map, xy, err, patch, -emax, emax, sim::ColorScale::kDiverging,
                           options.goal, title, dir + "/value_error.png");
  std::ostringstream js;
  js.precision(6);
  js << "{\n  \"env\": \"" << sim::EnvLabel(sim::EnvId::kPointMaze, options.maze)
     << "\",\n  \"agent\": \"" << agent << "\",\n"
     << "  \"goal\": [" << options.goal.x() << ", " << options.goal.y() << "],\n"
     << "  \"per_cell\": " << options.per_cell << ", \"rollouts\": " << options.rollouts
     << ", \"start_noise\": " << options.start_noise << ", \"max_steps\": " << options.max_steps
     << ", \"seed\": " << options.seed << ",\n  \"gamma\": " << result.gamma
     << ", \"episodes\": " << result.episodes
     << ",\n  \"mean_abs_error\": " << result.mean_abs_error << ", \"bias\": " << result.bias
     << ", \"correlation\": " << result.correlation << ", \"mean_success\": " << result.mean_success
     << ",\n  \"wall_time_s\": " << result.seconds << ",\n  \"points\": [\n";
  for (size_t i = 0; i < result.points.size(); ++i) {
    const auto& p = result.points[i];
    js << "    {\"x\": " << p.xy.x() << ", \"y\": " << p.xy.y()
       << ", \"predicted\": " << p.predicted << ", \"true\": " << p.true_value
       << ", \"success\": " << p.success << "}" << (i + 1 < result.points.size() ? ",\n" : "\n");
  }
  js << "  ]\n}\n";
  sim::WriteTextFile(dir + "/value_map.json", js.str());
}

sim::EvalReport MakeEvalReport(const MazeEvalResult& result, const MazeEvalOptions& options,
                               const std::string& agent) {
  sim::EvalReport report =
      MakeTaskReport(result, sim::EnvLabel(sim::EnvId::kPointMaze, options.maze), agent,
                     options.episodes, options.max_steps, options.seed);
  for (size_t i = 0; i < report.tasks.size() && i < options.custom_tasks.size(); ++i) {
    const auto& c = options.custom_tasks[i];
    report.tasks[i].start = {c.start.x(), c.start.y()};
    report.tasks[i].goal = {c.goal.x(), c.goal.y()};
  }
  return report;
}

void WriteResultsJson(const MazeEvalResult& result, const MazeEvalOptions& options,
                      const std::string& agent, const std::string& path) {
  sim::WriteTextFile(path, sim::EvalReportJson(sim::MazeMap::FromName(options.maze),
                                               MakeEvalReport(result, options, agent)));
}

}  // namespace msspr::agent
