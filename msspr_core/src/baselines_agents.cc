// The six OGBench agents (GCBC, GCIVL, GCIQL, QRL, CRL, HIQL): their networks, losses and
// acting rules over OgbenchAgent (baselines.cc).
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "autocast_compat.h"
#include "baselines_internal.h"
#include "msspr_core/baselines.h"

namespace msspr {
namespace core {

using namespace baselines_internal;

// --- The one-actor agents -----------------------------------------------------

void GcActorAgent::RegisterActor() {
  const BaselineOptions& b = options_.baseline;
  actor_enc = RegisterPairEncoder("actor_enc");
  actor = register_module("actor", GaussianActor(pair_dim_, b.hidden, b.layers, action_dim_));
}

torch::Tensor GcActorAgent::Act(const torch::Tensor& obs, const torch::Tensor& goal) {
  return ForActing(actor)->Mean(Pair(actor_enc, obs, goal)).clamp(-1.0, 1.0);
}

// --- GCBC ---------------------------------------------------------------------

GcbcAgent::GcbcAgent(const MsprOptions& o) : GcActorAgent(o) { RegisterActor(); }

torch::Tensor GcbcAgent::Loss(const TransitionBatch& batch, NamedValues* info) {
  const torch::Tensor x = Pair(actor_enc, batch.obs, batch.actor_goal);
  const torch::Tensor mean = actor->Mean(x);
  const torch::Tensor loss = -StdNormalLogProb(batch.action, mean).mean();
  if (info) {
    info->emplace_back("actor", Item(loss));
    info->emplace_back("mse", Item((mean - batch.action).pow(2).sum(-1).mean()));
  }
  return loss;
}

// --- GCIVL --------------------------------------------------------------------

GcivlAgent::GcivlAgent(const MsprOptions& o) : GcActorAgent(o) {
  value_enc = RegisterPairEncoder("value_enc");
  v1 = register_module("v1", OgMlp(Sizes(pair_dim_, 1), false, true));
  v2 = register_module("v2", OgMlp(Sizes(pair_dim_, 1), false, true));
  target_value_enc = RegisterPairEncoder("target_value_enc");
  target_v1 = register_module("target_v1", OgMlp(Sizes(pair_dim_, 1), false, true));
  target_v2 = register_module("target_v2", OgMlp(Sizes(pair_dim_, 1), false, true));
  if (value_enc) InitTarget(*target_value_enc, *value_enc);
  InitTarget(*target_v1, *v1);
  InitTarget(*target_v2, *v2);
  RegisterActor();
}

std::vector<torch::nn::Module*> GcivlAgent::Targets() {
  std::vector<torch::nn::Module*> t{target_v1.get(), target_v2.get()};
  if (target_value_enc) t.push_back(target_value_enc.get());
  return t;
}

torch::Tensor GcivlAgent::Loss(const TransitionBatch& batch, NamedValues* info) {
  const torch::Tensor s_g = Pair(value_enc, batch.obs, batch.value_goal);
  torch::Tensor next_target, target;
  {
    torch::NoGradGuard no_grad;
    next_target =
        Twin(target_v1, target_v2, Pair(target_value_enc, batch.next_obs, batch.value_goal));
    target = Twin(target_v1, target_v2,
                  value_enc ? Pair(target_value_enc, batch.obs, batch.value_goal) : s_g);
  }
  const torch::Tensor v = Twin(v1, v2, s_g);
  const torch::Tensor value_loss =
      TwinExpectileValueLoss(batch, next_target, target, v, options_.baseline.expectile);

  const torch::Tensor x = Pair(actor_enc, batch.obs, batch.actor_goal);
  torch::Tensor a_adv;
  {
    torch::NoGradGuard no_grad;
    const torch::Tensor v_x = value_enc ? Pair(value_enc, batch.obs, batch.actor_goal) : x;
    a_adv = Twin(v1, v2, Pair(value_enc, batch.next_obs, batch.actor_goal)).mean(-1) -
            Twin(v1, v2, v_x).mean(-1);
  }
  const torch::Tensor actor_loss =
      -(AwrWeight(a_adv, options_.baseline.alpha) * actor->LogProb(x, batch.action)).mean();
  if (info) {
    info->emplace_back("value", Item(value_loss));
    info->emplace_back("v", Item(v.select(-1, 0).mean()));
    info->emplace_back("actor", Item(actor_loss));
    info->emplace_back("adv", Item(a_adv.mean()));
  }
  return value_loss + actor_loss;
}

void GcivlAgent::UpdateTargets() {
  if (value_enc) Polyak(*target_value_enc, *value_enc);
  Polyak(*target_v1, *v1);
  Polyak(*target_v2, *v2);
}

torch::Tensor GcivlAgent::Value(const torch::Tensor& obs, const torch::Tensor&,
                                const torch::Tensor& goal) {
  return Twin(v1, v2, Pair(value_enc, obs, goal));
}

// --- GCIQL --------------------------------------------------------------------

GciqlAgent::GciqlAgent(const MsprOptions& o) : GcActorAgent(o) {
  const int64_t in_q = pair_dim_ + action_dim_;
  value_enc = RegisterPairEncoder("value_enc");
  v = register_module("v", OgMlp(Sizes(pair_dim_, 1), false, true));
  critic_enc = RegisterPairEncoder("critic_enc");
  q1 = register_module("q1", OgMlp(Sizes(in_q, 1), false, true));
  q2 = register_module("q2", OgMlp(Sizes(in_q, 1), false, true));
  target_critic_enc = RegisterPairEncoder("target_critic_enc");
  target_q1 = register_module("target_q1", OgMlp(Sizes(in_q, 1), false, true));
  target_q2 = register_module("target_q2", OgMlp(Sizes(in_q, 1), false, true));
  if (critic_enc) InitTarget(*target_critic_enc, *critic_enc);
  InitTarget(*target_q1, *q1);
  InitTarget(*target_q2, *q2);
  RegisterActor();
}

std::vector<torch::nn::Module*> GciqlAgent::Targets() {
  std::vector<torch::nn::Module*> t{target_q1.get(), target_q2.get()};
  if (target_critic_enc) t.push_back(target_critic_enc.get());
  return t;
}

torch::Tensor GciqlAgent::QOf(bool target, const torch::Tensor& obs, const torch::Tensor& goal,
                              const torch::Tensor& action) {
  // States: [s, g, a], one concatenation (as before encoders existed).
  const torch::Tensor x =
      critic_enc ? Cat(Pair(target ? target_critic_enc : critic_enc, obs, goal), action)
                 : torch::cat({obs, goal, action}, -1);
  return target ? Twin(target_q1, target_q2, x) : Twin(q1, q2, x);
}

torch::Tensor GciqlAgent::Q(const torch::Tensor& obs, const torch::Tensor& goal,
                            const torch::Tensor& action) {
  return QOf(false, obs, goal, action);
}

torch::Tensor GciqlAgent::Loss(const TransitionBatch& batch, NamedValues* info) {
  const torch::Tensor s_g = Pair(value_enc, batch.obs, batch.value_goal);
  torch::Tensor tq, y;
  {
    torch::NoGradGuard no_grad;
    tq = std::get<0>(QOf(true, batch.obs, batch.value_goal, batch.action).min(-1));
    y = batch.ret +
        batch.discount * v(Pair(value_enc, batch.next_obs, batch.value_goal)).squeeze(-1);
  }
  const torch::Tensor v_s = v(s_g).squeeze(-1);
  const torch::Tensor diff = tq - v_s;
  const torch::Tensor value_loss =
      (ExpectileWeight(diff.detach(), options_.baseline.expectile) * diff.pow(2)).mean();
  const torch::Tensor q = Q(batch.obs, batch.value_goal, batch.action);
  const torch::Tensor critic_loss =
      ((q.select(-1, 0) - y).pow(2) + (q.select(-1, 1) - y).pow(2)).mean();

  const torch::Tensor x = Pair(actor_enc, batch.obs, batch.actor_goal);
  const torch::Tensor mean = actor->Mean(x);
  torch::Tensor q_pi;
  {
    const Frozen frozen(critic_enc ? ParamsOf({q1.get(), q2.get(), critic_enc.get()})
                                   : ParamsOf({q1.get(), q2.get()}));
    q_pi = std::get<0>(Q(batch.obs, batch.actor_goal, mean.clamp(-1.0, 1.0)).min(-1));
  }
  if (info) {
    info->emplace_back("value", Item(value_loss));
    info->emplace_back("critic", Item(critic_loss));
    info->emplace_back("q", Item(q.mean()));
  }
  const torch::Tensor actor_loss = DdpgBcLoss(q_pi, StdNormalLogProb(batch.action, mean), info);
  return value_loss + critic_loss + actor_loss;
}

void GciqlAgent::UpdateTargets() {
  if (critic_enc) Polyak(*target_critic_enc, *critic_enc);
  Polyak(*target_q1, *q1);
  Polyak(*target_q2, *q2);
}

torch::Tensor GciqlAgent::Value(const torch::Tensor& obs, const torch::Tensor& action,
                                const torch::Tensor& goal) {
  return Q(obs, goal, action);
}

// --- QRL ----------------------------------------------------------------------

QrlAgent::QrlAgent(const MsprOptions& o) : GcActorAgent(o) {
  const BaselineOptions& b = o.baseline;
  phi = register_module("phi", OgMlp(Sizes(obs_dim_, b.latent_dim), false, true));
  dynamics = register_module("dynamics",
                             OgMlp(Sizes(b.latent_dim + action_dim_, b.latent_dim), false, true));
  alpha_raw = register_parameter("alpha_raw", torch::zeros({1}));
  log_lambda = register_parameter("log_lambda", torch::zeros({1}));
  RegisterActor();
}

torch::Tensor QrlAgent::Distance(const torch::Tensor& zx, const torch::Tensor& zy) {
  return IqeDistance(zx, zy, options_.baseline.iqe_dim, alpha_raw);
}

torch::Tensor QrlAgent::PredictLatent(const torch::Tensor& z, const torch::Tensor& action) {
  return z + dynamics(Cat(z, action));
}

torch::Tensor QrlAgent::Loss(const TransitionBatch& batch, NamedValues* info) {
  const BaselineOptions& b = options_.baseline;
  const torch::Tensor z = phi(batch.obs), z_next = phi(batch.next_obs),
                      z_goal = phi(batch.value_goal);
  const torch::Tensor d_neg = Distance(z, z_goal);
  const torch::Tensor d_pos = Distance(z, z_next);
  const torch::Tensor neg_loss = (100.0 * torch::softplus(5.0 - d_neg / 100.0)).mean();
  const torch::Tensor constraint = torch::relu(d_pos - 1.0).pow(2).mean();
  const torch::Tensor lambda = log_lambda.exp().reshape({});
  const torch::Tensor value_loss = neg_loss + lambda.detach() * constraint;
  const torch::Tensor lambda_loss = lambda * (b.qrl_eps - constraint.detach());
  const torch::Tensor z_hat = PredictLatent(z, batch.action);
  const torch::Tensor dyn_loss = ((Distance(z_next, z_hat) + Distance(z_hat, z_next)) / 2.0).mean();

  const torch::Tensor mean = actor->Mean(Cat(batch.obs, batch.actor_goal));
  torch::Tensor q_pi;
  {
    torch::Tensor zs, zg;
    {
      torch::NoGradGuard no_grad;
      zs = phi(batch.obs);
      zg = phi(batch.actor_goal);
    }
    std::vector<torch::Tensor> frozen_params = ParamsOf({dynamics.get()});
    frozen_params.push_back(alpha_raw);
    const Frozen frozen(frozen_params);
    q_pi = -Distance(PredictLatent(zs, mean.clamp(-1.0, 1.0)), zg);
  }
  if (info) {
    info->emplace_back("value", Item(value_loss));
    info->emplace_back("d_neg", Item(d_neg.mean()));
    info->emplace_back("d_pos", Item(d_pos.mean()));
    info->emplace_back("constraint", Item(constraint));
    info->emplace_back("lambda", Item(lambda));
    info->emplace_back("dyn", Item(dyn_loss));
  }
  const torch::Tensor actor_loss = DdpgBcLoss(q_pi, StdNormalLogProb(batch.action, mean), info);
  return value_loss + lambda_loss + dyn_loss + actor_loss;
}

torch::Tensor QrlAgent::Value(const torch::Tensor& obs, const torch::Tensor& action,
                              const torch::Tensor& goal) {
  const torch::Tensor q = -Distance(PredictLatent(phi(obs), action), phi(goal)).unsqueeze(-1);
  return torch::cat({q, q}, -1);
}

// --- CRL ----------------------------------------------------------------------

CrlAgent::CrlAgent(const MsprOptions& o) : GcActorAgent(o) {
  const BaselineOptions& b = o.baseline;
  phi1 = register_module("phi1", OgMlp(Sizes(obs_dim_ + action_dim_, b.latent_dim), false, true));
  phi2 = register_module("phi2", OgMlp(Sizes(obs_dim_ + action_dim_, b.latent_dim), false, true));
  psi1 = register_module("psi1", OgMlp(Sizes(obs_dim_, b.latent_dim), false, true));
  psi2 = register_module("psi2", OgMlp(Sizes(obs_dim_, b.latent_dim), false, true));
  RegisterActor();
}

torch::Tensor CrlAgent::PairLogits(int e, const torch::Tensor& obs, const torch::Tensor& action,
                                   const torch::Tensor& goal) {
  OgMlp& phi = e == 0 ? phi1 : phi2;
  OgMlp& psi = e == 0 ? psi1 : psi2;
  const double scale = std::sqrt(static_cast<double>(options_.baseline.latent_dim));
  const torch::Tensor x = phi(Cat(obs, action)), y = psi(goal);
  internal::AutocastOffScope off;  // the logits in fp32 under bf16 too
  return x.matmul(y.t()) / scale;
}

torch::Tensor CrlAgent::Loss(const TransitionBatch& batch, NamedValues* info) {
  const int64_t n = batch.obs.size(0);
  const torch::Tensor eye = torch::eye(n, batch.obs.options());
  torch::Tensor critic_loss = torch::zeros({}, batch.obs.options());
  torch::Tensor logits0;
  for (int e = 0; e < 2; ++e) {
    const torch::Tensor logits = PairLogits(e, batch.obs, batch.action, batch.value_goal);
    critic_loss = critic_loss + torch::binary_cross_entropy_with_logits(logits, eye) / 2.0;
    if (e == 0) logits0 = logits.detach();
  }
  const torch::Tensor mean = actor->Mean(Cat(batch.obs, batch.actor_goal));
  torch::Tensor q_pi;
  {
    const Frozen frozen(ParamsOf({phi1.get(), phi2.get(), psi1.get(), psi2.get()}));
    q_pi = std::get<0>(Value(batch.obs, mean.clamp(-1.0, 1.0), batch.actor_goal).min(-1));
  }
  if (info) {
    const torch::Tensor diag = logits0.diagonal();
    info->emplace_back("critic", Item(critic_loss));
    info->emplace_back("logits_pos", Item(diag.mean()));
    info->emplace_back("logits_neg",
                       n > 1 ? Item((logits0.sum() - diag.sum()) / (n * (n - 1))) : NAN);
    info->emplace_back("accuracy", Item((logits0.argmax(1) ==
                                         torch::arange(n, logits0.options().dtype(torch::kLong)))
                                            .to(torch::kFloat32)
                                            .mean()));
  }
  const torch::Tensor actor_loss = DdpgBcLoss(q_pi, StdNormalLogProb(batch.action, mean), info);
  return critic_loss + actor_loss;
}

torch::Tensor CrlAgent::Value(const torch::Tensor& obs, const torch::Tensor& action,
                              const torch::Tensor& goal) {
  const double scale = std::sqrt(static_cast<double>(options_.baseline.latent_dim));
  const torch::Tensor sa = Cat(obs, action);
  const torch::Tensor l1 = (phi1(sa) * psi1(goal)).sum(-1, true) / scale;
  const torch::Tensor l2 = (phi2(sa) * psi2(goal)).sum(-1, true) / scale;
  return torch::cat({l1, l2}, -1);
}

// --- HIQL ---------------------------------------------------------------------

HiqlAgent::HiqlAgent(const MsprOptions& o) : OgbenchAgent(o) {
  const BaselineOptions& b = o.baseline;
  // The observation's features: the state, or (pixels) a CNN's hidden features.
  const int64_t s_dim = pixels_ ? b.hidden : obs_dim_;
  const int64_t in_v = s_dim + b.rep_dim;
  goal_rep_enc = RegisterPairEncoder("goal_rep_enc");
  goal_rep = register_module("goal_rep", OgMlp(Sizes(pair_dim_, b.rep_dim), false, true));
  value_enc = RegisterPairEncoder("value_enc", 1);
  v1 = register_module("v1", OgMlp(Sizes(in_v, 1), false, true));
  v2 = register_module("v2", OgMlp(Sizes(in_v, 1), false, true));
  target_value_enc = RegisterPairEncoder("target_value_enc", 1);
  target_v1 = register_module("target_v1", OgMlp(Sizes(in_v, 1), false, true));
  target_v2 = register_module("target_v2", OgMlp(Sizes(in_v, 1), false, true));
  if (value_enc) InitTarget(*target_value_enc, *value_enc);
  InitTarget(*target_v1, *v1);
  InitTarget(*target_v2, *v2);
  low_actor_enc = RegisterPairEncoder("low_actor_enc", 1);
  low_actor = register_module("low_actor", GaussianActor(in_v, b.hidden, b.layers, action_dim_));
  high_actor_enc = RegisterPairEncoder("high_actor_enc");
  high_actor =
      register_module("high_actor", GaussianActor(pair_dim_, b.hidden, b.layers, b.rep_dim));
}

torch::Tensor HiqlAgent::GoalRep(const torch::Tensor& obs, const torch::Tensor& goal) {
  return LengthNormalize(goal_rep(Pair(goal_rep_enc, obs, goal)));
}

torch::Tensor HiqlAgent::V(const torch::Tensor& obs, const torch::Tensor& goal, bool target) {
  // The target heads (and, pixels, the target's CNN of s) on the online phi.
  const torch::Tensor x =
      Cat(Features(target ? target_value_enc : value_enc, obs), GoalRep(obs, goal));
  return target ? Twin(target_v1, target_v2, x) : Twin(v1, v2, x);
}

torch::Tensor HiqlAgent::Loss(const TransitionBatch& batch, NamedValues* info) {
  const BaselineOptions& b = options_.baseline;
  TORCH_CHECK(batch.low_goal.defined() && batch.high_goal.defined() && batch.high_target.defined(),
              "hiql: the batch has no subgoals (sample it with subgoal_steps > 0)");
  torch::Tensor next_target, target;
  {
    // The target heads on the online goal representation (OGBench shares phi).
    torch::NoGradGuard no_grad;
    next_target = V(batch.next_obs, batch.value_goal, true);
    target = V(batch.obs, batch.value_goal, true);
  }
  const torch::Tensor v = V(batch.obs, batch.value_goal, false);
  const torch::Tensor value_loss =
      TwinExpectileValueLoss(batch, next_target, target, v, b.expectile);

  torch::Tensor low_adv, high_adv, high_target_rep;
  {
    torch::NoGradGuard no_grad;
    low_adv = V(batch.next_obs, batch.low_goal, false).mean(-1) -
              V(batch.obs, batch.low_goal, false).mean(-1);
    high_adv = V(batch.high_target, batch.high_goal, false).mean(-1) -
               V(batch.obs, batch.high_goal, false).mean(-1);
    high_target_rep = GoalRep(batch.obs, batch.high_target);
  }
  torch::Tensor low_rep = GoalRep(batch.obs, batch.low_goal);
  if (!b.low_actor_rep_grad) low_rep = low_rep.detach();
  const torch::Tensor low_loss =
      -(AwrWeight(low_adv, b.low_alpha) *
        low_actor->LogProb(Cat(Features(low_actor_enc, batch.obs), low_rep), batch.action))
           .mean();
  const torch::Tensor high_loss =
      -(AwrWeight(high_adv, b.high_alpha) *
        high_actor->LogProb(Pair(high_actor_enc, batch.obs, batch.high_goal), high_target_rep))
           .mean();
  if (info) {
    info->emplace_back("value", Item(value_loss));
    info->emplace_back("v", Item(v.mean()));
    info->emplace_back("low_actor", Item(low_loss));
    info->emplace_back("high_actor", Item(high_loss));
    info->emplace_back("low_adv", Item(low_adv.mean()));
    info->emplace_back("high_adv", Item(high_adv.mean()));
  }
  return value_loss + low_loss + high_loss;
}

void HiqlAgent::UpdateTargets() {
  if (value_enc) Polyak(*target_value_enc, *value_enc);
  Polyak(*target_v1, *v1);
  Polyak(*target_v2, *v2);
}

std::vector<torch::nn::Module*> HiqlAgent::Targets() {
  std::vector<torch::nn::Module*> t{target_v1.get(), target_v2.get()};
  if (target_value_enc) t.push_back(target_value_enc.get());
  return t;
}

torch::Tensor HiqlAgent::Act(const torch::Tensor& obs, const torch::Tensor& goal) {
  const torch::Tensor z =
      LengthNormalize(ForActing(high_actor)->Mean(Pair(high_actor_enc, obs, goal)));
  return ForActing(low_actor)->Mean(Cat(Features(low_actor_enc, obs), z)).clamp(-1.0, 1.0);
}

torch::Tensor HiqlAgent::Value(const torch::Tensor& obs, const torch::Tensor&,
                               const torch::Tensor& goal) {
  return V(obs, goal, false);
}

}  // namespace core
}  // namespace msspr
