#include "offscreen_renderer.h"

#include <cstring>
#include <stdexcept>

namespace msspr::sim::internal {

OffscreenRenderer::OffscreenRenderer(const mjModel* m, int size, int camera_id)
    : size_(size), gl_(std::make_unique<GlContext>(size, size)) {
  mjv_defaultScene(&scene_);
  mjv_defaultCamera(&camera_);
  mjv_defaultOption(&vopt_);
  mjr_defaultContext(&context_);
  mjv_makeScene(m, &scene_, 2000);
  mjr_makeContext(m, &context_, mjFONTSCALE_100);
  mjr_setBuffer(mjFB_OFFSCREEN, &context_);
  if (context_.currentBuffer != mjFB_OFFSCREEN) {
    mjr_freeContext(&context_);
    mjv_freeScene(&scene_);
    throw std::runtime_error("MuJoCo: offscreen framebuffer is not available");
  }
  camera_.type = mjCAMERA_FIXED;
  camera_.fixedcamid = camera_id;
  flip_.resize(static_cast<size_t>(size) * size * 3);
  gl_->Release();
}

OffscreenRenderer::~OffscreenRenderer() {
  gl_->MakeCurrent();
  mjr_freeContext(&context_);
  mjv_freeScene(&scene_);
  gl_->Release();
}

void OffscreenRenderer::Render(const mjModel* m, mjData* d, uint8_t* rgb) {
  gl_->MakeCurrent();
  const mjrRect viewport = {0, 0, size_, size_};
  mjv_updateScene(m, d, &vopt_, nullptr, &camera_, mjCAT_ALL, &scene_);
  mjr_render(viewport, &scene_, &context_);
  mjr_readPixels(flip_.data(), nullptr, viewport, &context_);
  gl_->Release();
  // mjr_readPixels gives the bottom row first; images are top row first.
  const size_t row = static_cast<size_t>(size_) * 3;
  for (int r = 0; r < size_; ++r)
    std::memcpy(rgb + r * row, flip_.data() + (size_ - 1 - r) * row, row);
}

}  // namespace msspr::sim::internal
