// FrameStacker: the one owner of the frame-stack layout. The byte layout
// itself, and that an episode stacked step by step (as the in-process
// evaluator and the policy node do) gives exactly the images the dataset
// gathers for training.
#include "msspr_core/frame_stack.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <stdexcept>
#include <vector>

#include "msspr_core/dataset.h"

namespace msspr::core {
namespace {

std::vector<uint8_t> RandomFrame(size_t bytes, std::mt19937* rng) {
  std::vector<uint8_t> f(bytes);
  for (auto& v : f) v = static_cast<uint8_t>((*rng)() & 0xff);
  return f;
}

TEST(FrameStacker, LayoutIsPerPixelOldestFrameFirst) {
  constexpr int H = 2, W = 3, C = 3, S = 4;
  const FrameStacker st(H, W, C, S);
  EXPECT_EQ(st.frame_bytes(), size_t{H * W * C});
  EXPECT_EQ(st.stacked_bytes(), size_t{H * W * C * S});
  std::mt19937 rng(1);
  std::vector<std::vector<uint8_t>> frames;
  std::vector<const uint8_t*> ptrs;
  for (int s = 0; s < S; ++s) frames.push_back(RandomFrame(st.frame_bytes(), &rng));
  for (const auto& f : frames) ptrs.push_back(f.data());
  std::vector<uint8_t> out(st.stacked_bytes());
  st.Interleave(ptrs.data(), out.data());
  for (int p = 0; p < H * W; ++p)
    for (int s = 0; s < S; ++s)
      for (int c = 0; c < C; ++c)
        ASSERT_EQ(out[(p * S + s) * C + c], frames[s][p * C + c])
            << "pixel " << p << " frame " << s << " channel " << c;
}

TEST(FrameStacker, RepeatIsTheFrameInEverySlot) {
  const FrameStacker st(4, 4, 3, 3);
  std::mt19937 rng(2);
  const auto f = RandomFrame(st.frame_bytes(), &rng);
  const std::vector<const uint8_t*> same(3, f.data());
  std::vector<uint8_t> want(st.stacked_bytes());
  st.Interleave(same.data(), want.data());
  EXPECT_EQ(st.Repeat(f.data()), want);
}

TEST(FrameStacker, EpisodeHistoryResetPushReplace) {
  FrameStacker st(3, 2, 3, 3);
  std::mt19937 rng(3);
  const auto a = RandomFrame(st.frame_bytes(), &rng), b = RandomFrame(st.frame_bytes(), &rng),
             c = RandomFrame(st.frame_bytes(), &rng), d = RandomFrame(st.frame_bytes(), &rng);
  auto interleave = [&](std::vector<const uint8_t*> ptrs) {
    std::vector<uint8_t> out(st.stacked_bytes());
    st.Interleave(ptrs.data(), out.data());
    return out;
  };
  EXPECT_TRUE(st.empty());
  EXPECT_THROW(st.Stacked(), std::logic_error);
  st.Reset(a.data());
  EXPECT_EQ(st.Stacked(), interleave({a.data(), a.data(), a.data()}));
  st.Push(b.data());
  EXPECT_EQ(st.Stacked(), interleave({a.data(), a.data(), b.data()}));
  st.Replace(c.data());  // the same step again: its frame replaced, the older ones kept
  EXPECT_EQ(st.Stacked(), interleave({a.data(), a.data(), c.data()}));
  st.Push(d.data());
  st.Push(b.data());
  EXPECT_EQ(st.Stacked(), interleave({c.data(), d.data(), b.data()}));
  st.Reset(d.data());  // a new episode forgets the old frames
  EXPECT_EQ(st.Stacked(), st.Repeat(d.data()));
}

TEST(FrameStacker, OneFrameIsTheFrame) {
  FrameStacker st(5, 5, 3, 1);
  std::mt19937 rng(4);
  const auto a = RandomFrame(st.frame_bytes(), &rng), b = RandomFrame(st.frame_bytes(), &rng);
  st.Reset(a.data());
  EXPECT_EQ(st.Stacked(), a);
  st.Push(b.data());
  EXPECT_EQ(st.Stacked(), b);
  EXPECT_EQ(st.Repeat(a.data()), a);
}

TEST(FrameStacker, RejectsNonPositiveShapes) {
  EXPECT_THROW(FrameStacker(0, 4, 3, 2), std::invalid_argument);
  EXPECT_THROW(FrameStacker(4, 4, 0, 2), std::invalid_argument);
  EXPECT_THROW(FrameStacker(4, 4, 3, 0), std::invalid_argument);
}

// Training and acting see the same images: an episode stacked step by step
// (Reset at its first step, Push after) equals Dataset::GatherImages of each
// step, for every step of two trajectories, at frame stacks 1 to 4.
TEST(FrameStacker, EpisodeStackingEqualsTheDatasetsBatches) {
  constexpr int H = 4, W = 5, C = 3;
  const ImageShape shape{H, W, C};
  std::mt19937 rng(5);
  DatasetBuilder builder(1, 1, shape);
  const std::vector<int64_t> lengths = {6, 3};
  std::vector<std::vector<std::vector<uint8_t>>> episodes;
  for (int64_t T : lengths) {
    std::vector<float> obs(T, 0.f), act(T, 0.f);
    std::vector<uint8_t> images;
    episodes.emplace_back();
    for (int64_t t = 0; t < T; ++t) {
      episodes.back().push_back(RandomFrame(shape.numel(), &rng));
      images.insert(images.end(), episodes.back().back().begin(), episodes.back().back().end());
    }
    builder.AddEpisode(obs, act, images);
  }
  const Dataset data = builder.Build();
  for (int stack = 1; stack <= 4; ++stack) {
    FrameStacker st(H, W, C, stack);
    int64_t i = 0;
    for (const auto& episode : episodes) {
      for (size_t t = 0; t < episode.size(); ++t, ++i) {
        if (t == 0)
          st.Reset(episode[t].data());
        else
          st.Push(episode[t].data());
        std::vector<uint8_t> gathered(st.stacked_bytes());
        data.GatherImages(&i, 1, stack, gathered.data());
        ASSERT_EQ(st.Stacked(), gathered) << "stack " << stack << ", step " << i;
      }
    }
  }
}

}  // namespace
}  // namespace msspr::core
