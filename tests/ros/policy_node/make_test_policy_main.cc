// msspr_make_test_policy: writes an untrained policy export (Trainer::ExportPolicy)
// for the policy node's rostests and bench, built from a small synthetic
// point-maze-like dataset (obs_dim 2, action_dim 2; 64x64 rgb8 images in pixels
// mode). Untrained weights serve bad-input tests and latency measurements: the
// network sizes, not the values, set the cost.
//
//   msspr_make_test_policy --observation-mode state|pixels --scale tiny|cpu --out FILE [--seed N]
//                          [--agent mspr|gcbc|gcivl|gciql|qrl|crl|hiql]  (baselines: state only)
#include <cstdlib>
#include <iostream>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "msspr_core/dataset.h"
#include "msspr_core/options.h"
#include "msspr_core/trainer.h"

namespace {

int Usage(const std::string& why) {
  std::cerr << "msspr_make_test_policy: " << why
            << "\nusage: msspr_make_test_policy --observation-mode state|pixels --scale tiny|cpu "
               "--out FILE "
               "[--seed N]"
               " [--agent NAME]\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string mode = "state", scale = "tiny", out, agent = "mspr";
  uint64_t seed = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) return Usage("missing value after " + a);
    const std::string v = argv[++i];
    if (a == "--observation-mode")
      mode = v;
    else if (a == "--scale")
      scale = v;
    else if (a == "--out")
      out = v;
    else if (a == "--agent")
      agent = v;
    else if (a == "--seed")
      seed = std::strtoull(v.c_str(), nullptr, 10);
    else
      return Usage("unknown option " + a);
  }
  if (out.empty()) return Usage("--out is required");
  if (mode != "state" && mode != "pixels")
    return Usage("--observation-mode must be state or pixels");
  if (scale != "tiny" && scale != "cpu") return Usage("--scale must be tiny or cpu");
  try {
    namespace core = msspr::core;
    core::MsprOptions o = core::MakePreset(agent, "cpu");
    o.network.obs_mode = mode;
    o.trainer.seed = seed;
    o.trainer.batch_size = 16;
    if (scale == "tiny") {
      core::NetworkOptions& n = o.network;
      n.encoder_hidden = n.zs_dim = n.zsa_hidden = n.zsa_dim = n.goal_hidden = 32;
      n.critic_hidden = n.actor_hidden = 32;
      n.za_dim = n.goal_dim = 16;
      o.baseline.hidden = o.baseline.latent_dim = 32;
      o.baseline.subgoal_steps = 5;
    }
    const bool pixels = mode == "pixels";
    const core::ImageShape shape = pixels ? core::ImageShape{64, 64, 3} : core::ImageShape{};
    core::DatasetBuilder builder(pixels ? 0 : 2, 2, shape);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<float> u(-1.f, 1.f);
    std::uniform_int_distribution<int> byte(0, 255);
    const int kEpisodes = 4, kLength = 40;
    for (int e = 0; e < kEpisodes; ++e) {
      std::vector<float> obs, act;
      std::vector<uint8_t> images;
      float x = 0, y = 0;
      for (int t = 0; t < kLength; ++t) {
        const float ax = u(rng), ay = u(rng);
        obs.insert(obs.end(), {x, y});
        act.insert(act.end(), {ax, ay});
        x += 0.2f * ax;
        y += 0.2f * ay;
        if (pixels)
          for (int64_t k = 0; k < shape.numel(); ++k)
            images.push_back(static_cast<uint8_t>(byte(rng)));
      }
      builder.AddEpisode(pixels ? std::vector<float>{} : obs, act, images);
    }
    auto data = std::make_shared<core::Dataset>(builder.Build());
    core::Trainer trainer(o, data);
    trainer.ExportPolicy(out);
    std::cout << "wrote untrained " << agent << " " << mode << " policy (" << scale << ") to "
              << out << "\n";
  } catch (const std::exception& e) {
    std::cerr << "msspr_make_test_policy: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
