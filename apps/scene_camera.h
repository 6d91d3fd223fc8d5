// The scene file's "camera" object as the renderer's Camera. Render builds only (PLIANT_HAS_RENDER):
// sim/ and interaction/ know nothing of the renderer, so the conversion lives with the apps.
#pragma once

#include "interaction/scene/scene.h"
#include "render/camera.h"

namespace pliant {

/// The renderer camera a scene's camera object describes (position, target, up in m; fov in degrees).
inline Camera render_camera(const SceneCamera& scene_camera) {
  Camera camera;
  camera.position = scene_camera.position;
  camera.target = scene_camera.target;
  camera.up = scene_camera.up;
  camera.fov_y_deg = scene_camera.fov_deg;
  return camera;
}

}  // namespace pliant
