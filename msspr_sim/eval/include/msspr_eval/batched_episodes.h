// The in-process evaluators' episode loop (maze_evaluator.cc, cube_evaluator.cc,
// ant_evaluator.cc): every episode in a slot, and at each step one policy call
// for the slots not yet done. Policy::Act computes each row on its own, so an
// episode's actions, and so its outcome, are the same whatever the other
// episodes beside it and the thread count (and the same as one observation at
// a time over ROS).
#pragma once

#include <torch/torch.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

#include "msspr_core/frame_stack.h"
#include "msspr_core/policy.h"

namespace msspr::agent {

// Steps `slots` (each with a bool `done`) for at most max_steps steps.
// inputs(active, &obs, &goal) writes the policy's inputs for the slots not done
// (std::vector<Slot*>, in order); apply(slot, action) steps one slot with its
// action (a float row of action_dim values, as the policy gave it) and updates
// slot.done. Runs in inference mode.
template <class Slot, class Inputs, class Apply>
void StepEpisodesBatched(core::Policy& policy, std::vector<Slot>& slots, int max_steps,
                         Inputs inputs, Apply apply) {
  torch::InferenceMode guard;
  for (int step = 0; step < max_steps; ++step) {
    std::vector<Slot*> active;
    for (auto& s : slots)
      if (!s.done) active.push_back(&s);
    if (active.empty()) return;
    torch::Tensor obs, goal;
    inputs(active, &obs, &goal);
    const torch::Tensor act = policy.Act(obs, goal).to(torch::kCPU).contiguous();
    auto a = act.accessor<float, 2>();
    for (size_t b = 0; b < active.size(); ++b) apply(*active[b], a[static_cast<int64_t>(b)]);
  }
}

// Runs `episodes` episodes of each of `tasks` (task by task) in groups of at most `at_once` side
// by side, in order: make(task, episode) returns that episode's slot, started (its env reset);
// StepEpisodesBatched steps the group; finish(slot) takes each outcome, in order, before the
// group's slots and envs are freed. An episode's outcome does not depend on its group (see
// StepEpisodesBatched).
template <class Slot, class Make, class Inputs, class Apply, class Finish>
void RunEpisodesInGroups(core::Policy& policy, const std::vector<int>& tasks, int episodes,
                         int at_once, int max_steps, Make make, Inputs inputs, Apply apply,
                         Finish finish) {
  const size_t per_task = static_cast<size_t>(std::max(episodes, 0));
  const size_t count = tasks.size() * per_task, group = static_cast<size_t>(std::max(at_once, 1));
  for (size_t first = 0; first < count; first += group) {
    const size_t last = std::min(count, first + group);
    std::vector<Slot> slots;
    slots.reserve(last - first);
    for (size_t k = first; k < last; ++k)
      slots.push_back(make(tasks[k / per_task], static_cast<int>(k % per_task)));
    StepEpisodesBatched(policy, slots, max_steps, inputs, apply);
    for (const Slot& s : slots) finish(s);
  }
}

// A state policy's inputs for `batch` (slots with `obs`, the current observation, and `env`,
// whose goal_observation() is the episode's goal): obs and goal [B, dim] float32.
template <class Slot>
void StateInputs(const std::vector<Slot*>& batch, int64_t dim, torch::Tensor* obs,
                 torch::Tensor* goal) {
  const int64_t b = static_cast<int64_t>(batch.size());
  *obs = torch::empty({b, dim}, torch::kFloat32);
  *goal = torch::empty({b, dim}, torch::kFloat32);
  for (int64_t k = 0; k < b; ++k) {
    std::copy(batch[k]->obs.begin(), batch[k]->obs.end(), (*obs)[k].data_ptr<float>());
    const auto& g = batch[k]->env->goal_observation();
    std::copy(g.begin(), g.end(), (*goal)[k].data_ptr<float>());
  }
}

// A pixels policy's inputs for `batch` (slots with `frames`, a running
// core::FrameStacker, and `goal_frames`, the goal's stacked image): obs and
// goal [B, S, S, 3 * stack] uint8 in the frame-stack layout of training.
template <class Slot>
void StackedImageInputs(const std::vector<Slot*>& batch, const core::FrameStacker& stacker,
                        int size, torch::Tensor* obs, torch::Tensor* goal) {
  const int64_t b = static_cast<int64_t>(batch.size()), c = 3 * stacker.stack();
  *obs = torch::empty({b, size, size, c}, torch::kUInt8);
  *goal = torch::empty({b, size, size, c}, torch::kUInt8);
  for (int64_t k = 0; k < b; ++k) {
    batch[k]->frames->Stacked((*obs)[k].data_ptr<uint8_t>());
    std::memcpy((*goal)[k].data_ptr<uint8_t>(), batch[k]->goal_frames.data(),
                stacker.stacked_bytes());
  }
}

}  // namespace msspr::agent
