// Camera orientations for hand-made test scenes. Header-only, so that the
// synthetic-scene library (built without GoogleTest, for the demo and the
// benchmark) can use it as well as the tests.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace glomap {
namespace testing {

// The cam_from_world rotation of a camera whose optical axis (z) points
// along `forward`, in COLMAP's camera frame (x right, y down): x is
// forward x `world_up`, so the image's "down" points away from `world_up`.
// `forward` must not be parallel to `world_up`.
inline Eigen::Matrix3d CamFromWorldLookingAlong(
    const Eigen::Vector3d& forward,
    const Eigen::Vector3d& world_up = Eigen::Vector3d::UnitZ()) {
  const Eigen::Vector3d z = forward.normalized();
  const Eigen::Vector3d x = z.cross(world_up).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d cam_from_world;
  cam_from_world.row(0) = x;
  cam_from_world.row(1) = y;
  cam_from_world.row(2) = z;
  return cam_from_world;
}

}  // namespace testing
}  // namespace glomap
