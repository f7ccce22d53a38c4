// OGBench's baseline agents: losses on hand-made batches against values
// computed by hand or by an independent formula, where gradients flow,
// presets, the sampler's OGBench transitions, checkpoints and export, bf16
// steps and the policy's moving average.
#include "msspr_core/baselines.h"

#include <ATen/autocast_mode.h>
#include <gtest/gtest.h>
#include <torch/version.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <set>

#include "msspr_core/batch_sampler.h"
#include "msspr_core/checkpoint.h"
#include "msspr_core/trainer.h"
#include "point_square.h"
#include "test_util.h"
#include "torch_test_util.h"

namespace msspr {
namespace core {
namespace {

constexpr double kLog2Pi = 1.8378770664093453;

MsprOptions SmallOptions(const std::string& agent) {
  MsprOptions o = MakePreset(agent, "cpu");
  o.network.obs_dim = 2;
  o.network.action_dim = 2;
  o.baseline.hidden = 16;
  o.baseline.layers = 2;
  o.baseline.latent_dim = 16;
  o.baseline.iqe_dim = 4;
  o.baseline.rep_dim = 4;
  o.baseline.subgoal_steps = 3;
  o.trainer.batch_size = 8;
  o.trainer.seed = 3;
  return o;
}

// A hand-made batch of n transitions in 2-D: rows alternate success at the
// value goal (reward 0, discount 0) and not (reward -1, discount 0.99).
TransitionBatch HandBatch(int64_t n, uint64_t seed = 0) {
  torch::manual_seed(seed);
  TransitionBatch b;
  b.obs = torch::rand({n, 2}) * 2 - 1;
  b.action = torch::rand({n, 2}) * 2 - 1;
  b.next_obs = b.obs + 0.1 * b.action;
  b.value_goal = torch::rand({n, 2}) * 2 - 1;
  b.actor_goal = torch::rand({n, 2}) * 2 - 1;
  b.ret = torch::empty({n});
  b.discount = torch::empty({n});
  for (int64_t i = 0; i < n; ++i) {
    b.ret[i] = (i % 2 == 0) ? 0.0 : -1.0;
    b.discount[i] = (i % 2 == 0) ? 0.0 : 0.99;
  }
  b.low_goal = torch::rand({n, 2}) * 2 - 1;
  b.high_goal = torch::rand({n, 2}) * 2 - 1;
  b.high_target = torch::rand({n, 2}) * 2 - 1;
  return b;
}

// Makes an OgMlp with one output a constant c (final layer weights 0).
void MakeConstant(OgMlp& mlp, double c) {
  torch::NoGradGuard no_grad;
  auto* last = mlp->net->ptr(mlp->net->size() - 1)->as<torch::nn::Linear>();
  ASSERT_NE(last, nullptr);
  last->weight.zero_();
  last->bias.fill_(c);
}

// Twin value heads (online and target) made constant: head 1 is c1, head 2 is c2.
void MakeTwinConstant(OgMlp& v1, OgMlp& v2, OgMlp& target_v1, OgMlp& target_v2, double c1,
                      double c2) {
  MakeConstant(v1, c1);
  MakeConstant(v2, c2);
  MakeConstant(target_v1, c1);
  MakeConstant(target_v2, c2);
}

// OGBench's twin expectile value loss with constant heads c1, c2, by hand:
// q_i = r + d c_i; adv = r + d min(c) - (c1 + c2) / 2; weight tau when adv >= 0.
double TwinExpectileByHand(const TransitionBatch& b, double c1, double c2, double expectile) {
  const int64_t n = b.ret.size(0);
  double value = 0;
  for (int64_t i = 0; i < n; ++i) {
    const double r = b.ret[i].item<double>(), d = b.discount[i].item<double>();
    const double adv = r + d * std::min(c1, c2) - (c1 + c2) / 2;
    const double w = adv >= 0 ? expectile : 1 - expectile;
    value += w * (std::pow(r + d * c1 - c1, 2) + std::pow(r + d * c2 - c2, 2)) / n;
  }
  return value;
}

double Value(NamedValues& info, const std::string& name) {
  for (const auto& [k, v] : info)
    if (k == name) return v;
  ADD_FAILURE() << "no value named " << name;
  return NAN;
}

// Gaussian NLL with std 1, by hand: 0.5 ||a - mu||^2 + (D / 2) log(2 pi).
torch::Tensor Nll(const torch::Tensor& a, const torch::Tensor& mu) {
  return 0.5 * (a - mu).pow(2).sum(-1) + 0.5 * a.size(-1) * kLog2Pi;
}

// --- IQE ------------------------------------------------------------------------

// Union length of the intervals [x_j, y_j] with x_j < y_j, by merging sorted intervals.
double UnionLength(const std::vector<double>& x, const std::vector<double>& y) {
  std::vector<std::pair<double, double>> iv;
  for (size_t j = 0; j < x.size(); ++j)
    if (x[j] < y[j]) iv.emplace_back(x[j], y[j]);
  std::sort(iv.begin(), iv.end());
  double total = 0, lo = 0, hi = 0;
  bool open = false;
  for (const auto& [a, b] : iv) {
    if (!open || a > hi) {
      if (open) total += hi - lo;
      lo = a, hi = b, open = true;
    } else {
      hi = std::max(hi, b);
    }
  }
  if (open) total += hi - lo;
  return total;
}

TEST(IqeDistance, EqualsTheUnionOfIntervalsMixedByMeanAndMax) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> n01(0, 1);
  const int64_t b = 6, c = 3, k = 4;
  torch::Tensor x = torch::empty({b, c * k}, torch::kFloat64),
                y = torch::empty({b, c * k}, torch::kFloat64);
  for (int64_t i = 0; i < b * c * k; ++i) {
    x.view(-1)[i] = n01(rng);
    y.view(-1)[i] = n01(rng);
  }
  y[0].copy_(x[0]);  // no valid interval at all: distance 0
  const double alpha_raw = 0.3, a = 1.0 / (1.0 + std::exp(-alpha_raw));
  const torch::Tensor d = IqeDistance(x, y, k, torch::full({1}, alpha_raw, torch::kFloat64));
  ASSERT_EQ(d.sizes(), (std::vector<int64_t>{b}));
  for (int64_t i = 0; i < b; ++i) {
    double mean = 0, max = -1e9;
    for (int64_t comp = 0; comp < c; ++comp) {
      std::vector<double> xs(k), ys(k);
      for (int64_t j = 0; j < k; ++j) {
        xs[j] = x[i][comp * k + j].item<double>();
        ys[j] = y[i][comp * k + j].item<double>();
      }
      const double u = UnionLength(xs, ys);
      mean += u / c;
      max = std::max(max, u);
    }
    EXPECT_NEAR(d[i].item<double>(), a * mean + (1 - a) * max, 1e-12) << "row " << i;
  }
  EXPECT_EQ(d[0].item<double>(), 0.0);
}

TEST(IqeDistance, IsAQuasimetric) {
  torch::manual_seed(1);
  const torch::Tensor alpha = torch::zeros({1}, torch::kFloat64);
  const torch::Tensor x = torch::randn({200, 16}, torch::kFloat64),
                      y = torch::randn({200, 16}, torch::kFloat64),
                      z = torch::randn({200, 16}, torch::kFloat64);
  EXPECT_EQ(IqeDistance(x, x, 8, alpha).abs().max().item<double>(), 0.0);
  const torch::Tensor dxy = IqeDistance(x, y, 8, alpha), dyz = IqeDistance(y, z, 8, alpha),
                      dxz = IqeDistance(x, z, 8, alpha), dyx = IqeDistance(y, x, 8, alpha);
  EXPECT_GE(dxy.min().item<double>(), 0.0);
  EXPECT_LE((dxz - dxy - dyz).max().item<double>(), 1e-12);  // triangle inequality
  EXPECT_GT((dxy - dyx).abs().max().item<double>(), 1e-3);   // not symmetric
}

// --- Losses on hand-made batches ---------------------------------------------

TEST(BaselineLoss, GcbcIsTheGaussianNll) {
  auto agent = std::make_shared<GcbcAgent>(SmallOptions("gcbc"));
  const TransitionBatch b = HandBatch(8);
  NamedValues info;
  const double loss = agent->Loss(b, &info).item<double>();
  const torch::Tensor mu = agent->actor->Mean(torch::cat({b.obs, b.actor_goal}, -1));
  EXPECT_NEAR(loss, Nll(b.action, mu).mean().item<double>(), 1e-5);
  EXPECT_NEAR(Value(info, "actor"), loss, 1e-6);
  EXPECT_NEAR(Value(info, "mse"), (b.action - mu).pow(2).sum(-1).mean().item<double>(), 1e-5);
}

TEST(BaselineLoss, GcivlWithConstantHeads) {
  MsprOptions o = SmallOptions("gcivl");
  auto agent = std::make_shared<GcivlAgent>(o);
  const double c1 = -3.0, c2 = -5.0;
  MakeTwinConstant(agent->v1, agent->v2, agent->target_v1, agent->target_v2, c1, c2);
  const TransitionBatch b = HandBatch(8);
  NamedValues info;
  const double loss = agent->Loss(b, &info).item<double>();
  const double value = TwinExpectileByHand(b, c1, c2, 0.9);
  EXPECT_NEAR(Value(info, "value"), value, 1e-5);
  // Constant V: every advantage is 0, every AWR weight exp(0) = 1: the actor loss is the NLL.
  const torch::Tensor mu = agent->actor->Mean(torch::cat({b.obs, b.actor_goal}, -1));
  const double nll = Nll(b.action, mu).mean().item<double>();
  EXPECT_NEAR(Value(info, "adv"), 0.0, 1e-6);
  EXPECT_NEAR(Value(info, "actor"), nll, 1e-5);
  EXPECT_NEAR(loss, value + nll, 1e-4);
}

TEST(BaselineLoss, GciqlWithConstantHeads) {
  MsprOptions o = SmallOptions("gciql");
  auto agent = std::make_shared<GciqlAgent>(o);
  const double cv = -4.0, cq1 = -2.0, cq2 = -6.0, alpha = o.baseline.alpha;
  MakeConstant(agent->v, cv);
  MakeConstant(agent->q1, cq1);
  MakeConstant(agent->q2, cq2);
  MakeConstant(agent->target_q1, cq1);
  MakeConstant(agent->target_q2, cq2);
  const TransitionBatch b = HandBatch(8);
  NamedValues info;
  const double loss = agent->Loss(b, &info).item<double>();
  // Value: expectile 0.9 of min(Q) - V = -2 < 0: weight 0.1.
  const double value = 0.1 * std::pow(std::min(cq1, cq2) - cv, 2);
  double critic = 0;
  for (int i = 0; i < 8; ++i) {
    const double y = b.ret[i].item<double>() + b.discount[i].item<double>() * cv;
    critic += (std::pow(cq1 - y, 2) + std::pow(cq2 - y, 2)) / 8;
  }
  // DDPG+BC: q = min(Q) = -6 everywhere: -E[q] / (E|q| + 1e-6) = 6 / (6 + 1e-6).
  const torch::Tensor mu = agent->actor->Mean(torch::cat({b.obs, b.actor_goal}, -1));
  const double q_loss = 6.0 / (6.0 + 1e-6);
  const double bc = alpha * Nll(b.action, mu).mean().item<double>();
  EXPECT_NEAR(Value(info, "value"), value, 1e-5);
  EXPECT_NEAR(Value(info, "critic"), critic, 1e-4);
  EXPECT_NEAR(Value(info, "q_loss"), q_loss, 1e-6);
  EXPECT_NEAR(Value(info, "bc"), bc, 1e-6);
  EXPECT_NEAR(loss, value + critic + q_loss + bc, 1e-4);
}

TEST(BaselineLoss, CrlIsBinaryNceOverAllPairs) {
  auto agent = std::make_shared<CrlAgent>(SmallOptions("crl"));
  const TransitionBatch b = HandBatch(6);
  NamedValues info;
  agent->Loss(b, &info);
  // Independent formula: -[I log sigmoid(l) + (1 - I) log(1 - sigmoid(l))], averaged over
  // the 6 x 6 pairs and the two members.
  double expected = 0;
  for (int e = 0; e < 2; ++e) {
    const torch::Tensor l = agent->PairLogits(e, b.obs, b.action, b.value_goal).to(torch::kFloat64);
    const torch::Tensor p = 1.0 / (1.0 + torch::exp(-l));
    const torch::Tensor eye = torch::eye(6, torch::kFloat64);
    expected += -(eye * torch::log(p) + (1 - eye) * torch::log(1 - p)).mean().item<double>() / 2;
  }
  EXPECT_NEAR(Value(info, "critic"), expected, 1e-5);
  // The diagonal of the pair logits is the value of each row's own (s, a, g).
  const torch::Tensor v = agent->Value(b.obs, b.action, b.value_goal);
  EXPECT_TRUE(torch::allclose(
      v.select(-1, 0), agent->PairLogits(0, b.obs, b.action, b.value_goal).diagonal(), 1e-5, 1e-6));
  EXPECT_TRUE(torch::allclose(
      v.select(-1, 1), agent->PairLogits(1, b.obs, b.action, b.value_goal).diagonal(), 1e-5, 1e-6));
}

TEST(BaselineLoss, QrlLagrangianAndDynamics) {
  MsprOptions o = SmallOptions("qrl");
  auto agent = std::make_shared<QrlAgent>(o);
  {
    torch::NoGradGuard no_grad;
    agent->log_lambda.fill_(std::log(2.0));
  }
  const TransitionBatch b = HandBatch(8);
  NamedValues info;
  const torch::Tensor loss = agent->Loss(b, &info);
  // By formula from the agent's own distances.
  const torch::Tensor z = agent->phi(b.obs), zn = agent->phi(b.next_obs),
                      zg = agent->phi(b.value_goal);
  const torch::Tensor d_neg = agent->Distance(z, zg), d_pos = agent->Distance(z, zn);
  const double neg = (100.0 * torch::log1p(torch::exp(5.0 - d_neg / 100.0))).mean().item<double>();
  const double c = torch::relu(d_pos - 1).pow(2).mean().item<double>();
  EXPECT_NEAR(Value(info, "value"), neg + 2.0 * c, 1e-3);
  EXPECT_NEAR(Value(info, "constraint"), c, 1e-6);
  EXPECT_NEAR(Value(info, "lambda"), 2.0, 1e-6);
  const torch::Tensor zh = z + agent->dynamics(torch::cat({z, b.action}, -1));
  EXPECT_NEAR(Value(info, "dyn"),
              ((agent->Distance(zn, zh) + agent->Distance(zh, zn)) / 2).mean().item<double>(),
              1e-5);
  // d loss / d log_lambda = lambda (eps - C): lambda grows while the constraint is violated.
  agent->zero_grad();
  loss.backward();
  EXPECT_NEAR(agent->log_lambda.grad().item<double>(), 2.0 * (o.baseline.qrl_eps - c), 1e-5);
}

TEST(BaselineLoss, HiqlWithConstantHeads) {
  MsprOptions o = SmallOptions("hiql");
  auto agent = std::make_shared<HiqlAgent>(o);
  const double c1 = -3.0, c2 = -7.0;
  MakeTwinConstant(agent->v1, agent->v2, agent->target_v1, agent->target_v2, c1, c2);
  const TransitionBatch b = HandBatch(8);
  NamedValues info;
  agent->Loss(b, &info);
  EXPECT_NEAR(Value(info, "value"), TwinExpectileByHand(b, c1, c2, 0.7), 1e-5);  // expectile 0.7
  // Constant V: both advantages 0, weights 1: the actors' losses are their NLLs.
  const torch::Tensor low_in = torch::cat({b.obs, agent->GoalRep(b.obs, b.low_goal)}, -1);
  EXPECT_NEAR(Value(info, "low_actor"),
              Nll(b.action, agent->low_actor->Mean(low_in)).mean().item<double>(), 1e-4);
  const torch::Tensor z_star = agent->GoalRep(b.obs, b.high_target);
  const torch::Tensor high_mu = agent->high_actor->Mean(torch::cat({b.obs, b.high_goal}, -1));
  EXPECT_NEAR(Value(info, "high_actor"), Nll(z_star, high_mu).mean().item<double>(), 1e-4);
  // The subgoal representation has norm sqrt(rep_dim).
  EXPECT_TRUE(torch::allclose(z_star.norm(2, -1), torch::full({8}, 2.0), 1e-4, 1e-5));
}

// --- Where gradients flow ---------------------------------------------------------

// Gradients of the agent's summed loss on `b`, by parameter name.
std::map<std::string, torch::Tensor> Grads(GcAgentImpl& agent, const TransitionBatch& b) {
  agent.zero_grad();
  agent.Loss(b, nullptr).backward();
  std::map<std::string, torch::Tensor> g;
  for (const auto& p : agent.named_parameters()) {
    g[p.key()] =
        p.value().grad().defined() ? p.value().grad().clone() : torch::zeros_like(p.value());
  }
  return g;
}

bool StartsWithAny(const std::string& s, const std::vector<std::string>& prefixes) {
  for (const auto& p : prefixes)
    if (s.rfind(p, 0) == 0) return true;
  return false;
}

// Perturbing the `actors` changes no gradient outside them (no actor loss
// reaches the value networks), the targets get none, and every other
// parameter group except `no_grad` gets some.
void CheckGradientFlow(const std::string& name, const std::vector<std::string>& actors,
                       const std::vector<std::string>& no_grad = {}) {
  SCOPED_TRACE(name);
  MsprOptions o = SmallOptions(name);
  auto agent = MakeAgent(o);
  const TransitionBatch b = HandBatch(8, 1);
  const auto before = Grads(*agent, b);
  {
    torch::NoGradGuard guard;
    for (auto& p : agent->named_parameters())
      if (StartsWithAny(p.key(), actors)) p.value().add_(torch::randn_like(p.value()) * 0.5);
  }
  const auto after = Grads(*agent, b);
  bool actor_grad = false;
  for (const auto& [key, g] : before) {
    const bool is_actor = StartsWithAny(key, actors);
    if (is_actor) {
      actor_grad |= g.abs().sum().item<double>() > 0;
      continue;
    }
    EXPECT_TRUE(torch::allclose(g, after.at(key), 1e-5, 1e-7))
        << key << ": the actors' loss reaches it";
    if (key.rfind("target_", 0) == 0 || StartsWithAny(key, no_grad)) {
      EXPECT_EQ(g.abs().sum().item<double>(), 0.0) << key << " got a gradient";
    } else {
      EXPECT_GT(g.abs().sum().item<double>(), 0.0) << key << " got no gradient";
    }
  }
  EXPECT_TRUE(actor_grad);
}

TEST(BaselineGradients, GcivlActorLossStopsAtTheActor) { CheckGradientFlow("gcivl", {"actor."}); }
TEST(BaselineGradients, GciqlActorLossStopsAtTheActor) { CheckGradientFlow("gciql", {"actor."}); }
TEST(BaselineGradients, QrlActorLossStopsAtTheActor) { CheckGradientFlow("qrl", {"actor."}); }
TEST(BaselineGradients, CrlActorLossStopsAtTheActor) { CheckGradientFlow("crl", {"actor."}); }
TEST(BaselineGradients, HiqlActorsLeaveValueAndRepresentation) {
  CheckGradientFlow("hiql", {"low_actor.", "high_actor."});
}

TEST(BaselineGradients, HiqlLowActorTrainsTheRepresentationOnlyWhenAsked) {
  for (bool rep_grad : {false, true}) {
    MsprOptions o = SmallOptions("hiql");
    o.baseline.low_actor_rep_grad = rep_grad;
    auto agent = std::make_shared<HiqlAgent>(o);
    // Constant value heads: the value loss gives the representation no gradient.
    MakeTwinConstant(agent->v1, agent->v2, agent->target_v1, agent->target_v2, -1.0, -1.0);
    const auto g = Grads(*agent, HandBatch(8, 2));
    double rep = 0;
    for (const auto& [key, t] : g)
      if (key.rfind("goal_rep.", 0) == 0) rep += t.abs().sum().item<double>();
    if (rep_grad) {
      EXPECT_GT(rep, 0.0);
    } else {
      EXPECT_EQ(rep, 0.0);
    }
  }
}

// --- Presets, sampler, trainer, export ---------------------------------------------

TEST(BaselineOptions, PresetsFollowOgbenchPointmazeSettings) {
  const MsprOptions q = MakePreset("qrl", "paper");
  EXPECT_EQ(q.baseline.agent, "qrl");
  EXPECT_DOUBLE_EQ(q.relabel.value_p_randomgoal, 1.0);
  EXPECT_DOUBLE_EQ(q.baseline.alpha, 0.0003);
  EXPECT_EQ(q.baseline.hidden, 512);
  EXPECT_EQ(q.trainer.batch_size, 1024);
  const MsprOptions c = MakePreset("crl", "cpu");
  EXPECT_DOUBLE_EQ(c.relabel.value_p_trajgoal, 1.0);
  EXPECT_TRUE(c.relabel.value_geom_sample);
  EXPECT_EQ(c.baseline.hidden, 256);
  EXPECT_EQ(c.trainer.batch_size, 256);
  const MsprOptions h = MakePreset("hiql", "paper");
  EXPECT_DOUBLE_EQ(h.baseline.expectile, 0.7);
  EXPECT_EQ(h.baseline.subgoal_steps, 25);
  EXPECT_DOUBLE_EQ(MakePreset("gcivl", "paper").baseline.alpha, 10.0);
  EXPECT_DOUBLE_EQ(MakePreset("gciql", "paper").baseline.alpha, 0.003);
  EXPECT_DOUBLE_EQ(MakePreset("crl", "paper").baseline.alpha, 0.03);
  EXPECT_EQ(MakePreset("mspr", "paper").baseline.agent, "mspr");
  // The section round-trips through YAML.
  const MsprOptions back = ApplyOptionsYaml(OptionsToYaml(h), MsprOptions());
  EXPECT_EQ(OptionsToYaml(back), OptionsToYaml(h));
}

// Images are for the agents OGBench runs from pixels here (gcbc, gcivl,
// gciql, hiql), without a policy average; unknown agents are refused.
TEST(BaselineOptions, PixelsOnlyForImageAgentsAndUnknownAgentsAreRejected) {
  for (const char* agent : {"gcbc", "gcivl", "gciql", "hiql"}) {
    MsprOptions o = SmallOptions(agent);
    o.network.obs_mode = "pixels";
    EXPECT_NO_THROW(ValidateOptions(o)) << agent;
    o.trainer.policy_ema = 0.99;
    EXPECT_THROW(ValidateOptions(o), OptionsError) << agent;
  }
  for (const char* agent : {"qrl", "crl"}) {
    MsprOptions o = SmallOptions(agent);
    o.network.obs_mode = "pixels";
    try {
      ValidateOptions(o);
      FAIL() << agent << ": pixels accepted";
    } catch (const OptionsError& e) {
      EXPECT_NE(std::string(e.what()).find("images: gcbc, gcivl, gciql and hiql"),
                std::string::npos)
          << e.what();
    }
  }
  // One list decides, for the options and for the agent: AgentTakesImages.
  for (const std::string& agent : AgentNames()) {
    if (agent == "mspr") continue;
    MsprOptions o = SmallOptions(agent);
    o.network.obs_mode = "pixels";
    bool accepted = true;
    try {
      ValidateOptions(o);
    } catch (const OptionsError&) {
      accepted = false;
    }
    EXPECT_EQ(accepted, AgentTakesImages(agent)) << agent;
  }
  EXPECT_TRUE(AgentTakesImages("mspr"));
  EXPECT_FALSE(AgentTakesImages("sac"));
  MsprOptions o = SmallOptions("gcbc");
  o.baseline.agent = "sac";
  EXPECT_THROW(ValidateOptions(o), OptionsError);
  EXPECT_THROW(MakePreset("sac", "cpu"), OptionsError);
}

TEST(BaselineSampler, OgbenchTransitionsAndHiqlSubgoals) {
  // 20 trajectories of 30 steps.
  const int n = 600;
  std::vector<float> obs(n * 2), act(n * 2);
  for (int i = 0; i < n; ++i) obs[2 * i] = static_cast<float>(i);
  std::vector<uint8_t> term(n, 0);
  for (int i = 29; i < n; i += 30) term[i] = 1;
  const Dataset d = Dataset::FromArrays(obs, 2, {}, {}, act, 2, term);
  RelabelOptions r;
  r.actor_p_trajgoal = 0.5;
  r.actor_p_randomgoal = 0.5;
  const BatchSampler s(d, r, 0.99, 1, 1, 1);
  std::mt19937_64 rng(4);
  const int batch = 4000;
  const TransitionIndices b = s.SampleOgbenchTransitions(batch, rng, 5);
  int successes = 0, outside = 0;
  for (size_t k = 0; k < b.idx.size(); ++k) {
    const int64_t i = b.idx[k], end = d.trajectory_end(i);
    EXPECT_EQ(b.next_idx[k], i + 1);
    const bool success = b.value_goal[k] == i;
    successes += success;
    EXPECT_EQ(b.ret[k], success ? 0.0f : -1.0f);
    EXPECT_FLOAT_EQ(b.discount[k], success ? 0.0f : 0.99f);
    EXPECT_EQ(b.low_goal[k], std::min<int64_t>(i + 5, end));
    if (b.high_goal[k] > i && b.high_goal[k] <= end) {
      // A future state of the trajectory (or, rarely, a random goal landing there).
      EXPECT_TRUE(b.high_target[k] == std::min<int64_t>(i + 5, b.high_goal[k]) ||
                  b.high_target[k] == std::min<int64_t>(i + 5, end));
    } else {
      ++outside;  // a random goal: the target is the low-level one
      EXPECT_EQ(b.high_target[k], std::min<int64_t>(i + 5, end));
    }
  }
  // P(value goal = current state) = 0.2; half of the high goals are random, and a random
  // one lands in the future of the same trajectory with probability < 30 / 600.
  EXPECT_NEAR(successes / double(batch), 0.2, 0.02);
  EXPECT_NEAR(outside / double(batch), 0.5 * (1 - 15.0 / 600), 0.03);
}

class BaselineTrainer : public testing::TestWithParam<std::string> {};

// Two runs of `o`: 6 steps straight, and 3 steps, a checkpoint at `ckpt`,
// then 3 more steps in a trainer that loaded it.
struct StraightAndResumed {
  std::unique_ptr<Trainer> straight, resumed;
};
StraightAndResumed TrainStraightAndResumed(const MsprOptions& o,
                                           std::shared_ptr<const Dataset> data,
                                           const std::string& ckpt) {
  StraightAndResumed r;
  r.straight = std::make_unique<Trainer>(o, data);
  for (int i = 0; i < 6; ++i) r.straight->Step(false);
  Trainer first(o, data);
  for (int i = 0; i < 3; ++i) first.Step(false);
  first.SaveCheckpoint(ckpt);
  r.resumed = std::make_unique<Trainer>(o, data);
  r.resumed->LoadCheckpoint(ckpt);
  for (int i = 0; i < 3; ++i) r.resumed->Step(false);
  return r;
}

TEST_P(BaselineTrainer, ResumesExactlyAndExportsAPolicy) {
  torch::set_num_threads(1);
  MsprOptions o = SmallOptions(GetParam());
  o.network.obs_dim = 0;  // from the data
  o.network.action_dim = 0;
  o.trainer.steps = 6;
  o.trainer.log_every = 2;
  auto data = point_square::ExpertDataset(10, 20, 1);
  testing_util::TempDir dir;
  Trainer straight(o, data);
  for (int i = 0; i < 6; ++i) straight.Step(false);
  Trainer first(o, data);
  for (int i = 0; i < 3; ++i) first.Step(i == 2);
  first.SaveCheckpoint(dir.File("c.ckpt"));
  Trainer resumed(o, data);
  resumed.LoadCheckpoint(dir.File("c.ckpt"));
  EXPECT_EQ(resumed.step(), 3);
  for (int i = 0; i < 3; ++i) resumed.Step(false);
  const auto a = straight.agent()->named_parameters(), b = resumed.agent()->named_parameters();
  ASSERT_EQ(a.size(), b.size());
  for (const auto& p : a) EXPECT_TRUE(torch::equal(p.value(), b[p.key()])) << p.key();

  // A logged step reports the agent's named losses, all finite.
  const LossInfo info = resumed.Step(true);
  ASSERT_EQ(info.Named().size(), resumed.agent()->LossNames().size());
  for (const auto& [k, v] : info.Named()) EXPECT_TRUE(std::isfinite(v)) << k;

  // Export -> Policy::Load acts (and values) as the live agent.
  resumed.ExportPolicy(dir.File("p.pt"));
  Policy live = resumed.MakePolicy(), loaded = Policy::Load(dir.File("p.pt"));
  EXPECT_EQ(loaded.agent_name(), GetParam());
  const torch::Tensor s = torch::rand({5, 2}) * 2 - 1, g = torch::rand({5, 2}) * 2 - 1;
  const torch::Tensor act = loaded.Act(s, g);
  EXPECT_EQ(act.sizes(), (std::vector<int64_t>{5, 2}));
  EXPECT_LE(act.abs().max().item<double>(), 1.0);
  EXPECT_TRUE(torch::allclose(live.Act(s, g), act));
  EXPECT_EQ(loaded.Act(std::vector<float>{0.1f, 0.2f}, std::vector<float>{-0.5f, 0.5f}).size(), 2u);
  if (loaded.has_value()) {
    EXPECT_EQ(loaded.Q(s, act, g).sizes(), (std::vector<int64_t>{5, 2}));
    EXPECT_TRUE(torch::allclose(live.Q(s, act, g), loaded.Q(s, act, g)));
  } else {
    EXPECT_THROW(loaded.Q(s, act, g), std::logic_error);
  }
  // A checkpoint of another agent is refused, naming both.
  MsprOptions other = SmallOptions(GetParam() == "gcbc" ? "hiql" : "gcbc");
  other.network.obs_dim = other.network.action_dim = 0;
  Trainer wrong(other, data);
  try {
    wrong.LoadCheckpoint(dir.File("c.ckpt"));
    FAIL() << "loaded another agent's checkpoint";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("agent '" + GetParam() + "'"), std::string::npos)
        << e.what();
  }
}

// A run with bf16 and a policy average, interrupted by a checkpoint, ends
// with the uninterrupted run's weights, averages and exports, bit for bit.
TEST_P(BaselineTrainer, ResumesExactlyWithBf16AndAPolicyAverage) {
  torch::set_num_threads(1);
  MsprOptions o = SmallOptions(GetParam());
  o.network.obs_dim = 0;
  o.network.action_dim = 0;
  o.trainer.precision = "bf16";
  o.trainer.policy_ema = 0.9;
  auto data = point_square::ExpertDataset(10, 20, 1);
  testing_util::TempDir dir;
  StraightAndResumed runs = TrainStraightAndResumed(o, data, dir.File("c.ckpt"));
  Trainer &straight = *runs.straight, &resumed = *runs.resumed;
  const NamedModules a = straight.agent()->CheckpointModules(),
                     b = resumed.agent()->CheckpointModules();
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 1u);  // the agent and its averages
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].first, b[i].first);
    const auto pa = a[i].second->named_parameters(), pb = b[i].second->named_parameters();
    ASSERT_EQ(pa.size(), pb.size());
    for (const auto& p : pa) {
      EXPECT_TRUE(torch::equal(p.value(), pb[p.key()])) << a[i].first << "." << p.key();
    }
  }
  straight.ExportPolicy(dir.File("s.pt"));
  resumed.ExportPolicy(dir.File("r.pt"));
  const torch::Tensor s = torch::rand({5, 2}) * 2 - 1, g = torch::rand({5, 2}) * 2 - 1;
  EXPECT_TRUE(torch::equal(Policy::Load(dir.File("s.pt")).Act(s, g),
                           Policy::Load(dir.File("r.pt")).Act(s, g)));
  // The average is part of the run: a trainer without one refuses the checkpoint.
  MsprOptions plain = o;
  plain.trainer.policy_ema = 0;
  Trainer without(plain, data);
  try {
    without.LoadCheckpoint(dir.File("c.ckpt"));
    FAIL() << "an averaged run's checkpoint loaded into a trainer without the average";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("policy_ema"), std::string::npos) << e.what();
  }
}

