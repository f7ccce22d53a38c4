#include "msspr_core/sac.h"

#include <yaml-cpp/yaml.h>

#include <chrono>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <mutex>
#include <numeric>
#include <sstream>

#include "module_io.h"
#include "msspr_core/checkpoint.h"
#include "msspr_core/networks.h"
#include "msspr_core/progress.h"
#include "sac_internal.h"
#include "yaml_sections.h"

namespace msspr {
namespace core {
namespace {

void Check(bool ok, const std::string& what) {
  if (!ok) throw OptionsError("invalid sac options: " + what);
}

torch::Tensor Row(const std::vector<float>& v) {
  return torch::tensor(v, torch::kFloat32).unsqueeze(0);
}

std::vector<float> ToVector(const torch::Tensor& t) {
  const torch::Tensor c = t.to(torch::kFloat32).contiguous().view(-1);
  return std::vector<float>(c.data_ptr<float>(), c.data_ptr<float>() + c.numel());
}

}  // namespace

namespace sac_internal {

std::string HeaderToYaml(const SacHeader& h) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  WriteSection(out, "sac", h.options);
  out << YAML::Key << "obs_dim" << YAML::Value << h.obs_dim;
  out << YAML::Key << "action_dim" << YAML::Value << h.action_dim;
  out << YAML::Key << "step" << YAML::Value << h.step;
  out << YAML::Key << "episode" << YAML::Value << h.episode;
  out << YAML::Key << "updates" << YAML::Value << h.updates;
  out << YAML::Key << "rng" << YAML::Value << h.rng;
  out << YAML::EndMap;
  return out.c_str();
}

SacHeader ParseHeader(const std::string& yaml, const std::string& path) {
  SacHeader h;
  try {
    const YAML::Node root = YAML::Load(yaml);
    std::set<std::string> seen;
    ReadSection(root, "sac", h.options, path, seen);
    h.obs_dim = root["obs_dim"].as<int64_t>();
    h.action_dim = root["action_dim"].as<int64_t>();
    if (root["step"]) h.step = root["step"].as<int64_t>();
    if (root["episode"]) h.episode = root["episode"].as<int64_t>();
    if (root["updates"]) h.updates = root["updates"].as<int64_t>();
    if (root["rng"]) h.rng = root["rng"].as<std::string>();
  } catch (const std::exception& e) {
    throw CheckpointError(path + ": bad SAC checkpoint header: " + e.what());
  }
  if (h.obs_dim <= 0 || h.action_dim <= 0)
    throw CheckpointError(path + ": bad SAC checkpoint header: obs_dim / action_dim");
  return h;
}

}  // namespace sac_internal

using namespace sac_internal;

void ValidateSacOptions(const SacOptions& o) {
  Check(o.hidden > 0 && o.layers >= 1, "hidden must be > 0 and layers >= 1");
  Check(o.lr > 0 && std::isfinite(o.lr), "lr must be > 0");
  Check(o.batch_size > 0, "batch_size must be > 0");
  Check(o.gamma >= 0 && o.gamma < 1, "gamma must be in [0, 1)");
  Check(o.tau > 0 && o.tau <= 1, "tau must be in (0, 1]");
  Check(std::isnan(o.target_entropy) || std::isfinite(o.target_entropy),
        "target_entropy must be finite (or unset)");
  Check(o.init_temperature > 0, "init_temperature must be > 0");
  Check(o.log_std_min < o.log_std_max, "log_std_min must be < log_std_max");
  Check(o.steps > 0, "steps must be > 0");
  Check(o.random_steps >= 0, "random_steps must be >= 0");
  Check(o.buffer_size >= o.batch_size, "buffer_size must be >= batch_size");
  Check(o.log_every > 0, "log_every must be > 0");
  Check(o.checkpoint_every >= 0 && o.eval_every >= 0, "checkpoint_every / eval_every must be >= 0");
  Check(o.eval_episodes > 0, "eval_episodes must be > 0");
  Check(o.time_limit_s >= 0, "time_limit_s must be >= 0");
}

SacOptions ApplySacYaml(const std::string& yaml_text, const SacOptions& base,
                        const std::string& source) {
  SacOptions o = base;
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw OptionsError(source + ": " + e.what());
  }
  if (!root || root.IsNull()) return o;
  if (!root.IsMap()) throw OptionsError(source + ": expected a map with a 'sac' section");
  std::set<std::string> seen;
  ReadSection(root, "sac", o, source, seen);
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    if (!seen.count(key))
      throw OptionsError(source + ": unknown key '" + key + "' (expected 'sac')");
  }
  return o;
}

