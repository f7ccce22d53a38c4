#include <GL/osmesa.h>

#include <stdexcept>
#include <vector>

#include "gl_context.h"

namespace msspr::sim::internal {

struct GlContext::Impl {
  OSMesaContext context = nullptr;
  std::vector<unsigned char> buffer;  // [height, width, 4] uint8, the default framebuffer
  int width = 0, height = 0;
};

GlContext::GlContext(int width, int height) : impl_(std::make_unique<Impl>()) {
  impl_->width = width;
  impl_->height = height;
  impl_->context = OSMesaCreateContextExt(OSMESA_RGBA, 24, 8, 8, nullptr);
  if (impl_->context == nullptr) throw std::runtime_error("OSMesa: OSMesaCreateContextExt failed");
  impl_->buffer.resize(static_cast<size_t>(width) * height * 4);
  MakeCurrent();
}

GlContext::~GlContext() {
  if (impl_->context != nullptr) OSMesaDestroyContext(impl_->context);
}

void GlContext::MakeCurrent() {
  if (OSMesaGetCurrentContext() == impl_->context) return;
  if (!OSMesaMakeCurrent(impl_->context, impl_->buffer.data(), GL_UNSIGNED_BYTE, impl_->width,
                         impl_->height)) {
    throw std::runtime_error("OSMesa: OSMesaMakeCurrent failed");
  }
}

void GlContext::Release() {
  if (OSMesaGetCurrentContext() == impl_->context) {
    OSMesaMakeCurrent(nullptr, nullptr, GL_UNSIGNED_BYTE, 0, 0);
  }
}

const char* GlContext::Backend() { return "OSMESA"; }

}  // namespace msspr::sim::internal