// From images: each (observation, goal) network has its own encoder of the
// two images, the targets copy theirs; an interrupted run ends with the
// uninterrupted run's weights, and the export acts as the live agent.
class BaselinePixels : public testing::TestWithParam<std::string> {};

TEST_P(BaselinePixels, EncodersPerNetworkResumeExactlyAndExport) {
  torch::set_num_threads(1);
  MsprOptions o = SmallOptions(GetParam());
  o.network.obs_mode = "pixels";
  o.network.obs_dim = 0;
  o.network.action_dim = 0;
  o.network.cnn = "light";
  o.representation.augment_prob = 0.5;  // random shifts, drawn from the resumed stream too
  o.trainer.steps = 6;
  o.trainer.precision = "bf16";
  auto data = point_square::ExpertImageDataset(10, 20, 1);
  testing_util::TempDir dir;
  Trainer fresh(o, data);
  // The encoders: the actor's, and per value network one, with a target copy.
  std::set<std::string> encoders;
  for (const auto& c : fresh.agent()->named_children()) {
    if (c.value()->as<PairEncoderImpl>()) encoders.insert(c.key());
  }
  const std::map<std::string, std::set<std::string>> expected{
      {"gcbc", {"actor_enc"}},
      {"gcivl", {"actor_enc", "value_enc", "target_value_enc"}},
      {"gciql", {"actor_enc", "value_enc", "critic_enc", "target_critic_enc"}},
      // OGBench's visual HIQL: phi's CNN of [s; g], a CNN of s for V, its
      // target and the low actor, a CNN of [s; g] for the high actor.
      {"hiql",
       {"goal_rep_enc", "value_enc", "target_value_enc", "low_actor_enc", "high_actor_enc"}}};
  EXPECT_EQ(encoders, expected.at(GetParam()));
  for (torch::nn::Module* t : fresh.agent()->Targets()) {
    for (const auto& p : t->parameters()) EXPECT_FALSE(p.requires_grad());
  }
  StraightAndResumed runs = TrainStraightAndResumed(o, data, dir.File("c.ckpt"));
  Trainer &straight = *runs.straight, &resumed = *runs.resumed;
  const auto a = straight.agent()->named_parameters(), b = resumed.agent()->named_parameters();
  ASSERT_EQ(a.size(), b.size());
  for (const auto& p : a) EXPECT_TRUE(torch::equal(p.value(), b[p.key()])) << p.key();
  const LossInfo info = resumed.Step(true);
  for (const auto& [k, v] : info.Named()) EXPECT_TRUE(std::isfinite(v)) << k;

  resumed.ExportPolicy(dir.File("p.pt"));
  Policy live = resumed.MakePolicy(), loaded = Policy::Load(dir.File("p.pt"));
  EXPECT_EQ(loaded.agent_name(), GetParam());
  const float s0[2] = {0.3f, -0.2f}, g0[2] = {-0.6f, 0.5f};
  auto image = [](const float* p) {
    return torch::from_blob(point_square::Render(p).data(), {1, 16, 16, 3}, torch::kUInt8).clone();
  };
  const torch::Tensor act = loaded.Act(image(s0), image(g0));
  EXPECT_EQ(act.sizes(), (std::vector<int64_t>{1, 2}));
  EXPECT_TRUE(torch::equal(live.Act(image(s0), image(g0)), act));
}