std::string SacOptionsToYaml(const SacOptions& o) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  WriteSection(out, "sac", o);
  out << YAML::EndMap;
  return out.c_str();
}

// --- Actor --------------------------------------------------------------------

SacActorImpl::SacActorImpl(int64_t obs_dim, int64_t action_dim, const SacOptions& o)
    : log_std_min(o.log_std_min), log_std_max(o.log_std_max) {
  std::vector<int64_t> sizes{obs_dim};
  for (int i = 0; i < o.layers; ++i) sizes.push_back(o.hidden);
  trunk = register_module("trunk", OgMlp(sizes, /*activate_final=*/true, o.layer_norm));
  mean = register_module("mean", torch::nn::Linear(o.hidden, action_dim));
  log_std = register_module("log_std", torch::nn::Linear(o.hidden, action_dim));
  // OGBench's actor_fc_scale 0.01: variance_scaling(0.01, fan_avg, uniform), i.e. Xavier
  // uniform with gain 0.1, zero bias; the policy starts near mean 0 and log-std 0.
  for (auto* head : {&mean, &log_std}) {
    torch::nn::init::xavier_uniform_((*head)->weight, /*gain=*/0.1);
    torch::nn::init::zeros_((*head)->bias);
  }
}

std::pair<torch::Tensor, torch::Tensor> SacActorImpl::forward(const torch::Tensor& obs) {
  const torch::Tensor h = trunk->forward(obs);
  return {mean->forward(h), log_std->forward(h).clamp(log_std_min, log_std_max)};
}

std::pair<torch::Tensor, torch::Tensor> SacActorImpl::Sample(const torch::Tensor& obs) {
  auto [mu, ls] = forward(obs);
  const torch::Tensor eps = torch::randn_like(mu);
  const torch::Tensor u = mu + ls.exp() * eps;
  // log N(u; mu, std) - log |d tanh(u) / du|, the latter as 2 (log 2 - u - softplus(-2u)).
  const torch::Tensor log_normal = (-0.5 * eps.pow(2) - ls - 0.5 * std::log(2.0 * M_PI)).sum(-1);
  const torch::Tensor log_det =
      (2.0 * (std::log(2.0) - u - torch::nn::functional::softplus(-2.0 * u))).sum(-1);
  return {torch::tanh(u), log_normal - log_det};
}

torch::Tensor SacActorImpl::Deterministic(const torch::Tensor& obs) {
  return torch::tanh(forward(obs).first);
}

// --- Replay buffer --------------------------------------------------------------

ReplayBuffer::ReplayBuffer(int64_t capacity, int64_t obs_dim, int64_t action_dim)
    : capacity_(capacity), obs_dim_(obs_dim), action_dim_(action_dim) {
  TORCH_CHECK(capacity > 0 && obs_dim > 0 && action_dim > 0, "ReplayBuffer: sizes must be > 0");
  obs_ = torch::zeros({capacity, obs_dim});
  next_obs_ = torch::zeros({capacity, obs_dim});
  action_ = torch::zeros({capacity, action_dim});
  reward_ = torch::zeros({capacity});
  done_ = torch::zeros({capacity});
}

