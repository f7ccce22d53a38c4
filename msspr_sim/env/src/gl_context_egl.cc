#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <cstdio>
#include <mutex>
#include <stdexcept>
#include <string>

#include "gl_context.h"

namespace msspr::sim::internal {
namespace {

std::string EglError(const char* what) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "0x%04x", eglGetError());
  return std::string("EGL: ") + what + " failed (error " + buf + ")";
}

// The display is shared by every context of the process; it is initialised
// once and never terminated (eglTerminate would destroy the contexts of the
// other PointMaze instances). Mesa's surfaceless platform first (llvmpipe or
// a Mesa GPU driver); where that is missing or fails (NVIDIA's EGL), the
// first EGL device that initialises (EGL_EXT_platform_device).
EGLDisplay SharedDisplay() {
  static std::once_flag once;
  static EGLDisplay display = EGL_NO_DISPLAY;
  static std::string error;
  std::call_once(once, [] {
    auto get_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (get_display == nullptr) {
      error = "EGL: eglGetPlatformDisplayEXT is not available";
      return;
    }
    EGLint major = 0, minor = 0;
    EGLDisplay d = get_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (d != EGL_NO_DISPLAY && eglInitialize(d, &major, &minor) == EGL_TRUE) {
      display = d;
      return;
    }
    error = EglError(d == EGL_NO_DISPLAY ? "eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA)"
                                         : "eglInitialize (surfaceless)");
    auto query_devices =
        reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    if (query_devices == nullptr) return;
    EGLDeviceEXT devices[16];
    EGLint n = 0;
    if (query_devices(16, devices, &n) != EGL_TRUE) return;
    for (EGLint i = 0; i < n; ++i) {
      d = get_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
      if (d != EGL_NO_DISPLAY && eglInitialize(d, &major, &minor) == EGL_TRUE) {
        display = d;
        return;
      }
    }
    error += "; and none of " + std::to_string(n) + " EGL devices initialised";
  });
  if (display == EGL_NO_DISPLAY) throw std::runtime_error(error);
  return display;
}

}  // namespace

struct GlContext::Impl {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
};

GlContext::GlContext(int /*width*/, int /*height*/) : impl_(std::make_unique<Impl>()) {
  impl_->display = SharedDisplay();
  const EGLint config_attribs[] = {EGL_SURFACE_TYPE,
                                   EGL_PBUFFER_BIT,
                                   EGL_RENDERABLE_TYPE,
                                   EGL_OPENGL_BIT,
                                   EGL_RED_SIZE,
                                   8,
                                   EGL_GREEN_SIZE,
                                   8,
                                   EGL_BLUE_SIZE,
                                   8,
                                   EGL_ALPHA_SIZE,
                                   8,
                                   EGL_DEPTH_SIZE,
                                   24,
                                   EGL_STENCIL_SIZE,
                                   8,
                                   EGL_NONE};
  EGLConfig config;
  EGLint num_configs = 0;
  if (eglChooseConfig(impl_->display, config_attribs, &config, 1, &num_configs) != EGL_TRUE ||
      num_configs < 1) {
    throw std::runtime_error(EglError("eglChooseConfig (pbuffer, OpenGL)"));
  }
  if (eglBindAPI(EGL_OPENGL_API) != EGL_TRUE) throw std::runtime_error(EglError("eglBindAPI"));
  impl_->context = eglCreateContext(impl_->display, config, EGL_NO_CONTEXT, nullptr);
  if (impl_->context == EGL_NO_CONTEXT) throw std::runtime_error(EglError("eglCreateContext"));
  MakeCurrent();
}

GlContext::~GlContext() {
  if (impl_->context != EGL_NO_CONTEXT) {
    if (eglGetCurrentContext() == impl_->context) {
      eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    }
    eglDestroyContext(impl_->display, impl_->context);
  }
}

void GlContext::MakeCurrent() {
  if (eglGetCurrentContext() == impl_->context) return;
  if (eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, impl_->context) != EGL_TRUE) {
    throw std::runtime_error(EglError("eglMakeCurrent (surfaceless)"));
  }
}

void GlContext::Release() {
  if (eglGetCurrentContext() == impl_->context) {
    eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  }
}

const char* GlContext::Backend() { return "EGL"; }

}  // namespace msspr::sim::internal
