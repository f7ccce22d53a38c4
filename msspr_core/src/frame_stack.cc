#include "msspr_core/frame_stack.h"

#include <cstring>
#include <stdexcept>
#include <string>

namespace msspr::core {

FrameStacker::FrameStacker(int height, int width, int channels, int stack) : stack_(stack) {
  if (height <= 0 || width <= 0 || channels <= 0 || stack <= 0)
    throw std::invalid_argument(
        "FrameStacker: height, width, channels and stack must be positive, got " +
        std::to_string(height) + ", " + std::to_string(width) + ", " + std::to_string(channels) +
        ", " + std::to_string(stack));
  pixels_ = static_cast<size_t>(height) * static_cast<size_t>(width);
  channels_ = static_cast<size_t>(channels);
  frame_bytes_ = pixels_ * channels_;
}

void FrameStacker::Interleave(const uint8_t* const* frames, uint8_t* out) const {
  if (stack_ == 1) {
    std::memcpy(out, frames[0], frame_bytes_);
    return;
  }
  const size_t c = channels_, cs = channels_ * static_cast<size_t>(stack_);
  for (int s = 0; s < stack_; ++s) {
    const uint8_t* src = frames[s];
    uint8_t* dst = out + static_cast<size_t>(s) * c;
    for (size_t p = 0; p < pixels_; ++p) std::memcpy(dst + p * cs, src + p * c, c);
  }
}

void FrameStacker::Repeat(const uint8_t* frame, uint8_t* out) const {
  std::vector<const uint8_t*> frames(static_cast<size_t>(stack_), frame);
  Interleave(frames.data(), out);
}

std::vector<uint8_t> FrameStacker::Repeat(const uint8_t* frame) const {
  std::vector<uint8_t> out(stacked_bytes());
  Repeat(frame, out.data());
  return out;
}

void FrameStacker::Reset(const uint8_t* frame) {
  history_.assign(static_cast<size_t>(stack_), std::vector<uint8_t>(frame, frame + frame_bytes_));
}

void FrameStacker::Push(const uint8_t* frame) {
  if (history_.empty()) return Reset(frame);
  std::vector<uint8_t> oldest = std::move(history_.front());
  history_.pop_front();
  std::memcpy(oldest.data(), frame, frame_bytes_);
  history_.push_back(std::move(oldest));
}

void FrameStacker::Replace(const uint8_t* frame) {
  if (history_.empty()) return Reset(frame);
  std::memcpy(history_.back().data(), frame, frame_bytes_);
}

void FrameStacker::Stacked(uint8_t* out) const {
  if (history_.empty()) throw std::logic_error("FrameStacker::Stacked: no frame yet (Reset first)");
  std::vector<const uint8_t*> frames;
  frames.reserve(history_.size());
  for (const auto& f : history_) frames.push_back(f.data());
  Interleave(frames.data(), out);
}

std::vector<uint8_t> FrameStacker::Stacked() const {
  std::vector<uint8_t> out(stacked_bytes());
  Stacked(out.data());
  return out;
}

}  // namespace msspr::core