INSTANTIATE_TEST_SUITE_P(Agents, BaselinePixels, testing::Values("gcbc", "gcivl", "gciql", "hiql"),
                         [](const testing::TestParamInfo<std::string>& info) {
                           return info.param;
                         });

INSTANTIATE_TEST_SUITE_P(Agents, BaselineTrainer,
                         testing::Values("gcbc", "gcivl", "gciql", "qrl", "crl", "hiql"),
                         [](const testing::TestParamInfo<std::string>& info) {
                           return info.param;
                         });

// --- bf16 -------------------------------------------------------------------------

using testing_util::CpuBf16Autocast;

// Whether every element of `x` is a bfloat16 number (as an output that came
// out of a bfloat16 layer is).
bool AllBf16Representable(const torch::Tensor& x) {
  return torch::equal(x.to(torch::kBFloat16).to(torch::kFloat32), x.to(torch::kFloat32));
}

// The value heads in return units (last layers set to -70.3 below) and the
// step's loss column that averages their output.
std::vector<OgMlp> ReturnHeads(OgbenchAgent& agent) {
  if (auto* a = dynamic_cast<GcivlAgent*>(&agent)) return {a->v1, a->v2};
  if (auto* a = dynamic_cast<GciqlAgent*>(&agent)) return {a->q1, a->q2};
  if (auto* a = dynamic_cast<HiqlAgent*>(&agent)) return {a->v1, a->v2};
  return {};
}

