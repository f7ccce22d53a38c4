#include "msspr_eval/ant_expert.h"

namespace msspr::agent {
namespace {

std::vector<float> ToFloats(const Eigen::VectorXd& v) {
  std::vector<float> out(static_cast<size_t>(v.size()));
  for (Eigen::Index i = 0; i < v.size(); ++i)
    out[static_cast<size_t>(i)] = static_cast<float>(v[i]);
  return out;
}

}  // namespace

AntXyOnlineEnv::AntXyOnlineEnv(const sim::AntXyEnvOptions& options) : env_(options) {}

std::vector<float> AntXyOnlineEnv::Reset(uint64_t seed) { return ToFloats(env_.Reset(seed)); }

core::OnlineEnv::StepResult AntXyOnlineEnv::Step(const std::vector<float>& action) {
  Eigen::VectorXd a(static_cast<Eigen::Index>(action.size()));
  for (size_t i = 0; i < action.size(); ++i) a[static_cast<Eigen::Index>(i)] = action[i];
  const sim::AntXyEnv::StepResult r = env_.Step(a);
  StepResult out;
  out.obs = ToFloats(r.observation);
  out.reward = r.reward;
  out.terminated = r.terminated;
  out.truncated = r.truncated;
  return out;
}

}  // namespace msspr::agent