void ReplayBuffer::Add(const std::vector<float>& obs, const std::vector<float>& action,
                       double reward, const std::vector<float>& next_obs, bool done) {
  TORCH_CHECK(static_cast<int64_t>(obs.size()) == obs_dim_ &&
                  static_cast<int64_t>(next_obs.size()) == obs_dim_ &&
                  static_cast<int64_t>(action.size()) == action_dim_,
              "ReplayBuffer::Add: expected ", obs_dim_, " observation and ", action_dim_,
              " action values, got ", obs.size(), ", ", next_obs.size(), " and ", action.size());
  std::copy(obs.begin(), obs.end(), obs_.data_ptr<float>() + next_ * obs_dim_);
  std::copy(next_obs.begin(), next_obs.end(), next_obs_.data_ptr<float>() + next_ * obs_dim_);
  std::copy(action.begin(), action.end(), action_.data_ptr<float>() + next_ * action_dim_);
  reward_.data_ptr<float>()[next_] = static_cast<float>(reward);
  done_.data_ptr<float>()[next_] = done ? 1.0f : 0.0f;
  next_ = (next_ + 1) % capacity_;
  size_ = std::min(size_ + 1, capacity_);
}

SacBatch ReplayBuffer::Sample(int64_t n, std::mt19937_64& rng) const {
  TORCH_CHECK(size_ > 0, "ReplayBuffer::Sample: the buffer is empty");
  std::uniform_int_distribution<int64_t> pick(0, size_ - 1);
  torch::Tensor idx = torch::empty({n}, torch::kLong);
  int64_t* p = idx.data_ptr<int64_t>();
  for (int64_t i = 0; i < n; ++i) p[i] = pick(rng);
  return {obs_.index_select(0, idx), action_.index_select(0, idx), reward_.index_select(0, idx),
          next_obs_.index_select(0, idx), done_.index_select(0, idx)};
}

void ReplayBuffer::Save(torch::serialize::OutputArchive& archive) const {
  archive.write("buffer_obs", obs_.narrow(0, 0, size_).clone());
  archive.write("buffer_next_obs", next_obs_.narrow(0, 0, size_).clone());
  archive.write("buffer_action", action_.narrow(0, 0, size_).clone());
  archive.write("buffer_reward", reward_.narrow(0, 0, size_).clone());
  archive.write("buffer_done", done_.narrow(0, 0, size_).clone());
  archive.write("buffer_position", torch::tensor({size_, next_, capacity_}, torch::kLong));
}

void ReplayBuffer::Load(torch::serialize::InputArchive& archive) {
  torch::Tensor pos, o, no, a, r, d;
  archive.read("buffer_position", pos);
  archive.read("buffer_obs", o);
  archive.read("buffer_next_obs", no);
  archive.read("buffer_action", a);
  archive.read("buffer_reward", r);
  archive.read("buffer_done", d);
  const int64_t size = pos[0].item<int64_t>(), next = pos[1].item<int64_t>(),
                capacity = pos[2].item<int64_t>();
  TORCH_CHECK(size >= 0 && size <= capacity && next >= 0 && next < capacity && o.size(0) == size &&
                  o.size(1) == obs_dim_ && a.size(1) == action_dim_,
              "the checkpoint's replay buffer (", size, " transitions of ", o.size(1), " + ",
              a.size(1), " values) does not fit this run's (", obs_dim_, " + ", action_dim_, ")");
  std::vector<torch::Tensor*> dst{&obs_, &next_obs_, &action_, &reward_, &done_};
  std::vector<torch::Tensor> src{o, no, a, r, d};
  if (capacity == capacity_) {  // the same ring: sampling continues exactly
    for (size_t k = 0; k < src.size(); ++k) dst[k]->narrow(0, 0, size).copy_(src[k]);
    size_ = size;
    next_ = next;
    return;
  }
  // Another capacity: the newest transitions, oldest first.
  const int64_t keep = std::min(size, capacity_);
  torch::Tensor order = torch::arange(size, torch::kLong);
  if (size == capacity) order = (order + next) % capacity;  // a full ring starts at `next`
  order = order.narrow(0, size - keep, keep);
  for (size_t k = 0; k < src.size(); ++k)
    dst[k]->narrow(0, 0, keep).copy_(src[k].index_select(0, order));
  size_ = keep;
  next_ = keep % capacity_;
}

