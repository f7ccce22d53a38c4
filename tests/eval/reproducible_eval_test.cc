// The in-process evaluators give every episode the same outcome whatever the
// torch thread count and whatever the other episodes run beside it (the
// batch of each policy call): Policy::Act computes each episode's action on
// its own. Checked on the shipped antmaze-medium and cube-single checkpoints,
// episode by episode: success, steps and the final observation, bitwise.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <string>
#include <vector>

#include "msspr_core/policy.h"
#include "msspr_eval/ant_evaluator.h"
#include "msspr_eval/cube_evaluator.h"
#include "msspr_sim/package_files.h"

namespace msspr::agent {
namespace {

// Runs evaluate(policy, options) with `threads` torch threads.
template <class Options, class Evaluate>
TaskSuccessResult WithThreads(int threads, Evaluate evaluate, core::Policy& policy,
                              const Options& options) {
  const int before = torch::get_num_threads();
  torch::set_num_threads(threads);
  TaskSuccessResult r = evaluate(policy, options);
  torch::set_num_threads(before);
  return r;
}

// Expects episodes [a_first, a_first + n) of a to equal [b_first, b_first + n) of b.
void ExpectSameEpisodes(const TaskSuccessResult& a, size_t a_first, const TaskSuccessResult& b,
                        size_t b_first, size_t n, const std::string& what) {
  ASSERT_GE(a.episodes.size(), a_first + n) << what;
  ASSERT_GE(b.episodes.size(), b_first + n) << what;
  for (size_t k = 0; k < n; ++k) {
    const EpisodeResult &x = a.episodes[a_first + k], &y = b.episodes[b_first + k];
    EXPECT_EQ(x.success, y.success) << what << ", episode " << k;
    EXPECT_EQ(x.steps, y.steps) << what << ", episode " << k;
    ASSERT_FALSE(x.final_obs.empty()) << what << ", episode " << k;
    EXPECT_EQ(x.final_obs, y.final_obs) << what << ", episode " << k << ": final observations";
  }
}

core::Policy ShippedPolicy(const std::string& name) {
  return core::Policy::Load(sim::PackageFile("msspr_policy_node/checkpoints/" + name));
}

// 150 episodes side by side (every task x 30) for `short_steps` steps, then whole episodes
// of `full_tasks` x 3: the same at 1 and 2 threads.
template <class Options, class Evaluate>
void ExpectSameAtOneAndTwoThreads(Evaluate evaluate, core::Policy& policy, int short_steps,
                                  const std::vector<int>& full_tasks) {
  Options wide;
  wide.episodes = 30;
  wide.max_steps = short_steps;
  ExpectSameEpisodes(WithThreads(1, evaluate, policy, wide), 0,
                     WithThreads(2, evaluate, policy, wide), 0, 150,
                     "5 tasks x 30 episodes, " + std::to_string(short_steps) + " steps");
  Options full;  // whole episodes (up to the env's step limit)
  full.tasks = full_tasks;
  full.episodes = 3;
  const auto one = WithThreads(1, evaluate, policy, full);
  const auto two = WithThreads(2, evaluate, policy, full);
  ExpectSameEpisodes(one, 0, two, 0, 3 * full_tasks.size(), "whole episodes");
  EXPECT_EQ(one.success, two.success);
}

// Episode 0 of each of `alone_tasks` run on its own (a batch of one) equals the same episode
// among 150 (`short_steps` steps); and episode 0 of `full_task` alone equals it among 3,
// over a whole episode.
template <class Options, class Evaluate>
void ExpectSameAloneAsAmongOthers(Evaluate evaluate, core::Policy& policy, int short_steps,
                                  const std::vector<int>& alone_tasks, int full_task) {
  Options wide;
  wide.episodes = 30;
  wide.max_steps = short_steps;
  const auto among = WithThreads(1, evaluate, policy, wide);
  Options alone = wide;
  alone.episodes = 1;
  for (int task : alone_tasks) {
    alone.tasks = {task};
    ExpectSameEpisodes(
        among, static_cast<size_t>(task - 1) * 30, WithThreads(1, evaluate, policy, alone), 0, 1,
        "task " + std::to_string(task) + ", " + std::to_string(short_steps) + " steps");
  }
  Options full;
  full.tasks = {full_task};
  full.episodes = 3;
  const auto three = WithThreads(2, evaluate, policy, full);
  full.episodes = 1;
  ExpectSameEpisodes(three, 0, WithThreads(2, evaluate, policy, full), 0, 1,
                     "task " + std::to_string(full_task) + ", a whole episode");
}

TEST(ReproducibleEvaluation, AntEpisodesAreTheSameAtOneAndTwoThreads) {
  auto policy = ShippedPolicy("antmaze-medium-state.pt");
  ExpectSameAtOneAndTwoThreads<AntEvalOptions>(EvaluateOnAntMaze, policy, 40, {1, 3});
}

TEST(ReproducibleEvaluation, AntEpisodeIsTheSameAloneAsAmongOthers) {
  auto policy = ShippedPolicy("antmaze-medium-state.pt");
  ExpectSameAloneAsAmongOthers<AntEvalOptions>(EvaluateOnAntMaze, policy, 40, {2, 5}, 3);
}

TEST(ReproducibleEvaluation, CubeEpisodesAreTheSameAtOneAndTwoThreads) {
  auto policy = ShippedPolicy("cube-single-state.pt");
  ExpectSameAtOneAndTwoThreads<CubeEvalOptions>(EvaluateOnCube, policy, 20, {2});
}

TEST(ReproducibleEvaluation, CubeEpisodeIsTheSameAloneAsAmongOthers) {
  auto policy = ShippedPolicy("cube-single-state.pt");
  ExpectSameAloneAsAmongOthers<CubeEvalOptions>(EvaluateOnCube, policy, 20, {1, 4}, 2);
}

// The episodes run in groups (episodes_at_once, to bound the envs held at once): 50 episodes
// (5 tasks x 10, `steps` steps) in groups of 7 (the last of 1) give what they give all side by
// side, episode by episode; a group size below 1 is refused.
template <class Options, class Evaluate>
void ExpectSameInGroupsOfAnySize(Evaluate evaluate, core::Policy& policy, int steps) {
  Options all;
  all.episodes = 10;
  all.max_steps = steps;
  all.episodes_at_once = 50;
  Options groups = all;
  groups.episodes_at_once = 7;
  const auto a = evaluate(policy, all), b = evaluate(policy, groups);
  ExpectSameEpisodes(a, 0, b, 0, 50, "groups of 7 against 50 at once");
  EXPECT_EQ(a.success, b.success);
  groups.episodes_at_once = 0;
  EXPECT_THROW(evaluate(policy, groups), std::invalid_argument);
}

TEST(ReproducibleEvaluation, CubeEpisodesAreTheSameInGroupsOfAnySize) {
  auto policy = ShippedPolicy("cube-single-state.pt");
  ExpectSameInGroupsOfAnySize<CubeEvalOptions>(EvaluateOnCube, policy, 20);
}

TEST(ReproducibleEvaluation, AntEpisodesAreTheSameInGroupsOfAnySize) {
  auto policy = ShippedPolicy("antmaze-medium-state.pt");
  ExpectSameInGroupsOfAnySize<AntEvalOptions>(EvaluateOnAntMaze, policy, 40);
  AntEvalOptions bad;
  bad.tasks = {6};  // antmaze-medium has 5
  EXPECT_THROW(EvaluateOnAntMaze(policy, bad), std::invalid_argument);
}

}  // namespace
}  // namespace msspr::agent
