// Ms.PR's losses as free functions (mspr_losses.h): the representation loss
// (Eq. 1), the critic's n-step TD loss with its TD3 target (Eq. 2) and the
// TD3+BC actor loss (Eq. 3).
#include "msspr_core/mspr_losses.h"

#include <tuple>
#include <vector>

namespace msspr {
namespace core {
namespace mspr {

namespace {

torch::Tensor F32(const torch::Tensor& t) { return t.to(torch::kFloat32); }

torch::Tensor Huber(const torch::Tensor& diff, double delta) {
  const torch::Tensor a = diff.abs();
  return torch::where(a <= delta, 0.5 * diff * diff, delta * (a - 0.5 * delta));
}

// The latents of two states s1, s2 [B, ...] and their goal representations
// toward one goal g, from one encoder call and one goal-head call.
struct TwoStatesToGoal {
  torch::Tensor z;     // [2B, zs_dim]: s1's rows, then s2's
  torch::Tensor grep;  // [2B, goal_dim]
};
TwoStatesToGoal EncodeTwoStatesToGoal(RepresentationImpl& repr, const torch::Tensor& s1,
                                      const torch::Tensor& s2, const torch::Tensor& g) {
  const int64_t b = s1.size(0);
  const torch::Tensor z = repr.state_encoder->forward(torch::cat({s1, s2, g}, 0));
  const torch::Tensor zg = z.narrow(0, 2 * b, b);
  TwoStatesToGoal out;
  out.z = z.narrow(0, 0, 2 * b);
  out.grep = repr.goal_head->forward(out.z, torch::cat({zg, zg}, 0));
  return out;
}

// Per-step masked means summed over the steps: values and mask [H, B] -> [].
torch::Tensor SumOfMaskedMeans(const torch::Tensor& values, const torch::Tensor& mask) {
  return ((values * mask).sum(1) / mask.sum(1).clamp_min(1.0)).sum();
}

}  // namespace

torch::Tensor RepresentationLoss(const MsprOptions& options, RepresentationImpl& online,
                                 RepresentationImpl& target, const torch::Tensor& bins,
                                 const ChunkBatch& batch, LossInfo* info) {
  const RepresentationOptions& r = options.representation;
  const int64_t k = options.network.goal_horizon;
  const int64_t b = batch.states.size(0), l = batch.states.size(1);
  const int64_t horizon = batch.mc_return.size(1);
  auto& pred = online.predictors;
  // Terms with weight 0 (the ablations D, DI, DIR) are not computed; the goal
  // head is only needed by the reward and goal-level terms.
  const bool use_rew = r.weight_rew != 0, use_inv = r.weight_inv != 0;
  const bool use_gdyn = r.weight_goal_dyn != 0, use_gact = r.weight_goal_act != 0;
  const bool use_goal = use_rew || use_gdyn || use_gact;

  torch::Tensor targets;  // [B, L - 1, zs] target-encoder latents of s_1..s_{L-1}
  {
    torch::NoGradGuard no_grad;
    targets = F32(target.state_encoder->forward(batch.states.narrow(1, 1, l - 1).flatten(0, 1)))
                  .view({b, l - 1, -1});
  }
  // One encoder call for the chunk's first state and the goal.
  torch::Tensor z, zg;
  if (use_goal) {
    const torch::Tensor both =
        online.state_encoder->forward(torch::cat({batch.states.select(1, 0), batch.goal}, 0));
    z = both.narrow(0, 0, b);
    zg = both.narrow(0, b, b);
  } else {
    z = online.state_encoder->forward(batch.states.select(1, 0));
  }
  // The latent unroll is sequential: z^{h+1} = f_dyn(E_sa(z^h, a_h)).
  // Everything else is computed for all h at once on [H * B] rows.
  std::vector<torch::Tensor> zs_list{z}, zsa_list;
  for (int64_t h = 0; h < horizon; ++h) {
    zsa_list.push_back(online.Zsa(zs_list.back(), batch.actions.select(1, h)));
    zs_list.push_back(pred->Dynamics(zsa_list.back()));
  }
  const torch::Tensor z_h =
      torch::cat(std::vector<torch::Tensor>(zs_list.begin(), zs_list.end() - 1), 0);  // [H*B, zs]
  const torch::Tensor z_next =
      F32(torch::cat(std::vector<torch::Tensor>(zs_list.begin() + 1, zs_list.end()), 0));
  const torch::Tensor mask = batch.action_mask.narrow(1, 0, horizon).t();  // [H, B]
  const torch::Tensor target_next =
      targets.narrow(1, 0, horizon).transpose(0, 1).reshape({horizon * b, -1});

  const auto per_h = [&](const torch::Tensor& v) { return v.view({horizon, b}); };
  const torch::Tensor zero = torch::zeros({}, z_next.options());
  const torch::Tensor dyn = SumOfMaskedMeans(per_h((z_next - target_next).pow(2).mean(-1)), mask);
  torch::Tensor inv = zero, rew = zero, gdyn = zero, gact = zero;
  if (use_inv) {
    const torch::Tensor a_true =
        batch.actions.narrow(1, 0, horizon).transpose(0, 1).reshape({horizon * b, -1});
    inv = SumOfMaskedMeans(per_h((F32(pred->Inverse(z_h, target_next)) - a_true).pow(2).mean(-1)),
                           mask);
  }
  torch::Tensor grep;
  if (use_goal) grep = online.goal_head->forward(z_h, zg.repeat({horizon, 1}));  // [H*B, goal]
  if (use_rew) {
    const torch::Tensor logits = F32(pred->Reward(torch::cat(zsa_list, 0), grep));  // [H*B, bins]
    const torch::Tensor ret = batch.mc_return.t().reshape({horizon * b});
    torch::Tensor per;
    if (r.reward_loss == "mse") {
      per = (TwoHotDecode(logits, bins) - ret).pow(2);
    } else {
      const torch::Tensor two_hot =
          TwoHotEncode(ret, bins, -1.0 / (1.0 - options.agent.gamma), 0.0);
      per = -(two_hot * torch::log_softmax(logits, -1)).sum(-1);
    }
    // representation.reward_goals "trajectory": only goals ahead in the
    // chunk's own trajectory, whose Monte Carlo return is known, train f_rew.
    rew = SumOfMaskedMeans(per_h(per),
                           r.reward_goals == "trajectory" ? mask * batch.goal_ahead.t() : mask);
  }
  if (use_gdyn) {
    const torch::Tensor target_k =
        targets.narrow(1, k - 1, horizon).transpose(0, 1).reshape({horizon * b, -1});
    const torch::Tensor gd_mask = batch.state_mask.narrow(1, k, horizon).t();  // [H, B]
    gdyn = SumOfMaskedMeans(per_h((F32(pred->GoalDynamics(z_h, grep)) - target_k).pow(2).mean(-1)),
                            gd_mask);
  }
  if (use_gact) {
    std::vector<torch::Tensor> windows, masks;
    for (int64_t h = 0; h < horizon; ++h) {
      windows.push_back(batch.actions.narrow(1, h, k));    // [B, k, act]
      masks.push_back(batch.action_mask.narrow(1, h, k));  // [B, k]
    }
    const torch::Tensor ga_true = torch::cat(windows, 0);  // [H*B, k, act]
    const torch::Tensor ga_mask = torch::stack(masks, 0);  // [H, B, k]
    const torch::Tensor err =
        (F32(pred->GoalActions(z_h, grep)) - ga_true).pow(2).mean(-1).view({horizon, b, k});
    gact = ((err * ga_mask).sum({1, 2}) / ga_mask.sum({1, 2}).clamp_min(1.0)).sum();
  }
  const torch::Tensor total = r.weight_dyn * dyn + r.weight_rew * rew + r.weight_inv * inv +
                              r.weight_goal_dyn * gdyn + r.weight_goal_act * gact;
  if (info) {
    // One device-to-host copy (a sync on GPU) instead of one per term.
    const torch::Tensor host =
        torch::stack({dyn, rew, inv, gdyn, gact, total}).detach().to(torch::kCPU, torch::kFloat64);
    const double* v = host.data_ptr<double>();
    info->dyn = v[0];
    info->rew = v[1];
    info->inv = v[2];
    info->goal_dyn = v[3];
    info->goal_act = v[4];
    info->repr = v[5];
  }
  return total;
}

TransitionLatents EncodeTransitions(RepresentationImpl& repr, const TransitionBatch& batch) {
  // One call of the online encoder over observation, value goal and actor
  // goal (no gradient: actor and critic read the encoders detached).
  torch::NoGradGuard no_grad;
  const int64_t b = batch.obs.size(0);
  std::vector<torch::Tensor> inputs{batch.obs, batch.value_goal, batch.actor_goal};
  if (batch.high_goal.defined()) inputs.push_back(batch.high_goal);
  const torch::Tensor z = repr.state_encoder->forward(torch::cat(inputs, 0));
  TransitionLatents lat;
  lat.zs = z.narrow(0, 0, b);
  lat.z_value_goal = z.narrow(0, b, b);
  lat.z_actor_goal = z.narrow(0, 2 * b, b);
  if (batch.high_goal.defined()) lat.z_high_goal = z.narrow(0, 3 * b, b);
  return lat;
}

torch::Tensor CriticTarget(const AgentOptions& a, MsprNetworks& target,
                           const TransitionBatch& batch, const torch::Tensor& noise) {
  const int64_t b = batch.obs.size(0);
  torch::NoGradGuard no_grad;
  RepresentationImpl& repr = *target.repr;
  const torch::Tensor z =
      repr.state_encoder->forward(torch::cat({batch.next_obs, batch.value_goal}, 0));
  const torch::Tensor zs_next = z.narrow(0, 0, b), zg = z.narrow(0, b, b);
  const torch::Tensor grep_next = repr.goal_head->forward(zs_next, zg);
  const torch::Tensor eps = (noise.to(batch.ret.device()) * a.target_noise)
                                .clamp(-a.target_noise_clip, a.target_noise_clip);
  const torch::Tensor a_next =
      (F32(target.actor->forward(zs_next, grep_next, batch.next_obs, batch.value_goal)) + eps)
          .clamp(-1.0, 1.0);
  const torch::Tensor q_next =
      std::get<0>(F32(target.critic->forward(repr.Zsa(zs_next, a_next), grep_next, batch.next_obs,
                                             a_next, batch.value_goal))
                      .min(-1));
  torch::Tensor y = batch.ret + batch.discount * q_next;  // [B]
  if (a.clip_target) y = y.clamp(-1.0 / (1.0 - a.gamma), 0.0);
  return y;
}

namespace {

// min_j Q'_j(s, a) at the dataset's action, from the target critic.
torch::Tensor DataActionQ(MsprNetworks& target, const torch::Tensor& zs, const torch::Tensor& grep,
                          const TransitionBatch& batch) {
  return std::get<0>(F32(target.critic->forward(target.repr->Zsa(zs, batch.action), grep, batch.obs,
                                                batch.action, batch.value_goal))
                         .min(-1));
}

// E[|tau - 1(d < 0)| d^2], d = q_data - V(s, g) (gradient into V only).
torch::Tensor ExpectileLoss(const AgentOptions& a, ValueImpl& value, const torch::Tensor& zs,
                            const torch::Tensor& grep, const torch::Tensor& q_data,
                            const TransitionBatch& batch) {
  const torch::Tensor d = q_data - value.forward(zs, grep, batch.obs, batch.value_goal);
  const torch::Tensor w = torch::where(d < 0, 1.0 - a.expectile, a.expectile);
  return (w * d * d).mean();
}

}  // namespace

torch::Tensor ExpectileValueLoss(const AgentOptions& a, MsprNetworks& target, ValueImpl& value,
                                 const TransitionBatch& batch) {
  const int64_t b = batch.obs.size(0);
  torch::Tensor zs, grep, q_data;
  {
    torch::NoGradGuard no_grad;
    RepresentationImpl& repr = *target.repr;
    const torch::Tensor z =
        repr.state_encoder->forward(torch::cat({batch.obs, batch.value_goal}, 0));
    zs = z.narrow(0, 0, b);
    grep = repr.goal_head->forward(zs, z.narrow(0, b, b));
    q_data = DataActionQ(target, zs, grep, batch);
  }
  return ExpectileLoss(a, value, zs, grep, q_data, batch);
}

ExpectileTarget ExpectileCriticTarget(const AgentOptions& a, MsprNetworks& target, ValueImpl& value,
                                      const TransitionBatch& batch) {
  const int64_t b = batch.obs.size(0);
  torch::Tensor zs, zs_next, grep, grep_next, q_data;
  ExpectileTarget out;
  {
    torch::NoGradGuard no_grad;
    RepresentationImpl& repr = *target.repr;
    // One encoder call and one goal-head call for s and s'.
    const TwoStatesToGoal e =
        EncodeTwoStatesToGoal(repr, batch.obs, batch.next_obs, batch.value_goal);
    zs = e.z.narrow(0, 0, b);
    zs_next = e.z.narrow(0, b, b);
    grep = e.grep.narrow(0, 0, b);
    grep_next = e.grep.narrow(0, b, b);
    q_data = DataActionQ(target, zs, grep, batch);
    const torch::Tensor v_next =
        value.forward(zs_next, grep_next, batch.next_obs, batch.value_goal);
    out.y = batch.ret + batch.discount * v_next;
    if (a.clip_target) out.y = out.y.clamp(-1.0 / (1.0 - a.gamma), 0.0);
  }
  out.value_loss = ExpectileLoss(a, value, zs, grep, q_data, batch);
  return out;
}

torch::Tensor CriticLoss(const AgentOptions& a, MsprNetworks& online, const TransitionBatch& batch,
                         const TransitionLatents* lat, const torch::Tensor& y, LossInfo* info) {
  const int64_t b = batch.obs.size(0);
  RepresentationImpl& repr = *online.repr;
  torch::Tensor zsa, grep;
  if (lat) {
    torch::NoGradGuard no_grad;
    grep = repr.goal_head->forward(lat->zs, lat->z_value_goal);
    zsa = repr.Zsa(lat->zs, batch.action);
  } else {
    // The critic's gradient reaches the encoders (agent.critic_grad_to_encoder).
    const torch::Tensor z =
        repr.state_encoder->forward(torch::cat({batch.obs, batch.value_goal}, 0));
    grep = repr.goal_head->forward(z.narrow(0, 0, b), z.narrow(0, b, b));
    zsa = repr.Zsa(z.narrow(0, 0, b), batch.action);
  }
  const torch::Tensor q =
      F32(online.critic->forward(zsa, grep, batch.obs, batch.action, batch.value_goal));  // [B, 2]
  const torch::Tensor loss = Huber(q - y.unsqueeze(-1), a.huber_delta).mean(0).sum();
  if (info) {
    const torch::Tensor host =
        torch::stack({loss.detach(), q.detach().mean()}).to(torch::kCPU, torch::kFloat64);
    info->critic = host[0].item<double>();
    info->q_mean = host[1].item<double>();
  }
  return loss;
}

torch::Tensor ActorLoss(const AgentOptions& a, MsprNetworks& online, const TransitionBatch& batch,
                        const TransitionLatents& lat, LossInfo* info) {
  RepresentationImpl& repr = *online.repr;
  torch::Tensor grep;
  {
    torch::NoGradGuard no_grad;
    grep = repr.goal_head->forward(lat.zs, lat.z_actor_goal);
  }
  const torch::Tensor pi = F32(online.actor->forward(lat.zs, grep, batch.obs, batch.actor_goal));
  if (a.actor_loss == "awr") {
    // The weights: the critic's advantage of the dataset action over the actor's own.
    torch::Tensor weight;
    {
      torch::NoGradGuard no_grad;
      const torch::Tensor pi_now = pi.detach();
      auto q_of = [&](const torch::Tensor& act) {
        return std::get<0>(F32(online.critic->forward(repr.Zsa(lat.zs, act), grep, batch.obs, act,
                                                      batch.actor_goal))
                               .min(-1));  // [B]
      };
      const torch::Tensor adv = q_of(batch.action) - q_of(pi_now);
      weight = (a.awr_temperature * adv).exp().clamp_max(100.0);
    }
    const torch::Tensor sq = (pi - batch.action).pow(2).sum(-1);  // [B]
    const torch::Tensor loss = (weight * sq).mean();
    if (info) {
      const torch::Tensor host =
          torch::stack({loss.detach(), sq.detach().mean()}).to(torch::kCPU, torch::kFloat64);
      info->actor = host[0].item<double>();
      info->bc = host[1].item<double>();
    }
    return loss;
  }
  const torch::Tensor q = std::get<0>(
      F32(online.critic->forward(repr.Zsa(lat.zs, pi), grep, batch.obs, pi, batch.actor_goal))
          .min(-1));  // [B]
  const torch::Tensor scale = q.abs().mean().detach().clamp_min(1e-6);
  const torch::Tensor q_loss = -q.mean() / scale;
  const torch::Tensor bc = (pi - batch.action).pow(2).sum(-1).mean();
  const torch::Tensor loss = q_loss + a.bc_weight * bc;
  if (info) {
    const torch::Tensor host =
        torch::stack({loss.detach(), bc.detach()}).to(torch::kCPU, torch::kFloat64);
    info->actor = host[0].item<double>();
    info->bc = host[1].item<double>();
  }
  return loss;
}

torch::Tensor SubgoalLoss(const AgentOptions& a, MsprNetworks& online, MsprNetworks& target,
                          ValueImpl& value, const TransitionBatch& batch,
                          const TransitionLatents& lat, double* loss_out) {
  TORCH_CHECK(batch.high_goal.defined() && lat.z_high_goal.defined(),
              "SubgoalLoss: the batch has no subgoals (agent.subgoal_steps > 0 samples them)");
  const int64_t b = batch.obs.size(0);
  torch::Tensor weight, grep;
  {
    torch::NoGradGuard no_grad;
    // The target representation of s and s_sub toward g; V of both at once.
    const TwoStatesToGoal e =
        EncodeTwoStatesToGoal(*target.repr, batch.obs, batch.high_target, batch.high_goal);
    const torch::Tensor v =
        F32(value.forward(e.z, e.grep, torch::cat({batch.obs, batch.high_target}, 0),
                          torch::cat({batch.high_goal, batch.high_goal}, 0)));
    const torch::Tensor adv = v.narrow(0, b, b) - v.narrow(0, 0, b);
    weight = (a.subgoal_temperature * adv).exp().clamp_max(100.0);
    grep = online.repr->goal_head->forward(lat.zs, lat.z_high_goal);
  }
  const torch::Tensor pred = F32(online.subgoal->forward(lat.zs, grep, batch.obs, batch.high_goal));
  const torch::Tensor loss = (weight * (pred - batch.high_target).pow(2).mean(-1)).mean();
  if (loss_out) *loss_out = loss.detach().to(torch::kCPU, torch::kFloat64).item<double>();
  return loss;
}

}  // namespace mspr
}  // namespace core
}  // namespace msspr
