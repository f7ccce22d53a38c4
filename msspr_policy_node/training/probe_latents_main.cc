// msspr_probe_latents: how much of the agent's position a trained encoder
// keeps. Encodes dataset observations (states or camera images) with a
// policy export's state encoder, fits a ridge regression from z_s to the
// recorded (x, y) on 80% of the samples and reports R^2 and the RMSE in
// metres on the other 20%, next to the same probe on a freshly initialised
// encoder of the same architecture (what the architecture gives for free).
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "bag_dataset.h"
#include "msspr_core/cli_args.h"
#include "msspr_core/networks.h"
#include "msspr_core/policy.h"

namespace {

constexpr const char* kUsage =
    "usage: msspr_probe_latents --policy POLICY.pt --data A.bag[,B.bag] [--samples N] [--seed S]\n"
    "                           [--split train|val] [--threads N]\n"
    "Fits a linear probe from the policy's state latent z_s to the recorded (x, y) and prints\n"
    "one JSON line: held-out R^2 and RMSE (m) for the trained encoder and for a fresh one.\n";

struct Probe {
  double r2_x = 0, r2_y = 0, rmse = 0;
};

// Ridge regression z -> xy on the first n_fit rows, scored on the rest.
Probe FitProbe(const torch::Tensor& z, const torch::Tensor& xy, int64_t n_fit) {
  const torch::Tensor ones = torch::ones({z.size(0), 1}, z.options());
  const torch::Tensor a = torch::cat({z, ones}, 1).to(torch::kFloat64);
  const torch::Tensor y = xy.to(torch::kFloat64);
  const torch::Tensor af = a.narrow(0, 0, n_fit), yf = y.narrow(0, 0, n_fit);
  const torch::Tensor gram = af.t().mm(af) + 1e-3 * torch::eye(a.size(1), a.options()) * n_fit;
  const torch::Tensor w = torch::linalg_solve(gram, af.t().mm(yf));
  const int64_t n_test = z.size(0) - n_fit;
  const torch::Tensor at = a.narrow(0, n_fit, n_test), yt = y.narrow(0, n_fit, n_test);
  const torch::Tensor err = at.mm(w) - yt;
  const torch::Tensor ss_res = err.pow(2).sum(0);
  const torch::Tensor ss_tot = (yt - yt.mean(0)).pow(2).sum(0);
  const torch::Tensor r2 = 1 - ss_res / ss_tot;
  Probe p;
  p.r2_x = r2[0].item<double>();
  p.r2_y = r2[1].item<double>();
  p.rmse = std::sqrt(err.pow(2).sum(1).mean().item<double>());
  return p;
}

std::string Json(const Probe& p) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "{\"r2_x\": %.4f, \"r2_y\": %.4f, \"rmse_m\": %.3f}", p.r2_x,
                p.r2_y, p.rmse);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  using msspr::cli::CliError;
  try {
    msspr::cli::CliArgs args(argc, argv, {"help"},
                             {"policy", "data", "samples", "seed", "split", "threads"});
    if (args.Has("help")) {
      std::cout << kUsage;
      return 0;
    }
    const std::string policy_path = args.Get("policy", ""), data = args.Get("data", "");
    if (policy_path.empty() || data.empty()) throw CliError("--policy and --data are required");
    const int64_t samples = args.GetInt("samples", 20000, 100, 10000000);
    const uint64_t seed = static_cast<uint64_t>(args.GetInt("seed", 0, 0));
    const std::string split = args.GetChoice("split", "val", {"train", "val"});
    const int threads = static_cast<int>(args.GetInt("threads", 0, 0, 4096));
    if (threads > 0) torch::set_num_threads(threads);

    msspr::core::Policy policy = msspr::core::Policy::Load(policy_path);
    msspr::agent::BagLoadOptions lo;
    lo.split = split;
    lo.images = policy.pixels();
    std::vector<std::string> bags;
    std::stringstream list(data);
    for (std::string b; std::getline(list, b, ',');)
      if (!b.empty()) bags.push_back(b);
    const msspr::core::Dataset d = msspr::agent::LoadBagDataset(bags, lo, nullptr);
    if (!d.has_states() || d.obs_dim() < 2)
      throw std::runtime_error(data + ": no (x, y) states to probe against");

    std::mt19937_64 rng(seed);
    std::vector<int64_t> idx(d.size());
    std::iota(idx.begin(), idx.end(), 0);
    std::shuffle(idx.begin(), idx.end(), rng);
    idx.resize(std::min<int64_t>(samples, d.size()));
    const int64_t n = static_cast<int64_t>(idx.size());
    torch::Tensor xy = torch::empty({n, 2});
    for (int64_t i = 0; i < n; ++i) {
      xy[i][0] = d.state(idx[i])[0];
      xy[i][1] = d.state(idx[i])[1];
    }
    torch::manual_seed(seed);
    msspr::core::StateEncoder fresh(policy.options().network);
    torch::NoGradGuard no_grad;
    policy.repr()->state_encoder->eval();
    auto encode = [&](msspr::core::StateEncoder& enc) {
      std::vector<torch::Tensor> parts;
      for (int64_t b = 0; b < n; b += 512) {
        const int64_t m = std::min<int64_t>(512, n - b);
        torch::Tensor obs;
        if (policy.pixels()) {
          const auto& s = d.image_shape();
          obs = torch::empty({m, s.height, s.width, s.channels}, torch::kUInt8);
          for (int64_t i = 0; i < m; ++i)
            std::memcpy(obs[i].data_ptr<uint8_t>(), d.image(idx[b + i]), s.numel());
        } else {
          obs = torch::empty({m, d.obs_dim()});
          for (int64_t i = 0; i < m; ++i)
            std::memcpy(obs[i].data_ptr<float>(), d.state(idx[b + i]), sizeof(float) * d.obs_dim());
        }
        parts.push_back(enc->forward(obs).to(torch::kFloat32));
      }
      return torch::cat(parts, 0);
    };
    const int64_t n_fit = n * 4 / 5;
    const Probe trained = FitProbe(encode(policy.repr()->state_encoder), xy, n_fit);
    const Probe untrained = FitProbe(encode(fresh), xy, n_fit);
    std::cout << "{\"policy\": \"" << policy_path << "\", \"samples\": " << n << ", \"split\": \""
              << split << "\", \"trained\": " << Json(trained)
              << ", \"fresh_encoder\": " << Json(untrained) << "}\n";
  } catch (const CliError& e) {
    std::cerr << "msspr_probe_latents: " << e.what() << "\n" << kUsage;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "msspr_probe_latents: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