// --- Agent ----------------------------------------------------------------------

SacAgent::SacAgent(int64_t obs_dim, int64_t action_dim, const SacOptions& o)
    : options_(o), obs_dim_(obs_dim), action_dim_(action_dim) {
  target_entropy_ =
      std::isnan(o.target_entropy) ? -static_cast<double>(action_dim) / 2.0 : o.target_entropy;
  std::vector<int64_t> q_sizes{obs_dim + action_dim};
  for (int i = 0; i < o.layers; ++i) q_sizes.push_back(o.hidden);
  q_sizes.push_back(1);
  q1 = OgMlp(q_sizes, false, o.layer_norm);
  q2 = OgMlp(q_sizes, false, o.layer_norm);
  target_q1 = OgMlp(q_sizes, false, o.layer_norm);
  target_q2 = OgMlp(q_sizes, false, o.layer_norm);
  HardUpdate(*target_q1, *q1);
  HardUpdate(*target_q2, *q2);
  SetRequiresGrad(*target_q1, false);
  SetRequiresGrad(*target_q2, false);
  actor = SacActor(obs_dim, action_dim, o);
  log_alpha = torch::full({}, std::log(o.init_temperature), torch::kFloat32).requires_grad_(true);
  const auto adam = torch::optim::AdamOptions(o.lr);
  actor_opt = std::make_unique<torch::optim::Adam>(actor->parameters(), adam);
  std::vector<torch::Tensor> critic_params = q1->parameters();
  for (const auto& p : q2->parameters()) critic_params.push_back(p);
  critic_opt = std::make_unique<torch::optim::Adam>(critic_params, adam);
  alpha_opt = std::make_unique<torch::optim::Adam>(std::vector<torch::Tensor>{log_alpha}, adam);
}

torch::Tensor SacAgent::Q(OgMlp& q, const torch::Tensor& obs, const torch::Tensor& action) {
  return q->forward(torch::cat({obs, action}, -1)).squeeze(-1);
}

double SacAgent::alpha() const { return std::exp(log_alpha.item<double>()); }

NamedValues SacAgent::Update(const SacBatch& b) {
  // All three losses from the parameters before this update (as OGBench's
  // one joint step), each optimiser stepping its own parameters.
  const torch::Tensor alpha_now = log_alpha.exp().detach();
  torch::Tensor y;
  {
    torch::NoGradGuard no_grad;
    auto [next_a, next_logp] = actor->Sample(b.next_obs);
    torch::Tensor q_next =
        torch::min(Q(target_q1, b.next_obs, next_a), Q(target_q2, b.next_obs, next_a));
    if (options_.backup_entropy) q_next = q_next - alpha_now * next_logp;
    y = b.reward + options_.gamma * (1.0 - b.done) * q_next;
  }
  const torch::Tensor q1v = Q(q1, b.obs, b.action), q2v = Q(q2, b.obs, b.action);
  const torch::Tensor critic_loss = 0.5 * ((q1v - y).pow(2).mean() + (q2v - y).pow(2).mean());

  auto [pi, logp] = actor->Sample(b.obs);
  const torch::Tensor q_pi = torch::min(Q(q1, b.obs, pi), Q(q2, b.obs, pi));
  const torch::Tensor actor_loss = (alpha_now * logp - q_pi).mean();
  const torch::Tensor alpha_loss = -(log_alpha.exp() * (logp.detach() + target_entropy_)).mean();

  const std::vector<torch::Tensor> actor_params = actor->parameters();
  const std::vector<torch::Tensor> actor_grads = torch::autograd::grad({actor_loss}, actor_params);
  // Gradients are set, not accumulated (grad() may return views, which zero_grad cannot detach).
  for (auto* opt : {critic_opt.get(), alpha_opt.get()})
    for (auto& group : opt->param_groups())
      for (auto& p : group.params()) p.mutable_grad() = torch::Tensor();
  critic_loss.backward();
  critic_opt->step();
  for (size_t i = 0; i < actor_params.size(); ++i) actor_params[i].mutable_grad() = actor_grads[i];
  actor_opt->step();
  alpha_loss.backward();
  alpha_opt->step();
  SoftUpdate(*target_q1, *q1, options_.tau);
  SoftUpdate(*target_q2, *q2, options_.tau);
  const torch::Tensor host = torch::stack({critic_loss.detach(), actor_loss.detach(),
                                           -logp.detach().mean(), q1v.detach().mean()})
                                 .to(torch::kFloat64);
  return {{"critic_loss", host[0].item<double>()},
          {"actor_loss", host[1].item<double>()},
          {"alpha", alpha()},
          {"entropy", host[2].item<double>()},
          {"q_mean", host[3].item<double>()}};
}

