// Ms.PR's losses as functions of the networks and a batch, callable without
// a trainer: the representation loss (Eq. 1), the critic's n-step TD3 target
// and Huber loss (Eq. 2) and the TD3+BC actor loss (Eq. 3) of
// the paper. Each loss returns a scalar tensor with its graph and, when
// `info` is not null, fills its fields of it with one device-to-host read.
// Precision scopes, gradients and optimiser steps are the caller's
// (MsprAgent).
#pragma once

#include <torch/torch.h>

#include "msspr_core/batches.h"
#include "msspr_core/networks.h"
#include "msspr_core/options.h"

namespace msspr {
namespace core {

// One set of Ms.PR's networks: online, target or moving average.
struct MsprNetworks {
  Representation repr{nullptr};  // encoders, goal head, predictors
  Critic critic{nullptr};
  Actor actor{nullptr};
  SubgoalActor subgoal{nullptr};  // agent.subgoal_steps > 0 (no target copy)
};

namespace mspr {

// Online-encoder latents of a transition batch (no gradient), shared by the
// critic and the actor update of a step.
struct TransitionLatents {
  torch::Tensor zs, z_value_goal, z_actor_goal;  // [B, zs_dim]
  torch::Tensor z_high_goal;  // [B, zs_dim] when the batch has subgoals, else undefined
};

// One encoder call over observation, value goal, actor goal and (when the
// batch has subgoals) the subgoal actor's goal, without gradient.
TransitionLatents EncodeTransitions(RepresentationImpl& repr, const TransitionBatch& batch);

// Eq. 1: the latent unroll of `online.repr` over the chunk's actions against
// the target encoder's latents of the chunk's states (dynamics), plus the
// weighted reward (two-hot over `bins` or MSE), inverse-dynamics and
// goal-level terms of options.representation; terms of weight 0 are not
// computed. Fills info->repr, dyn, rew, inv, goal_dyn, goal_act.
torch::Tensor RepresentationLoss(const MsprOptions& options, RepresentationImpl& online,
                                 RepresentationImpl& target, const torch::Tensor& bins,
                                 const ChunkBatch& batch, LossInfo* info = nullptr);

// Eq. 2's TD target y = ret + discount * min_j Q'_j(s', pi'(s') + eps) [B]
// from the target networks only (no gradient); noise [B, action_dim] N(0, 1)
// draws, scaled by agent.target_noise and clipped here; clipped to
// [-1/(1-gamma), 0] with agent.clip_target.
torch::Tensor CriticTarget(const AgentOptions& agent, MsprNetworks& target,
                           const TransitionBatch& batch, const torch::Tensor& noise);

// The in-sample alternative to CriticTarget (agent.critic_target "expectile"),
// from the target representation and critic and the value network V:
//   y = ret + discount * V(s', g), clipped as CriticTarget's (no gradient);
//   value_loss = E[|tau - 1(d < 0)| d^2], d = min_j Q'_j(s, a) - V(s, g), with
// a the dataset's action (gradient into V only).
struct ExpectileTarget {
  torch::Tensor y;           // [B]
  torch::Tensor value_loss;  // []
};
ExpectileTarget ExpectileCriticTarget(const AgentOptions& agent, MsprNetworks& target,
                                      ValueImpl& value, const TransitionBatch& batch);
// ExpectileCriticTarget's value_loss alone, without the TD target (V beside
// the TD3 target, for the subgoal actor's advantage).
torch::Tensor ExpectileValueLoss(const AgentOptions& agent, MsprNetworks& target, ValueImpl& value,
                                 const TransitionBatch& batch);

// Eq. 2's loss: the Huber distance of both online Q heads to y, summed over
// the heads. lat: the batch's latents (the encoders get no gradient); null:
// encode here with gradient into the encoders (agent.critic_grad_to_encoder).
// Fills info->critic and q_mean.
torch::Tensor CriticLoss(const AgentOptions& agent, MsprNetworks& online,
                         const TransitionBatch& batch, const TransitionLatents* lat,
                         const torch::Tensor& y, LossInfo* info = nullptr);

// Eq. 3: -E[min_j Q_j(s, pi(s))] / sg(E|Q|) + bc_weight * E||pi(s) - a||^2,
// differentiated through the critic and E_sa (the caller updates the actor
// only). Fills info->actor and bc.
torch::Tensor ActorLoss(const AgentOptions& agent, MsprNetworks& online,
                        const TransitionBatch& batch, const TransitionLatents& lat,
                        LossInfo* info = nullptr);

// The subgoal actor's advantage-weighted regression (agent.subgoal_steps):
//   E[min(exp(subgoal_temperature * (V(s_sub, g) - V(s, g))), 100) *
//     mean_j (subgoal(s, g) - s_sub)_j^2]
// with g = batch.high_goal, s_sub = batch.high_target, V the value network on
// the target representation's latents (no gradient into V or the encoders).
// Fills *loss_out with the loss's value when not null.
torch::Tensor SubgoalLoss(const AgentOptions& agent, MsprNetworks& online, MsprNetworks& target,
                          ValueImpl& value, const TransitionBatch& batch,
                          const TransitionLatents& lat, double* loss_out = nullptr);

}  // namespace mspr
}  // namespace core
}  // namespace msspr
