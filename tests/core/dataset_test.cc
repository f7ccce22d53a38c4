#include "msspr_core/dataset.h"

#include <gtest/gtest.h>

#include <vector>

namespace msspr {
namespace core {
namespace {

// Episode e of length T: state (e, t), action (t, -t).
void AddSimpleEpisode(DatasetBuilder* b, int e, int T) {
  std::vector<float> obs(2 * T), act(2 * T);
  for (int t = 0; t < T; ++t) {
    obs[2 * t] = static_cast<float>(e);
    obs[2 * t + 1] = static_cast<float>(t);
    act[2 * t] = static_cast<float>(t);
    act[2 * t + 1] = static_cast<float>(-t);
  }
  b->AddEpisode(obs, act);
}

TEST(DatasetTest, BuilderKeepsTrajectoryBoundaries) {
  DatasetBuilder b(2, 2);
  b.Reserve(12);
  AddSimpleEpisode(&b, 0, 4);
  AddSimpleEpisode(&b, 1, 1);
  AddSimpleEpisode(&b, 2, 7);
  EXPECT_EQ(b.num_episodes(), 3);
  const Dataset d = b.Build();
  EXPECT_EQ(b.size(), 0);
  ASSERT_EQ(d.size(), 12);
  EXPECT_EQ(d.num_trajectories(), 3);
  EXPECT_EQ(d.obs_dim(), 2);
  EXPECT_EQ(d.action_dim(), 2);
  EXPECT_FALSE(d.has_images());
  EXPECT_EQ(d.trajectory_starts(), (std::vector<int64_t>{0, 4, 5}));
  EXPECT_EQ(d.trajectory_ends(), (std::vector<int64_t>{3, 4, 11}));
  EXPECT_EQ(d.trajectory_start(2), 0);
  EXPECT_EQ(d.trajectory_end(2), 3);
  EXPECT_EQ(d.trajectory_of(4), 1);
  EXPECT_EQ(d.trajectory_end(8), 11);
  // Valid transition starts: all but each trajectory's last step.
  EXPECT_EQ(d.valid_indices(), (std::vector<int64_t>{0, 1, 2, 5, 6, 7, 8, 9, 10}));
  EXPECT_EQ(d.terminals(), (std::vector<uint8_t>{0, 0, 0, 1, 1, 0, 0, 0, 0, 0, 0, 1}));
  EXPECT_FLOAT_EQ(d.state(6)[0], 2.0f);
  EXPECT_FLOAT_EQ(d.state(6)[1], 1.0f);
  EXPECT_FLOAT_EQ(d.action(7)[1], -2.0f);
  std::vector<int64_t> idx{3, 9};
  std::vector<float> out(4);
  d.GatherStates(idx.data(), 2, out.data());
  EXPECT_EQ(out, (std::vector<float>{0, 3, 2, 4}));
  d.GatherActions(idx.data(), 2, out.data());
  EXPECT_EQ(out, (std::vector<float>{3, -3, 4, -4}));
}

TEST(DatasetTest, ImagesAndFrameStacking) {
  const ImageShape shape{2, 2, 3};
  DatasetBuilder b(0, 1, shape);
  for (int e = 0; e < 2; ++e) {
    const int T = 3;
    std::vector<float> act(T, 0.5f);
    std::vector<uint8_t> img;
    for (int t = 0; t < T; ++t)
      img.insert(img.end(), shape.numel(), static_cast<uint8_t>(10 * e + t));
    b.AddEpisode({}, act, img);
  }
  const Dataset d = b.Build();
  EXPECT_TRUE(d.has_images());
  EXPECT_FALSE(d.has_states());
  EXPECT_EQ(d.image(4)[0], 11);
  // Frame stack 3 of step 4 (episode 1, t = 1): frames t = 0, 0, 1 (oldest first).
  std::vector<int64_t> idx{4, 2};
  std::vector<uint8_t> out(2 * 4 * 9);
  d.GatherImages(idx.data(), 2, 3, out.data());
  for (int p = 0; p < 4; ++p) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(out[p * 9 + 0 + c], 10);
      EXPECT_EQ(out[p * 9 + 3 + c], 10);
      EXPECT_EQ(out[p * 9 + 6 + c], 11);
      EXPECT_EQ(out[36 + p * 9 + 0 + c], 0);
      EXPECT_EQ(out[36 + p * 9 + 3 + c], 1);
      EXPECT_EQ(out[36 + p * 9 + 6 + c], 2);
    }
  }
}

TEST(DatasetTest, RejectsBadSizes) {
  DatasetBuilder b(2, 2);
  EXPECT_THROW(b.AddEpisode(std::vector<float>{1, 2, 3}, std::vector<float>{1, 2}), DatasetError);
  EXPECT_THROW(b.AddEpisode(std::vector<float>{1, 2}, std::vector<float>{1, 2, 3}), DatasetError);
  EXPECT_THROW(b.AddEpisode(std::vector<float>{1, 2}, std::vector<float>{1, 2}, {1, 2, 3}),
               DatasetError);
  EXPECT_THROW(DatasetBuilder(0, 2), DatasetError);
  EXPECT_THROW(DatasetBuilder(2, 0), DatasetError);
  DatasetBuilder single(1, 1);
  single.AddEpisode(std::vector<float>{1}, std::vector<float>{1});
  EXPECT_THROW(single.Build(), DatasetError);  // no transition at all
  EXPECT_THROW(DatasetBuilder(1, 1).Build(), DatasetError);
}

TEST(DatasetTest, FromArraysTakesOwnershipWithoutCopy) {
  std::vector<float> states(6, 1.0f), actions(3, 0.0f);
  const float* p = states.data();
  const Dataset d =
      Dataset::FromArrays(std::move(states), 2, {}, {}, std::move(actions), 1, {0, 0, 1});
  EXPECT_EQ(d.state(0), p);
}

}  // namespace
}  // namespace core
}  // namespace msspr