std::vector<float> SacAgent::Act(const std::vector<float>& obs, bool deterministic) {
  torch::NoGradGuard no_grad;
  const torch::Tensor o = Row(obs);
  return ToVector(deterministic ? actor->Deterministic(o) : actor->Sample(o).first);
}

std::vector<std::pair<const char*, torch::optim::Adam*>> SacAgent::NamedOptimizers() const {
  return {{"actor_opt", actor_opt.get()},
          {"critic_opt", critic_opt.get()},
          {"alpha_opt", alpha_opt.get()}};
}

void SacAgent::Save(torch::serialize::OutputArchive& archive) const {
  WriteModule(archive, "actor", *actor);
  WriteModule(archive, "q1", *q1);
  WriteModule(archive, "q2", *q2);
  WriteModule(archive, "target_q1", *target_q1);
  WriteModule(archive, "target_q2", *target_q2);
  archive.write("log_alpha", log_alpha.detach().clone());
  for (const auto& [key, opt] : NamedOptimizers()) {
    torch::serialize::OutputArchive sub;
    opt->save(sub);
    archive.write(key, sub);
  }
}

void SacAgent::Load(torch::serialize::InputArchive& archive) {
  ReadModule(archive, "actor", *actor);
  ReadModule(archive, "q1", *q1);
  ReadModule(archive, "q2", *q2);
  ReadModule(archive, "target_q1", *target_q1);
  ReadModule(archive, "target_q2", *target_q2);
  torch::Tensor la;
  archive.read("log_alpha", la);
  {
    torch::NoGradGuard no_grad;
    log_alpha.copy_(la);
  }
  for (const auto& [key, opt] : NamedOptimizers()) {
    torch::serialize::InputArchive sub;
    archive.read(key, sub);
    opt->load(sub);
  }
}

// --- Policy ---------------------------------------------------------------------

SacPolicy::SacPolicy(const std::string& path) {
  const CheckpointFile file = ReadCheckpointFile(path, kSacPolicyKind);
  const SacHeader h = ParseHeader(file.header, path);
  options_ = h.options;
  obs_dim_ = h.obs_dim;
  action_dim_ = h.action_dim;
  actor_ = SacActor(obs_dim_, action_dim_, options_);
  try {
    torch::serialize::InputArchive archive;
    std::istringstream payload(file.payload);
    archive.load_from(payload);
    ReadModule(archive, "actor", *actor_);
  } catch (const c10::Error& e) {
    throw CheckpointError(path + ": unreadable SAC policy: " + e.what_without_backtrace());
  }
  actor_->eval();
}

std::vector<float> SacPolicy::Act(const std::vector<float>& obs) {
  TORCH_CHECK(static_cast<int64_t>(obs.size()) == obs_dim_, "SacPolicy::Act: expected ", obs_dim_,
              " observation values, got ", obs.size());
  torch::InferenceMode guard;
  return ToVector(actor_->Deterministic(Row(obs)));
}

}  // namespace core
}  // namespace msspr
