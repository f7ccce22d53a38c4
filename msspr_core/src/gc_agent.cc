// The agent interface's shared parts (gc_agent.h) and its factory.
#include "msspr_core/gc_agent.h"

#include <stdexcept>

#include "msspr_core/baselines.h"
#include "msspr_core/distributed.h"
#include "msspr_core/mspr_agent.h"

namespace msspr {
namespace core {

NamedValues LossInfo::Named() const {
  if (!agent.empty()) return agent;
  NamedValues named{{"repr", repr},     {"dyn", dyn},       {"rew", rew},       {"inv", inv},
                    {"gdyn", goal_dyn}, {"gact", goal_act}, {"critic", critic}, {"q", q_mean},
                    {"actor", actor},   {"bc", bc}};
  named.insert(named.end(), extra.begin(), extra.end());
  return named;
}

GcAgent::GcAgent(const MsprOptions& options) : options_(options) {}

LossInfo GcAgent::NoLosses() const {
  LossInfo info;
  for (const std::string& name : LossNames()) info.agent.emplace_back(name, NAN);
  return info;
}

NamedValues GcAgent::ProgressValues(const LossInfo& info) const {
  NamedValues named = info.Named();
  if (named.size() > 4) named.resize(4);
  return named;
}

torch::Tensor GcAgent::Value(const torch::Tensor&, const torch::Tensor&, const torch::Tensor&) {
  throw std::logic_error("agent '" + agent_name() + "' has no value function");
}

void GcAgent::AverageGradients(const std::vector<torch::Tensor>& params) {
  if (dist_) dist_->AverageGradients(params);
}

std::shared_ptr<GcAgent> MakeGcAgent(const MsprOptions& options, torch::Device device,
                                     bool training) {
  if (options.baseline.agent == "mspr")
    return std::make_shared<MsprAgent>(options, device, training);
  std::shared_ptr<OgbenchAgent> agent = MakeAgent(options);
  if (training) agent->PrepareTraining(device);
  return agent;
}

}  // namespace core
}  // namespace msspr
