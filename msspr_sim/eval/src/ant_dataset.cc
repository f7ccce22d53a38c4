#include "msspr_eval/ant_dataset.h"

#include <zip.h>

#include <cstdio>
#include <deque>
#include <memory>
#include <stdexcept>

#include "msspr_core/dataset.h"
#include "msspr_core/npz.h"
#include "msspr_eval/ant_waypoint_expert.h"
#include "msspr_sim/random_util.h"

namespace msspr::agent {
namespace {

using sim::Mix64;
using sim::RoundToFloat;
using sim::Uniform01;
using sim::UniformIndex;

Eigen::Vector2d NoisyCentre(const sim::MazeMap& map, sim::Cell c, std::mt19937_64& rng) {
  Eigen::Vector2d xy = map.CellCenter(c);
  for (int k = 0; k < 2; ++k)
    xy[k] += -sim::AntMaze::kCellNoise + 2.0 * sim::AntMaze::kCellNoise * Uniform01(rng);
  return xy;
}

// Separate streams for the cells and goals, and for the expert's noise.
constexpr uint64_t kTaskSalt = 0x616E747461736BULL;   // "anttask"
constexpr uint64_t kNoiseSalt = 0x616E746E6F6973ULL;  // "antnois"

}  // namespace

sim::Cell StitchGoalCell(const sim::MazeMap& map, sim::Cell start, std::mt19937_64& rng,
                         int steps) {
  const std::vector<int> dist = map.BfsDistances(start);
  std::vector<sim::Cell> cells;
  for (int i = 0; i < map.rows(); ++i)
    for (int j = 0; j < map.cols(); ++j)
      if (dist[static_cast<size_t>(i * map.cols() + j)] == steps) cells.push_back({i, j});
  return cells.empty() ? start : cells[UniformIndex(rng, cells.size())];
}

AntEpisode CollectAntEpisode(sim::AntMaze& env, core::SacPolicy& policy,
                             const AntCollectOptions& options, uint64_t index) {
  if (options.episode_length < 1)
    throw std::invalid_argument("CollectAntEpisode: episode_length must be >= 1");
  const sim::MazeMap& map = env.map();
  AntEpisode ep;
  ep.index = index;
  ep.seed = sim::EpisodeSeed(options.seed, index);
  ep.length = options.episode_length;
  std::mt19937_64 rng(Mix64(ep.seed ^ kTaskSalt));
  const std::vector<sim::Cell> free = map.FreeCells(), vertices = map.VertexCells();
  const bool navigate = options.kind == sim::DatasetKind::kNavigate;
  ep.start_cell = free[UniformIndex(rng, free.size())];
  ep.goal_cell = navigate ? vertices[UniformIndex(rng, vertices.size())]
                          : StitchGoalCell(map, ep.start_cell, rng);
  const Eigen::Vector2d start = NoisyCentre(map, ep.start_cell, rng);
  Eigen::Vector2d goal = NoisyCentre(map, ep.goal_cell, rng);
  env.Reset(start, goal, rng());
  ep.goal = env.goal();
  ep.goal_rows.push_back(0);
  ep.goal_cells.push_back(ep.goal_cell);
  ep.goal_xys.push_back(goal);
  AntWaypointExpert expert(policy, map, options.noise_std, Mix64(ep.seed ^ kNoiseSalt));

  const size_t n = static_cast<size_t>(ep.length);
  ep.observations.reserve(n * sim::AntMaze::kObsDim);
  ep.actions.reserve(n * sim::AntMaze::kActionDim);
  ep.qpos.reserve(n * sim::AntMaze::kQposDim);
  ep.qvel.reserve(n * sim::AntMaze::kQvelDim);
  const double radius = env.options().success_radius;
  for (int t = 0; t < ep.length; ++t) {
    const Eigen::VectorXd qpos = env.qpos(), qvel = env.qvel();
    ep.qpos.insert(ep.qpos.end(), qpos.data(), qpos.data() + qpos.size());
    ep.qvel.insert(ep.qvel.end(), qvel.data(), qvel.data() + qvel.size());
    Eigen::VectorXd ob(sim::AntMaze::kObsDim);
    ob << qpos, qvel;
    for (Eigen::Index i = 0; i < ob.size(); ++i) ep.observations.push_back(RoundToFloat(ob[i]));
    const Eigen::VectorXd raw = expert.Act(ob, goal);
    Eigen::VectorXd sent(raw.size());
    for (Eigen::Index i = 0; i < raw.size(); ++i) {
      const float a = RoundToFloat(raw[i]);
      ep.actions.push_back(a);
      sent[i] = a;
    }
    if (t + 1 == ep.length) break;
    env.Step(sent);
    if (navigate && (env.xy() - goal).norm() <= radius) {
      const sim::Cell c = vertices[UniformIndex(rng, vertices.size())];
      goal = NoisyCentre(map, c, rng);
      ep.goal_rows.push_back(t + 1);
      ep.goal_cells.push_back(c);
      ep.goal_xys.push_back(goal);
    }
  }
  return ep;
}

void SaveAntNpz(const std::vector<const AntEpisode*>& episodes, const std::string& path,
                bool compress) {
  // observations, actions, terminals by the core's writer; qpos and qvel added after.
  core::DatasetBuilder b(sim::AntMaze::kObsDim, sim::AntMaze::kActionDim);
  int64_t total = 0;
  for (const AntEpisode* ep : episodes) total += ep->length;
  b.Reserve(total);
  std::vector<float> qpos, qvel;
  qpos.reserve(static_cast<size_t>(total) * sim::AntMaze::kQposDim);
  qvel.reserve(static_cast<size_t>(total) * sim::AntMaze::kQvelDim);
  for (const AntEpisode* ep : episodes) {
    b.AddEpisode(ep->observations, ep->actions);
    for (double v : ep->qpos) qpos.push_back(static_cast<float>(v));
    for (double v : ep->qvel) qvel.push_back(static_cast<float>(v));
  }
  const std::string tmp = path + ".ant.tmp";
  core::SaveNpzDataset(b.Build(), tmp, compress);
  int err = 0;
  zip_t* z = zip_open(tmp.c_str(), 0, &err);
  if (z == nullptr)
    throw std::runtime_error(path + ": cannot reopen the archive to add qpos, qvel");
  std::deque<std::string> keep;  // the headers must live until zip_close
  auto add = [&](const std::string& key, const std::vector<float>& v, int64_t cols) {
    // numpy .npy v1.0 header, padded with spaces and a newline to a multiple of 64
    std::string dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (" +
                       std::to_string(total) + ", " + std::to_string(cols) + "), }";
    dict.append((64 - (10 + dict.size() + 1) % 64) % 64, ' ');
    dict.push_back('\n');
    std::string h("\x93NUMPY\x01\x00", 8);
    h.push_back(static_cast<char>(dict.size() & 0xff));
    h.push_back(static_cast<char>(dict.size() >> 8));
    keep.push_back(h + dict);
    zip_buffer_fragment_t frags[2];
    frags[0].data = reinterpret_cast<zip_uint8_t*>(keep.back().data());
    frags[0].length = keep.back().size();
    frags[1].data = reinterpret_cast<zip_uint8_t*>(const_cast<float*>(v.data()));
    frags[1].length = sizeof(float) * v.size();
    zip_source_t* src = zip_source_buffer_fragment(z, frags, v.empty() ? 1 : 2, 0);
    const zip_int64_t idx =
        src ? zip_file_add(z, (key + ".npy").c_str(), src, ZIP_FL_OVERWRITE) : -1;
    if (idx < 0) {
      if (src) zip_source_free(src);
      const std::string msg = zip_strerror(z);
      zip_discard(z);
      std::remove(tmp.c_str());
      throw std::runtime_error(path + ": cannot add " + key + ": " + msg);
    }
    zip_set_file_compression(z, idx, compress ? ZIP_CM_DEFLATE : ZIP_CM_STORE, 0);
  };
  add("qpos", qpos, sim::AntMaze::kQposDim);
  add("qvel", qvel, sim::AntMaze::kQvelDim);
  if (zip_close(z) != 0) {
    const std::string msg = zip_strerror(z);
    zip_discard(z);
    std::remove(tmp.c_str());
    throw std::runtime_error(path + ": cannot write: " + msg);
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error(path + ": cannot rename " + tmp);
  }
}

}  // namespace msspr::agent
