#include "msspr_core/policy.h"

#include <ATen/Parallel.h>

#include <sstream>

#include "module_io.h"
#include "msspr_core/checkpoint.h"
#include "msspr_core/mspr_agent.h"
#include "trainer_internal.h"

namespace msspr {
namespace core {

namespace {

MsprNetworks& MsprNetworksOf(Policy& policy) {
  auto* m = dynamic_cast<MsprAgent*>(policy.agent().get());
  if (!m)
    throw std::logic_error("Policy: the " + policy.agent_name() + " agent has no Ms.PR networks");
  return m->policy_networks();
}

// The agent's action for one row (obs, goal: [1, ...]), computed the same
// way on any thread: in float32 (autocast off), with every op of the forward
// pass serial (one OpenMP thread for torch's intra-op loops, OpenBLAS and
// oneDNN on this thread), so that the result depends neither on the thread
// setting nor on the batch the row came in.
torch::Tensor ActOneRow(GcAgent& agent, const torch::Tensor& obs, const torch::Tensor& goal) {
  torch::InferenceMode inference;  // thread-local: set on torch's worker threads too
  internal::AutocastOffScope fp32;
  // Torch initialises a thread's OpenMP thread count at its first query:
  // before the scope below, so that it does not undo it.
  (void)at::get_num_threads();
  trainer_internal::ThreadCountScope one_thread(1);
  return agent.Act(obs, goal);
}

}  // namespace

Policy::Policy(const MsprOptions& options, std::shared_ptr<GcAgent> agent, torch::Device device)
    : options_(options), agent_(std::move(agent)), device_(device) {}

Policy::Policy(const MsprOptions& options, Representation repr, Actor actor, Critic critic,
               torch::Device device)
    : Policy(
          options,
          std::make_shared<MsprAgent>(
              options, MsprNetworks{std::move(repr), std::move(critic), std::move(actor)}, device),
          device) {}

Policy Policy::Load(const std::string& path, torch::Device device) {
  const CheckpointFile file = ReadCheckpointFile(path);
  if (file.kind != "policy" && file.kind != "trainer") {
    throw CheckpointError(path + ": checkpoint kind '" + file.kind + "' holds no policy");
  }
  const CheckpointHeader header = ParseCheckpointHeader(file.header, path);
  MsprOptions options = header.options;
  options.trainer.device = device.str();
  std::shared_ptr<GcAgent> agent;
  try {
    agent = MakeGcAgent(options, device, /*training=*/false);
    torch::serialize::InputArchive archive;
    archive.load_from(file.payload.data(), file.payload.size(), device);
    agent->ReadPolicy(archive, file.kind == "trainer");
  } catch (const c10::Error& e) {
    throw CheckpointError(path + ": cannot read the " + options.baseline.agent +
                          " agent's networks: " + e.what_without_backtrace());
  } catch (const OptionsError& e) {
    throw CheckpointError(path + ": " + e.what());
  }
  agent->to(device);
  agent->eval();
  Policy policy(options, agent, device);
  policy.step_ = header.step;
  return policy;
}

Representation& Policy::repr() { return MsprNetworksOf(*this).repr; }
Actor& Policy::actor() { return MsprNetworksOf(*this).actor; }
Critic& Policy::critic() { return MsprNetworksOf(*this).critic; }

void AveragePolicies(const std::vector<std::string>& inputs, const std::string& out) {
  if (inputs.empty()) throw std::invalid_argument("AveragePolicies: no input policies");
  auto network_yaml = [](const MsprOptions& options) {
    MsprOptions o;
    o.network = options.network;
    return OptionsToYaml(o);
  };
  std::vector<Policy> policies;
  int64_t step = 0;
  for (const std::string& path : inputs) {
    policies.push_back(Policy::Load(path));
    const Policy& p = policies.back();
    if (p.agent_name() != "mspr") {
      throw CheckpointError(path + ": a " + p.agent_name() +
                            " agent's policy; only Ms.PR policies are averaged");
    }
    if (network_yaml(p.options()) != network_yaml(policies.front().options()) ||
        p.options().agent.subgoal_steps != policies.front().options().agent.subgoal_steps) {
      throw CheckpointError(path + ": network options differ from those of " + inputs.front() +
                            " (only exports of one network shape are averaged)");
    }
    step = std::max(step, p.step());
  }
  Policy& first = policies.front();
  torch::NoGradGuard no_grad;
  auto average = [&](auto module_of) {
    auto dst = module_of(first)->parameters();
    for (size_t k = 1; k < policies.size(); ++k) {
      const auto src = module_of(policies[k])->parameters();
      for (size_t i = 0; i < dst.size(); ++i) dst[i].add_(src[i]);
    }
    for (auto& t : dst) t.div_(static_cast<double>(policies.size()));
  };
  average([](Policy& p) { return p.repr().ptr(); });
  average([](Policy& p) { return p.actor().ptr(); });
  average([](Policy& p) { return p.critic().ptr(); });
  std::vector<std::pair<std::string, const torch::nn::Module*>> modules{
      {"repr", first.repr().get()},
      {"actor", first.actor().get()},
      {"critic", first.critic().get()}};
  if (MsprNetworksOf(first).subgoal) {
    average([](Policy& p) { return MsprNetworksOf(p).subgoal.ptr(); });
    modules.emplace_back("subgoal_actor", MsprNetworksOf(first).subgoal.get());
  }
  MsprOptions options = first.options();
  options.trainer.device = "cpu";
  WritePolicyExport(out, options, step, modules);
}

bool Policy::Batch(torch::Tensor* obs) const {
  const int64_t single_dim = pixels() ? 3 : 1;
  if (obs->dim() == single_dim) {
    *obs = obs->unsqueeze(0);
    return true;
  }
  TORCH_CHECK(obs->dim() == single_dim + 1, "Policy: observation of shape ", obs->sizes(),
              " does not match obs_mode ", options_.network.obs_mode);
  return false;
}

torch::Tensor Policy::Act(const torch::Tensor& obs_in, const torch::Tensor& goal_in) {
  torch::InferenceMode guard;
  torch::Tensor obs = obs_in.to(device_), goal = goal_in.to(device_);
  const bool single = Batch(&obs);
  Batch(&goal);
  TORCH_CHECK(goal.size(0) == obs.size(0), "Policy::Act: ", obs.size(0), " observations and ",
              goal.size(0), " goals");
  if (!pixels()) {
    obs = obs.to(torch::kFloat32);
    goal = goal.to(torch::kFloat32);
  }
  const int64_t rows = obs.size(0);
  if (rows <= 1) {
    const torch::Tensor a = ActOneRow(*agent_, obs, goal);
    return single ? a.squeeze(0) : a;
  }
  // Row by row (see policy.h); on the CPU the rows are shared among torch's
  // threads, each row's forward pass in one thread.
  std::vector<torch::Tensor> actions(static_cast<size_t>(rows));
  const auto act_rows = [&](int64_t begin, int64_t end) {
    for (int64_t b = begin; b < end; ++b)
      actions[static_cast<size_t>(b)] =
          ActOneRow(*agent_, obs.narrow(0, b, 1), goal.narrow(0, b, 1));
  };
  if (device_.is_cpu())
    at::parallel_for(0, rows, /*grain_size=*/1, act_rows);
  else
    act_rows(0, rows);
  return torch::cat(actions);
}

std::vector<float> Policy::Act(const std::vector<float>& obs, const std::vector<float>& goal) {
  TORCH_CHECK(!pixels(), "Policy::Act(vector): only for state observations");
  const int64_t d = static_cast<int64_t>(obs.size());
  TORCH_CHECK(d == obs_dim() && goal.size() == obs.size(), "Policy::Act: expected obs and goal of ",
              obs_dim(), " values, got ", obs.size(), " and ", goal.size());
  const torch::Tensor o = torch::from_blob(const_cast<float*>(obs.data()), {d}, torch::kFloat32);
  const torch::Tensor g = torch::from_blob(const_cast<float*>(goal.data()), {d}, torch::kFloat32);
  const torch::Tensor a = Act(o, g).to(torch::kCPU).contiguous();
  return std::vector<float>(a.data_ptr<float>(), a.data_ptr<float>() + a.numel());
}

torch::Tensor Policy::Q(const torch::Tensor& obs_in, const torch::Tensor& action_in,
                        const torch::Tensor& goal_in) {
  torch::InferenceMode guard;
  torch::Tensor obs = obs_in.to(device_), goal = goal_in.to(device_);
  torch::Tensor action = action_in.to(device_).to(torch::kFloat32);
  const bool single = Batch(&obs);
  Batch(&goal);
  if (action.dim() == 1) action = action.unsqueeze(0);
  if (!pixels()) {
    obs = obs.to(torch::kFloat32);
    goal = goal.to(torch::kFloat32);
  }
  const torch::Tensor q = agent_->Value(obs, action, goal);
  return single ? q.squeeze(0) : q;
}

}  // namespace core
}  // namespace msspr
