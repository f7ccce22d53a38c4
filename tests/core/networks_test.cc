#include "msspr_core/networks.h"

#include <ATen/autocast_mode.h>
#include <gtest/gtest.h>

#include <cmath>

#include "autocast_compat.h"
#include "bf16_weights.h"
#include "gelu_layer_norm.h"
#include "torch_test_util.h"

namespace msspr {
namespace core {
namespace {

NetworkOptions StateNet() {
  NetworkOptions n = testing_util::TinyOptions().network;
  n.obs_dim = 5;
  n.action_dim = 3;
  return n;
}

TEST(NetworksTest, MlpPreLayerNormPlacement) {
  torch::manual_seed(0);
  Mlp mlp(std::vector<int64_t>{4, 8, 8, 3}, /*output_gelu=*/false);
  EXPECT_EQ(mlp->LayerKinds(), (std::vector<std::string>{"Linear", "GELU", "LayerNorm", "Linear",
                                                         "GELU", "LayerNorm", "Linear"}));
  Mlp enc(std::vector<int64_t>{4, 8, 6}, /*output_gelu=*/true);
  EXPECT_EQ(enc->LayerKinds(),
            (std::vector<std::string>{"Linear", "GELU", "LayerNorm", "Linear", "GELU"}));
  Mlp plain(std::vector<int64_t>{4, 8, 6}, false, /*layer_norm=*/false);
  EXPECT_EQ(plain->LayerKinds(), (std::vector<std::string>{"Linear", "GELU", "Linear"}));
  // The LayerNorm's epsilon is the paper's 1e-6.
  auto ln = mlp->net->ptr(2)->as<torch::nn::LayerNorm>();
  ASSERT_NE(ln, nullptr);
  EXPECT_DOUBLE_EQ(ln->options.eps(), 1e-6);
  EXPECT_EQ(mlp->forward(torch::randn({7, 4})).sizes(), (std::vector<int64_t>{7, 3}));
}

using testing_util::CpuBf16Autocast;

double RelativeError(const torch::Tensor& a, const torch::Tensor& b) {
  return ((a.to(torch::kFloat64) - b.to(torch::kFloat64)).norm() /
          b.to(torch::kFloat64).norm().clamp_min(1e-30))
      .item<double>();
}

// Under bf16 autocast on the CPU, an Mlp's LayerNorms run as one bfloat16 op
// each way (statistics in fp32). It must give what the chain it replaces gives:
// cast the bfloat16 activation up, fp32 LayerNorm, cast down for the next
// Linear; outputs and every parameter's gradient, over more rows than one
// parallel chunk.
TEST(NetworksTest, Bf16LayerNormEqualsCastFp32LayerNormInValueAndGradient) {
  torch::manual_seed(0);
  Mlp mlp(std::vector<int64_t>{16, 256, 256, 8}, /*output_gelu=*/false);
  // Non-trivial affine parameters, so that their use and gradients count.
  {
    torch::NoGradGuard no_grad;
    for (auto& p : mlp->named_parameters()) {
      if (p.key().find("weight") != std::string::npos && p.value().dim() == 1)
        p.value().uniform_(0.5, 1.5);
      if (p.key().find("bias") != std::string::npos) p.value().uniform_(-0.2, 0.2);
    }
  }
  const torch::Tensor x = torch::randn({300, 16}) * 3.0;
  const torch::Tensor w_out = torch::randn({300, 8});
  auto run = [&](bool fused) {
    mlp->zero_grad();
    torch::Tensor y;
    {
      CpuBf16Autocast autocast;
      if (fused) {
        y = mlp->forward(x);
      } else {
        torch::Tensor h = x;
        for (auto& layer : *mlp->net) {
          if (layer.ptr()->as<torch::nn::LayerNorm>()) h = h.to(torch::kFloat32);
          h = layer.forward(h);
        }
        y = h;
      }
    }
    EXPECT_EQ(y.scalar_type(), torch::kBFloat16);
    (y.to(torch::kFloat32) * w_out).sum().backward();
    std::vector<torch::Tensor> grads;
    for (const auto& p : mlp->parameters()) grads.push_back(p.grad().clone());
    return std::make_pair(y.to(torch::kFloat32), grads);
  };
  const auto fused = run(true);
  const auto chain = run(false);
  EXPECT_LT(RelativeError(fused.first, chain.first), 5e-3);
  ASSERT_EQ(fused.second.size(), chain.second.size());
  for (size_t i = 0; i < fused.second.size(); ++i) {
    EXPECT_LT(RelativeError(fused.second[i], chain.second[i]), 2e-2) << "parameter " << i;
  }
  // And against fp32 throughout, within bfloat16's precision.
  const torch::Tensor y32 = mlp->forward(x);
  EXPECT_LT(RelativeError(fused.first, y32), 3e-2);
}

// Whether bfloat16 tensor a is `exact` (float64) rounded to bfloat16, to within
// one rounding: each element by at most one unit in the last place (or 1e-6:
// erf's approximation is absolute, so values under 1e-3 keep fewer bits), and at
// most 1% of the elements of magnitude 1e-3 or more differ from the rounded value.
void ExpectBf16WithinOneRounding(const torch::Tensor& a, const torch::Tensor& exact) {
  ASSERT_EQ(a.scalar_type(), torch::kBFloat16);
  const torch::Tensor fa = a.to(torch::kFloat64), rounded = exact.to(torch::kBFloat16);
  const torch::Tensor fr = rounded.to(torch::kFloat64);
  const torch::Tensor diff = (fa - fr).abs();
  const double ulp = 1.0 / 128.0;  // bfloat16 keeps 8 significant bits
  const torch::Tensor large = fr.abs().ge(1e-3);
  EXPECT_LE(diff.gt(0).logical_and(large).sum().item<double>(), 0.01 * large.sum().item<double>());
  EXPECT_TRUE(diff.le(fr.abs() * ulp + 1e-6).all().item<bool>())
      << "largest difference " << diff.max().item<double>();
}

// The bfloat16 GELU computes the exact GELU in fp32 and rounds once: its
// values and input gradients are the exact ones (float64) rounded to bfloat16.
TEST(NetworksTest, Bf16GeluIsTheExactGeluRoundedOnceInValueAndGradient) {
  torch::manual_seed(0);
  const torch::Tensor x =
      (torch::randn({5000}) * 3.0).to(torch::kBFloat16).detach().requires_grad_(true);
  const torch::Tensor dy = torch::randn({5000}).to(torch::kBFloat16);
  const torch::Tensor y = internal::GeluBf16(x);
  y.backward(dy);
  const torch::Tensor xd = x.detach().to(torch::kFloat64).requires_grad_(true);
  const torch::Tensor yd = torch::gelu(xd);
  yd.backward(dy.to(torch::kFloat64));
  ExpectBf16WithinOneRounding(y.detach(), yd.detach());
  ExpectBf16WithinOneRounding(x.grad(), xd.grad());
  // Far tails: GELU(-10) = -7.6e-23, GELU(10) = 10.
  const torch::Tensor tails =
      internal::GeluBf16(torch::tensor({-10.0f, 10.0f, 0.0f}).to(torch::kBFloat16));
  EXPECT_LT(std::fabs(tails.to(torch::kFloat32)[0].item<float>()), 1e-20f);
  EXPECT_EQ(tails.to(torch::kFloat32)[1].item<float>(), 10.0f);
  EXPECT_EQ(tails.to(torch::kFloat32)[2].item<float>(), 0.0f);
}

// GELU and the LayerNorm after it as one op give the two ops' values and
// gradients bit for bit, over more rows than one parallel chunk.
TEST(NetworksTest, Bf16GeluLayerNormEqualsGeluThenLayerNormBitForBit) {
  torch::manual_seed(0);
  const torch::Tensor x0 = (torch::randn({300, 256}) * 2.0).to(torch::kBFloat16);
  const torch::Tensor w0 = torch::rand({256}) + 0.5, b0 = torch::rand({256}) * 0.4 - 0.2;
  const torch::Tensor dy = torch::randn({300, 256}).to(torch::kBFloat16);
  auto run = [&](bool fused) {
    const torch::Tensor x = x0.clone().requires_grad_(true);
    const torch::Tensor w = w0.clone().requires_grad_(true), b = b0.clone().requires_grad_(true);
    const torch::Tensor y = fused ? internal::GeluLayerNormBf16(x, w, b, 1e-6)
                                  : internal::LayerNormBf16(internal::GeluBf16(x), w, b, 1e-6);
    y.backward(dy);
    return std::vector<torch::Tensor>{y.detach(), x.grad(), w.grad(), b.grad()};
  };
  const auto fused = run(true), chain = run(false);
  const char* names[] = {"output", "input gradient", "weight gradient", "bias gradient"};
  for (size_t i = 0; i < fused.size(); ++i)
    EXPECT_TRUE(torch::equal(fused[i], chain[i])) << names[i];
  EXPECT_EQ(fused[0].scalar_type(), torch::kBFloat16);
  EXPECT_EQ(fused[1].scalar_type(), torch::kBFloat16);
}

// In fp32 on the CPU, in training, GELU and the LayerNorm after it run as one op
// each way: LibTorch's torch::gelu then torch::layer_norm to within fp32
// rounding, in the output and in every gradient, over more rows than one
// parallel chunk; an Mlp built on them gives LibTorch's own layers' outputs and
// gradients; without a graph the Mlp is LibTorch's layers bit for bit.
TEST(NetworksTest, Fp32GeluLayerNormEqualsLibTorchsGeluThenLayerNormToFp32Rounding) {
  torch::manual_seed(0);
  const torch::Tensor x0 = torch::randn({300, 256}) * 2.0;
  const torch::Tensor w0 = torch::rand({256}) + 0.5, b0 = torch::rand({256}) * 0.4 - 0.2;
  const torch::Tensor dy = torch::randn({300, 256});
  auto run = [&](bool fused) {
    const torch::Tensor x = x0.clone().requires_grad_(true);
    const torch::Tensor w = w0.clone().requires_grad_(true), b = b0.clone().requires_grad_(true);
    const torch::Tensor y = fused ? internal::GeluLayerNormFp32(x, w, b, 1e-6)
                                  : torch::layer_norm(torch::gelu(x), {256}, w, b, 1e-6);
    y.backward(dy);
    return std::vector<torch::Tensor>{y.detach(), x.grad(), w.grad(), b.grad()};
  };
  const auto fused = run(true), torch_ops = run(false);
  const char* names[] = {"output", "input gradient", "weight gradient", "bias gradient"};
  for (size_t i = 0; i < fused.size(); ++i) {
    EXPECT_EQ(fused[i].scalar_type(), torch::kFloat32) << names[i];
    EXPECT_LT(RelativeError(fused[i], torch_ops[i]), 2e-6) << names[i];
  }
  // The GELU alone, and its gradient.
  const torch::Tensor x = x0.clone().requires_grad_(true), xt = x0.clone().requires_grad_(true);
  const torch::Tensor y = internal::GeluFp32(x), yt = torch::gelu(xt);
  y.backward(dy);
  yt.backward(dy);
  EXPECT_LT(RelativeError(y.detach(), yt.detach()), 2e-6);
  EXPECT_LT(RelativeError(x.grad(), xt.grad()), 2e-6);

  // A whole Mlp (Linear, GELU, LayerNorm, ..., GELU output) against its layers run
  // one by one as LibTorch's modules.
  Mlp mlp(std::vector<int64_t>{16, 256, 256, 8}, /*output_gelu=*/true);
  const torch::Tensor in = torch::randn({300, 16}) * 3.0, w_out = torch::randn({300, 8});
  auto grads_of = [&](bool ours) {
    mlp->zero_grad();
    torch::Tensor h = in;
    if (ours) {
      h = mlp->forward(in);
    } else {
      for (auto& layer : *mlp->net) h = layer.forward(h);
    }
    (h * w_out).sum().backward();
    std::vector<torch::Tensor> out{h.detach()};
    for (const auto& p : mlp->parameters()) out.push_back(p.grad().clone());
    return out;
  };
  const auto ours = grads_of(true), modules = grads_of(false);
  ASSERT_EQ(ours.size(), modules.size());
  for (size_t i = 0; i < ours.size(); ++i)
    EXPECT_LT(RelativeError(ours[i], modules[i]), 1e-5) << (i ? "a gradient" : "the output");
  EXPECT_THROW(internal::GeluLayerNormFp32(x0.to(torch::kBFloat16), w0, b0, 1e-6), c10::Error);
  // Without a graph (acting, evaluating) the Mlp runs LibTorch's own ops: bit for bit.
  torch::NoGradGuard no_grad;
  torch::Tensor h = in;
  for (auto& layer : *mlp->net) h = layer.forward(h);
  EXPECT_TRUE(torch::equal(mlp->forward(in), h));
}

// The bf16 weight cache: an Mlp under bf16 autocast gives autocast's own
// outputs and gradients bit for bit, casts each weight once while it is
// unchanged, and casts it again after an in-place update.
TEST(NetworksTest, Bf16WeightCacheMatchesAutocastAndRecastsAfterAnUpdate) {
  torch::manual_seed(0);
  Mlp mlp(std::vector<int64_t>{16, 64, 64, 8}, /*output_gelu=*/false);
  const torch::Tensor x = torch::randn({40, 16});
  internal::Bf16WeightCache cache;
  auto run = [&](bool cached) {
    mlp->zero_grad();
    torch::Tensor y;
    {
      CpuBf16Autocast autocast;
      internal::Bf16WeightCacheScope scope(cached ? &cache : nullptr);
      y = mlp->forward(x);
    }
    y.to(torch::kFloat32).sum().backward();
    std::vector<torch::Tensor> out{y.detach()};
    for (const auto& p : mlp->parameters()) out.push_back(p.grad().clone());
    return out;
  };
  auto expect_equal = [](const std::vector<torch::Tensor>& a, const std::vector<torch::Tensor>& b) {
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) EXPECT_TRUE(torch::equal(a[i], b[i])) << "tensor " << i;
  };
  const auto plain = run(false);
  const auto first = run(true);
  expect_equal(first, plain);
  EXPECT_EQ(cache.size(), 6u);  // three Linears' weights and biases
  // The second pass reuses the copies (and their graphs) and still matches.
  const torch::Tensor w0 = cache.Get(mlp->net->ptr(0)->as<torch::nn::Linear>()->weight);
  expect_equal(run(true), plain);
  EXPECT_TRUE(cache.Get(mlp->net->ptr(0)->as<torch::nn::Linear>()->weight).is_same(w0));
  // An in-place update (as an optimiser step makes) is seen.
  {
    torch::NoGradGuard no_grad;
    for (auto& p : mlp->parameters()) p.mul_(1.5);
  }
  const auto updated_plain = run(false);
  EXPECT_FALSE(torch::equal(updated_plain[0], plain[0]));
  expect_equal(run(true), updated_plain);
  // A copy cast without gradient mode is recast with a graph when one is needed.
  cache.Clear();
  {
    torch::NoGradGuard no_grad;
    CpuBf16Autocast autocast;
    internal::Bf16WeightCacheScope scope(&cache);
    mlp->forward(x);
  }
  expect_equal(run(true), updated_plain);
}

// Under bf16 autocast the critics' Q and the value network's V come out of
// a float32 last layer: a return near -70 keeps its hundredths, where a
// bfloat16 output would round it to a multiple of 0.5. The hidden layers stay
// in bfloat16, autocast is on again afterwards, and the gradient reaches the
// last layer in float32.
TEST(NetworksTest, Bf16ValueHeadsKeepFloat32Resolution) {
  torch::manual_seed(0);
  const NetworkOptions n = StateNet();
  const int64_t B = 8;
  Critic critic(n);
  Value value(n);
  const torch::Tensor zsa = torch::randn({B, n.zsa_dim}), grep = torch::randn({B, n.goal_dim});
  const torch::Tensor zs = torch::randn({B, n.zs_dim});
  auto last = [](Mlp& mlp) { return mlp->net->ptr(mlp->net->size() - 1)->as<torch::nn::Linear>(); };
  {
    torch::NoGradGuard no_grad;
    for (Mlp* m : {&critic->q1, &critic->q2, &value->v}) {
      last(*m)->weight.mul_(1e-3);  // outputs within a few hundredths of the bias
      last(*m)->bias.fill_(-70.3);
    }
  }
  torch::Tensor q, v, fp32_q;
  {
    CpuBf16Autocast autocast;
    q = critic->forward(zsa, grep);
    v = value->forward(zs, grep);
    EXPECT_TRUE(internal::CpuBf16Autocast());
    // A hidden layer under the same autocast still gives bfloat16.
    EXPECT_EQ(critic->q1->net->ptr(0)
                  ->as<torch::nn::Linear>()
                  ->forward(torch::cat({zsa, grep}, 1))
                  .scalar_type(),
              torch::kBFloat16);
  }
  fp32_q = critic->forward(zsa, grep);
  ASSERT_EQ(q.scalar_type(), torch::kFloat32);
  ASSERT_EQ(v.scalar_type(), torch::kFloat32);
  // Not multiples of 0.5 (bfloat16's spacing in [64, 128)), and within
  // bfloat16 hidden-layer error of the float32 forward.
  const torch::Tensor frac = (q * 2.0 - (q * 2.0).round()).abs();
  EXPECT_GT(frac.max().item<double>(), 0.01);
  EXPECT_LT((q - fp32_q).abs().max().item<double>(), 0.01);
  EXPECT_NEAR(v.mean().item<double>(), -70.3, 0.05);
  EXPECT_GT((v * 2.0 - (v * 2.0).round()).abs().max().item<double>(), 0.01);
  // Gradients reach the last layer.
  q.sum().backward();
  ASSERT_TRUE(last(critic->q1)->weight.grad().defined());
  EXPECT_EQ(last(critic->q1)->weight.grad().scalar_type(), torch::kFloat32);
  EXPECT_GT(last(critic->q1)->weight.grad().abs().sum().item<double>(), 0.0);
}

TEST(NetworksTest, StateModuleShapes) {
  torch::manual_seed(0);
  const NetworkOptions n = StateNet();
  const int64_t B = 6;
  Representation repr(n);
  const torch::Tensor obs = torch::randn({B, n.obs_dim});
  const torch::Tensor a = torch::rand({B, n.action_dim}) * 2 - 1;
  const torch::Tensor zs = repr->state_encoder->forward(obs);
  EXPECT_EQ(zs.sizes(), (std::vector<int64_t>{B, n.zs_dim}));
  const torch::Tensor grep = repr->goal_head->forward(zs, zs.flip(0));
  EXPECT_EQ(grep.sizes(), (std::vector<int64_t>{B, n.goal_dim}));
  const torch::Tensor za = repr->action_encoder->forward(a);
  EXPECT_EQ(za.sizes(), (std::vector<int64_t>{B, n.za_dim}));
  const torch::Tensor zsa = repr->sa_encoder->forward(zs, za);
  EXPECT_EQ(zsa.sizes(), (std::vector<int64_t>{B, n.zsa_dim}));
  EXPECT_TRUE(torch::equal(zsa, repr->Zsa(zs, a)));
  auto& p = repr->predictors;
  EXPECT_EQ(p->Dynamics(zsa).sizes(), (std::vector<int64_t>{B, n.zs_dim}));
  EXPECT_EQ(p->Reward(zsa, grep).sizes(), (std::vector<int64_t>{B, n.num_bins}));
  EXPECT_EQ(p->Inverse(zs, zs).sizes(), (std::vector<int64_t>{B, n.action_dim}));
  EXPECT_EQ(p->GoalDynamics(zs, grep).sizes(), (std::vector<int64_t>{B, n.zs_dim}));
  EXPECT_EQ(p->GoalActions(zs, grep).sizes(),
            (std::vector<int64_t>{B, n.goal_horizon, n.action_dim}));
  Critic critic(n);
  EXPECT_EQ(critic->forward(zsa, grep).sizes(), (std::vector<int64_t>{B, 2}));
  Actor actor(n);
  const torch::Tensor pi = actor->forward(zs, grep);
  EXPECT_EQ(pi.sizes(), (std::vector<int64_t>{B, n.action_dim}));
  EXPECT_LE(pi.abs().max().item<float>(), 1.0f);
}

TEST(NetworksTest, PolicyInputsRawReadsOnlyTheRawStateActionAndGoal) {
  torch::manual_seed(0);
  const int64_t B = 4;
  NetworkOptions n = StateNet();
  const torch::Tensor zsa = torch::randn({B, n.zsa_dim}), grep = torch::randn({B, n.goal_dim});
  const torch::Tensor zs = torch::randn({B, n.zs_dim});
  const torch::Tensor s = torch::randn({B, n.obs_dim}), g = torch::randn({B, n.obs_dim});
  const torch::Tensor a = torch::rand({B, n.action_dim}) * 2 - 1;
  n.policy_inputs = "raw";
  Critic raw_critic(n);
  Actor raw_actor(n);
  // First layers sized for [s, a, g] and [s, g].
  EXPECT_EQ(raw_critic->q1->net->ptr(0)->as<torch::nn::Linear>()->weight.size(1),
            2 * n.obs_dim + n.action_dim);
  EXPECT_EQ(raw_actor->backbone->net->ptr(0)->as<torch::nn::Linear>()->weight.size(1),
            2 * n.obs_dim);
  const torch::Tensor q = raw_critic->forward(zsa, grep, s, a, g);
  EXPECT_EQ(q.sizes(), (std::vector<int64_t>{B, 2}));
  // The latents are not read; the raw inputs are.
  EXPECT_TRUE(torch::equal(q, raw_critic->forward(zsa * 3 + 1, -grep, s, a, g)));
  EXPECT_FALSE(torch::allclose(q, raw_critic->forward(zsa, grep, s, a, g.flip(0))));
  const torch::Tensor pi = raw_actor->forward(zs, grep, s, g);
  EXPECT_TRUE(torch::equal(pi, raw_actor->forward(zs.flip(0), grep.flip(0), s, g)));
  EXPECT_THROW(raw_critic->forward(zsa, grep), c10::Error);  // raw inputs missing
  n.policy_inputs = "both";
  Critic both_critic(n);
  Actor both_actor(n);
  const torch::Tensor qb = both_critic->forward(zsa, grep, s, a, g);
  EXPECT_FALSE(torch::allclose(qb, both_critic->forward(zsa * 3 + 1, grep, s, a, g)));
  EXPECT_FALSE(torch::allclose(qb, both_critic->forward(zsa, grep, s, a, g.flip(0))));
  EXPECT_EQ(both_actor->forward(zs, grep, s, g).sizes(), (std::vector<int64_t>{B, n.action_dim}));
}

TEST(NetworksTest, PixelEncoderShapes) {
  torch::manual_seed(0);
  NetworkOptions n = StateNet();
  n.obs_mode = "pixels";
  n.frame_stack = 3;
  StateEncoder enc(n);
  ASSERT_TRUE(enc->cnn);
  const torch::Tensor img = torch::randint(0, 256, {2, 64, 64, 9}, torch::kUInt8);
  EXPECT_EQ(enc->forward(img).sizes(), (std::vector<int64_t>{2, n.zs_dim}));
  // 64x64 gives 8x8x32 = 2048 features before the projection.
  torch::Tensor x = img.permute({0, 3, 1, 2}).to(torch::kFloat32) / 255.0;
  x = enc->cnn->block3->forward(enc->cnn->block2->forward(enc->cnn->block1->forward(x)));
  EXPECT_EQ(x.sizes(), (std::vector<int64_t>{2, 32, 8, 8}));
  // Inputs are scaled by 1/255: an all-255 image equals a float image of ones.
  const torch::Tensor white = torch::full({1, 64, 64, 9}, 255, torch::kUInt8);
  torch::Tensor ones = torch::ones({1, 9, 64, 64});
  ones = enc->cnn->block3->forward(enc->cnn->block2->forward(enc->cnn->block1->forward(ones)));
  EXPECT_TRUE(torch::allclose(enc->forward(white), enc->cnn->fc->forward(ones.flatten(1))));
}

TEST(NetworksTest, LightCnnAndDownsampling) {
  torch::manual_seed(0);
  NetworkOptions n = StateNet();
  n.obs_mode = "pixels";
  n.cnn = "light";
  for (int ds : {1, 2, 4}) {
    n.image_downsample = ds;
    StateEncoder enc(n);
    ASSERT_TRUE(enc->light_cnn);
    ASSERT_FALSE(enc->cnn);
    const torch::Tensor img = torch::randint(0, 256, {3, 64, 64, 3}, torch::kUInt8);
    EXPECT_EQ(enc->forward(img).sizes(), (std::vector<int64_t>{3, n.zs_dim}));
    // Three stride-2 convolutions: (64 / ds / 8)^2 x 32 features.
    const int64_t side = 64 / ds / 8;
    EXPECT_EQ(enc->light_cnn->fc->net->ptr(0)->as<torch::nn::Linear>()->weight.size(1),
              32 * side * side);
    // Downsampling averages each ds x ds block of the image scaled to [0, 1].
    torch::Tensor x = img.permute({0, 3, 1, 2}).to(torch::kFloat32) / 255.0;
    x = x.view({3, 3, 64 / ds, ds, 64 / ds, ds}).mean({3, 5});
    EXPECT_TRUE(torch::allclose(enc->forward(img), enc->light_cnn->forward(x), 1e-5, 1e-6));
  }
  // The Impala CNN takes a downsampled image too.
  n.cnn = "impala";
  n.image_downsample = 2;
  StateEncoder impala(n);
  ASSERT_TRUE(impala->cnn);
  EXPECT_EQ(impala->forward(torch::zeros({1, 64, 64, 3}, torch::kUInt8)).sizes(),
            (std::vector<int64_t>{1, n.zs_dim}));
}

// network.cnn_feature_norm: the projection sees layer-normalised features, so
// scaling the CNN's last convolution (its features) leaves the latent alone.
TEST(NetworksTest, CnnFeatureNormMakesTheLatentScaleFree) {
  torch::manual_seed(2);
  NetworkOptions n = StateNet();
  n.obs_mode = "pixels";
  for (const char* cnn : {"light", "impala"}) {
    n.cnn = cnn;
    n.image_downsample = 2;
    n.cnn_feature_norm = true;
    StateEncoder enc(n);
    const torch::Tensor img = torch::randint(0, 256, {2, 64, 64, 3}, torch::kUInt8);
    const torch::Tensor z = enc->forward(img);
    EXPECT_EQ(z.sizes(), (std::vector<int64_t>{2, n.zs_dim})) << cnn;
    ASSERT_TRUE(
        static_cast<bool>(enc->light_cnn ? enc->light_cnn->feature_norm : enc->cnn->feature_norm))
        << cnn;
    if (!enc->light_cnn) continue;  // Impala: the shape and the norm are there
    {
      torch::NoGradGuard no_grad;
      // ReLU(7 (Wx + b)) = 7 ReLU(Wx + b): the features scale by 7.
      enc->light_cnn->conv3->weight.mul_(7.0);
      enc->light_cnn->conv3->bias.mul_(7.0);
    }
    const double normed_change = (enc->forward(img) - z).abs().max().item<double>();
    // Without it the same scaling moves the latent.
    n.cnn_feature_norm = false;
    StateEncoder plain(n);
    const torch::Tensor z0 = plain->forward(img);
    {
      torch::NoGradGuard no_grad;
      plain->light_cnn->conv3->weight.mul_(7.0);
      plain->light_cnn->conv3->bias.mul_(7.0);
    }
    const double plain_change = (plain->forward(img) - z0).abs().max().item<double>();
    // Only LayerNorm's epsilon keeps the normalised one from exactly 0.
    EXPECT_LT(normed_change, 0.02 * plain_change);
    EXPECT_GT(plain_change, 0.05);
    n.cnn_feature_norm = true;
  }
}

TEST(NetworksTest, GoalVectorsHaveNormSqrtDim) {
  torch::manual_seed(1);
  const NetworkOptions n = StateNet();
  GoalHead psi(n);
  const torch::Tensor g =
      psi->forward(torch::randn({10, n.zs_dim}) * 5, torch::randn({10, n.zs_dim}));
  const torch::Tensor norms = g.norm(2, -1);
  EXPECT_TRUE(torch::allclose(norms, torch::full({10}, std::sqrt(double(n.goal_dim))), 1e-5, 1e-5));
}

TEST(NetworksTest, TwoHotRoundTrip) {
  const double gamma = 0.99;
  const torch::Tensor bins = ReturnBins(21, gamma);
  EXPECT_FLOAT_EQ(bins[0].item<float>(), -100.0f);
  EXPECT_FLOAT_EQ(bins[20].item<float>(), 0.0f);
  const torch::Tensor values = torch::tensor({-100.0f, -99.9f, -37.3f, -5.0f, -0.01f, 0.0f});
  const torch::Tensor enc = TwoHotEncode(values, bins);
  EXPECT_TRUE(torch::allclose(enc.sum(-1), torch::ones({6})));
  EXPECT_LE((enc > 0).sum(-1).max().item<int64_t>(), 2);
  // Expected value of the two-hot distribution is the value itself.
  EXPECT_TRUE(torch::allclose((enc * bins).sum(-1), values, 1e-4, 1e-4));
  // Decoding logits that put exactly that distribution back.
  const torch::Tensor decoded = TwoHotDecode(torch::log(enc + 1e-30), bins);
  EXPECT_TRUE(torch::allclose(decoded, values, 1e-3, 1e-3));
  // Out of range values clamp to the end bins.
  const torch::Tensor clamped = TwoHotEncode(torch::tensor({-500.0f, 3.0f}), bins);
  EXPECT_FLOAT_EQ(clamped[0][0].item<float>(), 1.0f);
  EXPECT_FLOAT_EQ(clamped[1][20].item<float>(), 1.0f);
}

TEST(NetworksTest, StableCheckpointKeys) {
  Representation repr(StateNet());
  std::vector<std::string> keys;
  for (const auto& kv : repr->named_parameters()) keys.push_back(kv.key());
  for (const char* k :
       {"state_encoder.mlp.net.0.weight", "goal_head.mlp.net.2.weight",
        "action_encoder.linear.weight", "sa_encoder.mlp.net.0.weight", "predictors.dynamics.weight",
        "predictors.reward.bias", "predictors.inverse.weight", "predictors.goal_dynamics.weight",
        "predictors.goal_action.weight"}) {
    EXPECT_NE(std::find(keys.begin(), keys.end(), k), keys.end()) << k;
  }
  Critic critic(StateNet());
  EXPECT_TRUE(critic->named_parameters().contains("q1.net.0.weight"));
  EXPECT_TRUE(critic->named_parameters().contains("q2.net.9.bias"));
  Actor actor(StateNet());
  EXPECT_TRUE(actor->named_parameters().contains("backbone.net.0.weight"));
  EXPECT_TRUE(actor->named_parameters().contains("head.weight"));
}

TEST(NetworksTest, HardUpdateCopies) {
  torch::manual_seed(0);
  Critic a(StateNet()), b(StateNet());
  EXPECT_FALSE(torch::equal(testing_util::Flat(*a), testing_util::Flat(*b)));
  HardUpdate(*b, *a);
  EXPECT_TRUE(torch::equal(testing_util::Flat(*a), testing_util::Flat(*b)));
}

}  // namespace
}  // namespace core
}  // namespace msspr
