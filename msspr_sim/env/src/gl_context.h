// Internal: a headless OpenGL context (EGL surfaceless or OSMesa, chosen at
// build time by MSSPR_RENDER_BACKEND).
#ifndef MSSPR_SIM_SRC_GL_CONTEXT_H_
#define MSSPR_SIM_SRC_GL_CONTEXT_H_

#include <memory>

namespace msspr::sim::internal {

class GlContext {
 public:
  // Creates the context (throws std::runtime_error naming the failing call)
  // and makes it current on the calling thread.
  GlContext(int width, int height);
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;
  // Makes the context current on the calling thread; throws on failure.
  void MakeCurrent();
  // Releases it from the calling thread (so another thread may take it).
  void Release();
  // "EGL" or "OSMESA".
  static const char* Backend();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace msspr::sim::internal

#endif  // MSSPR_SIM_SRC_GL_CONTEXT_H_