std::string ValueColumn(const std::string& agent) {
  if (agent == "gciql") return "q";
  if (agent == "qrl") return "d_neg";
  if (agent == "crl") return "logits_pos";
  return "v";  // gcivl, hiql
}

double RelativeError(const torch::Tensor& a, const torch::Tensor& b) {
  return ((a.to(torch::kFloat64) - b.to(torch::kFloat64)).norm() /
          b.to(torch::kFloat64).norm().clamp_min(1e-30))
      .item<double>();
}

// OgMlp under bf16 autocast (bfloat16 hidden products; its own GELU and
// LayerNorm on bfloat16 activations) gives the fp32 output and gradients
// within bfloat16 rounding: value-style (GELU + LayerNorm, fp32 output) and
// actor-style (GELU only, activated output).
TEST(OgMlpBf16, ForwardAndGradientsAreCloseToFp32) {
  torch::manual_seed(4);
  for (bool value_style : {true, false}) {
    SCOPED_TRACE(value_style ? "GELU + LayerNorm" : "GELU");
    OgMlp mlp(std::vector<int64_t>{6, 64, 64, value_style ? 1 : 64},
              /*activate_final=*/!value_style, /*layer_norm=*/value_style);
    const torch::Tensor x = torch::randn({32, 6}) * 2;
    const torch::Tensor r = torch::randn({32, value_style ? 1 : 64});
    auto run = [&](bool bf16, torch::Tensor* out) {
      mlp->zero_grad();
      torch::Tensor y;
      {
        std::optional<CpuBf16Autocast> autocast;
        if (bf16) autocast.emplace();
        y = mlp(x);
      }
      *out = y.detach();
      (y.to(torch::kFloat32) * r).sum().backward();
      std::vector<torch::Tensor> grads;
      for (const auto& p : mlp->parameters()) grads.push_back(p.grad().flatten().clone());
      return torch::cat(grads);
    };
    torch::Tensor y32, y16;
    const torch::Tensor g32 = run(false, &y32), g16 = run(true, &y16);
    EXPECT_EQ(y16.scalar_type(), value_style ? torch::kFloat32 : torch::kBFloat16);
    EXPECT_LT(RelativeError(y16, y32), 0.02);
    EXPECT_LT(RelativeError(g16, g32), 0.03);
    for (const auto& p : mlp->parameters()) EXPECT_EQ(p.grad().scalar_type(), torch::kFloat32);
  }
}

