// The frame-stack layout of pixel observations, in one place: `stack` frames
// of [H, W, C] uint8 form one [H, W, C * stack] image, interleaved per pixel,
// oldest frame first (frame s of pixel p, channel c, at byte
// (p * stack + s) * C + c). At a trajectory's start the first frame stands in
// for the frames before it; a goal is one frame repeated `stack` times. The
// dataset's batches (Dataset::GatherImages), the in-process evaluator and the
// policy node build their inputs through this class. No torch.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <vector>

namespace msspr::core {

class FrameStacker {
 public:
  // Throws std::invalid_argument unless all of them are positive.
  FrameStacker(int height, int width, int channels, int stack);

  int stack() const { return stack_; }
  // Bytes of one frame (H * W * C) and of a stacked image (times stack).
  size_t frame_bytes() const { return frame_bytes_; }
  size_t stacked_bytes() const { return frame_bytes_ * static_cast<size_t>(stack_); }

  // frames[0..stack-1], oldest first, each frame_bytes(), into
  // out[stacked_bytes()].
  void Interleave(const uint8_t* const* frames, uint8_t* out) const;
  // One frame repeated stack times (a goal; a trajectory's first step).
  void Repeat(const uint8_t* frame, uint8_t* out) const;
  std::vector<uint8_t> Repeat(const uint8_t* frame) const;

  // The frames of a running episode. Reset: a new episode starts with `frame`
  // (repeated); Push: the next step's frame (the oldest drops out); Replace:
  // the latest frame again, e.g. a re-sent step. Each takes frame_bytes().
  void Reset(const uint8_t* frame);
  void Push(const uint8_t* frame);
  void Replace(const uint8_t* frame);
  bool empty() const { return history_.empty(); }
  void Clear() { history_.clear(); }
  // The episode's stacked image (stacked_bytes()); the history must not be empty.
  void Stacked(uint8_t* out) const;
  std::vector<uint8_t> Stacked() const;

 private:
  size_t pixels_, channels_, frame_bytes_;
  int stack_;
  std::deque<std::vector<uint8_t>> history_;  // oldest first, stack_ frames
};

}  // namespace msspr::core
