// Internal: MuJoCo's offscreen rendering of one fixed camera into RGB images,
// shared by the environments (PointMaze, CubeEnv).
#ifndef MSSPR_SIM_SRC_OFFSCREEN_RENDERER_H_
#define MSSPR_SIM_SRC_OFFSCREEN_RENDERER_H_

#include <mujoco/mujoco.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "gl_context.h"

namespace msspr::sim::internal {

class OffscreenRenderer {
 public:
  // A headless GL context, MuJoCo's scene (default visual options: geom
  // groups 0-2 visible) and offscreen context for model `m`, rendering its
  // fixed camera `camera_id` at size x size. Throws std::runtime_error when
  // the context or the offscreen framebuffer cannot be had. The GL context is
  // left released, so that any thread may render next.
  OffscreenRenderer(const mjModel* m, int size, int camera_id);
  ~OffscreenRenderer();
  OffscreenRenderer(const OffscreenRenderer&) = delete;
  OffscreenRenderer& operator=(const OffscreenRenderer&) = delete;

  // Scene flags (shadows, skybox) may be changed before rendering.
  mjvScene& scene() { return scene_; }

  // Renders `d` as it is posed (no physics is run) into rgb: [size, size, 3]
  // uint8, top row first. The context is current only during the call (a
  // context can be current in one thread at a time).
  void Render(const mjModel* m, mjData* d, uint8_t* rgb);

 private:
  int size_;
  std::unique_ptr<GlContext> gl_;
  mjvScene scene_;
  mjvCamera camera_;
  mjvOption vopt_;
  mjrContext context_;
  std::vector<uint8_t> flip_;  // [S, S, 3] scratch for the bottom-up read
};

}  // namespace msspr::sim::internal

#endif  // MSSPR_SIM_SRC_OFFSCREEN_RENDERER_H_