class BaselineBf16 : public testing::TestWithParam<std::string> {};

// A bf16 step: finite losses close to fp32's, fp32 master weights, weights
// that differ from the fp32 step's (the products did run in bfloat16), and
// value outputs at float32 resolution: in the step (its value column) and
// from Value under autocast. Returns near -70 keep their tenths where a
// bfloat16 output would round them to a multiple of 0.5.
TEST_P(BaselineBf16, StepIsFiniteAndValuesKeepFloat32Resolution) {
  torch::set_num_threads(1);
  const std::string name = GetParam();
  MsprOptions o = SmallOptions(name);
  o.network.obs_dim = 0;
  o.network.action_dim = 0;
  auto data = point_square::ExpertDataset(10, 20, 1);
  Trainer f32(o, data);
  o.trainer.precision = "bf16";
  Trainer b16(o, data);
  auto& agent = dynamic_cast<OgbenchAgent&>(*b16.agent());
  ASSERT_TRUE(torch::equal(testing_util::Flat(*f32.agent()), testing_util::Flat(agent)));
  const LossInfo a = f32.Step(true), b = b16.Step(true);
  ASSERT_EQ(a.agent.size(), b.agent.size());
  for (size_t i = 0; i < a.agent.size(); ++i) {
    const auto& [key, x] = a.agent[i];
    const double y = b.agent[i].second;
    EXPECT_TRUE(std::isfinite(y)) << key;
    if (key != "accuracy") {
      EXPECT_NEAR(x, y, 0.05 * std::abs(x) + 0.02) << key;
    }
  }
  for (const auto& p : agent.parameters()) EXPECT_EQ(p.scalar_type(), torch::kFloat32);
  EXPECT_FALSE(torch::equal(testing_util::Flat(*f32.agent()), testing_util::Flat(agent)));
  if (!agent.has_value()) return;  // gcbc

  const torch::Tensor s = torch::rand({16, 2}) * 2 - 1, g = torch::rand({16, 2}) * 2 - 1,
                      act = torch::rand({16, 2}) * 2 - 1;
  const std::vector<OgMlp> heads = ReturnHeads(agent);
  {
    torch::NoGradGuard no_grad;
    for (const OgMlp& h : heads) {
      auto* last = h->net->ptr(h->net->size() - 1)->as<torch::nn::Linear>();
      last->weight.mul_(1e-3);  // outputs within a few hundredths of the bias
      last->bias.fill_(-70.3);
    }
  }
  torch::Tensor v;
  {
    torch::NoGradGuard no_grad;
    CpuBf16Autocast autocast;
    v = agent.Value(s, act, g);
  }
  const torch::Tensor v32 = agent.Value(s, act, g).detach();
  EXPECT_EQ(v.scalar_type(), torch::kFloat32);
  EXPECT_FALSE(AllBf16Representable(v)) << v;
  // Within the hidden layers' bfloat16 error of the fp32 forward.
  EXPECT_LT((v - v32).abs().max().item<double>(), 0.05 * v32.abs().max().item<double>() + 0.01);
  if (!heads.empty()) {
    EXPECT_NEAR(v.mean().item<double>(), -70.3, 0.05);
    EXPECT_GT((v * 2.0 - (v * 2.0).round()).abs().max().item<double>(), 0.1);
  }
  // The step's own value outputs (its value column, a mean over the batch).
  const LossInfo c = b16.Step(true);
  double column = NAN;
  for (const auto& [key, x] : c.agent)
    if (key == ValueColumn(name)) column = x;
  ASSERT_TRUE(std::isfinite(column)) << ValueColumn(name);
  EXPECT_FALSE(AllBf16Representable(torch::full({1}, column, torch::kFloat32))) << column;
  if (!heads.empty()) {
    EXPECT_NEAR(column, -70.3, 0.05);
    EXPECT_GT(std::abs(column * 2 - std::round(column * 2)), 0.1) << column;
  }
}

INSTANTIATE_TEST_SUITE_P(Agents, BaselineBf16,
                         testing::Values("gcbc", "gcivl", "gciql", "qrl", "crl", "hiql"),
                         [](const testing::TestParamInfo<std::string>& info) {
                           return info.param;
                         });

// --- The policy's moving average ---------------------------------------------------

class BaselinePolicyAverage : public testing::TestWithParam<std::string> {};

// With trainer.policy_ema the acting networks' average after step s is
// d avg + (1 - d) w_s with d = min(ema, s / (s + 1)) (until then the plain
// mean of the initial weights and every step's); the export, the live policy
// and the trainer checkpoint act with it, the raw export with the online
// weights; the export's other networks are the online ones.
TEST_P(BaselinePolicyAverage, ExportsTheRunningAverageOfTheActingNetworks) {
  torch::set_num_threads(1);
  using testing_util::Flat;
  const std::string name = GetParam();
  MsprOptions o = SmallOptions(name);
  o.network.obs_dim = 0;
  o.network.action_dim = 0;
  o.trainer.policy_ema = 0.8;  // s / (s + 1) < 0.8 up to step 3: a plain mean, then the EMA
  auto data = point_square::ExpertDataset(10, 20, 1);
  Trainer t(o, data);
  auto& agent = dynamic_cast<OgbenchAgent&>(*t.agent());
  ASSERT_TRUE(agent.HasRawPolicy());
  const auto acting = agent.ActingNetworks();
  ASSERT_EQ(acting.size(), name == "hiql" ? 2u : 1u);
  auto all_acting = [&](bool average) {
    std::vector<torch::Tensor> parts;
    for (const auto& [key, net] : acting) {
      parts.push_back(average ? Flat(*agent.PolicyAverage(key)) : Flat(*net));
    }
    return torch::cat(parts);
  };
  const torch::Tensor w0 = all_acting(false).clone();
  EXPECT_TRUE(torch::equal(all_acting(true), w0));  // starts at the initial weights
  std::vector<torch::Tensor> seen{w0};
  torch::Tensor expected = w0.to(torch::kFloat64);
  for (int step = 1; step <= 7; ++step) {
    t.Step(false);
    const torch::Tensor w = all_acting(false).clone();
    EXPECT_FALSE(torch::equal(w, seen.back())) << "step " << step << " did not train the actors";
    seen.push_back(w);
    const double d = std::min(0.8, step / (step + 1.0));
    expected = d * expected + (1 - d) * w.to(torch::kFloat64);
    EXPECT_TRUE(torch::allclose(all_acting(true).to(torch::kFloat64), expected, 1e-5, 1e-7))
        << "step " << step;
    if (step == 3) {
      EXPECT_TRUE(torch::allclose(all_acting(true), torch::stack(seen).mean(0), 1e-5, 1e-7));
    }
  }
  EXPECT_FALSE(torch::allclose(all_acting(true), all_acting(false), 1e-4, 1e-6));

  testing_util::TempDir dir;
  t.ExportPolicy(dir.File("avg.pt"));
  t.ExportPolicy(dir.File("raw.pt"), /*raw=*/true);
  t.SaveCheckpoint(dir.File("end.ckpt"));
  Policy avg = Policy::Load(dir.File("avg.pt")), raw = Policy::Load(dir.File("raw.pt"));
  auto is_acting = [&](const std::string& key) {
    for (const auto& [n, net] : acting)
      if (key.rfind(n + ".", 0) == 0) return true;
    return false;
  };
  const auto live = agent.named_parameters();
  const auto avg_params = avg.agent()->named_parameters(),
             raw_params = raw.agent()->named_parameters();
  ASSERT_EQ(avg_params.size(), live.size());
  for (const auto& p : live) {
    EXPECT_TRUE(torch::equal(raw_params[p.key()], p.value())) << p.key();
    if (is_acting(p.key())) continue;
    EXPECT_TRUE(torch::equal(avg_params[p.key()], p.value())) << p.key();
  }
  for (const auto& [key, net] : acting) {
    const auto ema = agent.PolicyAverage(key)->named_parameters();
    for (const auto& p : ema) {
      EXPECT_TRUE(torch::equal(avg_params[key + "." + p.key()], p.value())) << key << p.key();
    }
  }
  const torch::Tensor s = torch::rand({6, 2}) * 2 - 1, g = torch::rand({6, 2}) * 2 - 1;
  const torch::Tensor a = t.MakePolicy().Act(s, g);
  EXPECT_TRUE(torch::equal(avg.Act(s, g), a));
  EXPECT_TRUE(torch::equal(Policy::Load(dir.File("end.ckpt")).Act(s, g), a));
  EXPECT_FALSE(torch::allclose(raw.Act(s, g), a, 1e-4, 1e-6));

  // Without the option: no average, one export.
  o.trainer.policy_ema = 0;
  Trainer plain(o, data);
  auto& plain_agent = dynamic_cast<OgbenchAgent&>(*plain.agent());
  EXPECT_FALSE(plain_agent.HasRawPolicy());
  EXPECT_FALSE(plain_agent.PolicyAverage(acting.front().first));
  EXPECT_EQ(plain_agent.CheckpointModules().size(), 1u);
}

INSTANTIATE_TEST_SUITE_P(Agents, BaselinePolicyAverage,
                         testing::Values("gcbc", "gcivl", "gciql", "qrl", "crl", "hiql"),
                         [](const testing::TestParamInfo<std::string>& info) {
                           return info.param;
                         });

}  // namespace
}  // namespace core
}  // namespace msspr
