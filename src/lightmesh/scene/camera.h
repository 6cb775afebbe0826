// camera.h -- turns pixel positions into camera rays.
#pragma once

#include "lightmesh/math/ray.h"
#include "lightmesh/scene/scene.h"

namespace lm {

/// A pinhole camera set up for an image of width × height pixels.
class CameraRays {
  public:
    /// Throws Error if the camera is degenerate (look_at = position, up parallel to the
    /// view direction, field of view outside (0, 180)).
    CameraRays(const Camera& camera, int width, int height);

    /// The ray through image position (px, py), in pixels from the top-left corner
    /// (pixel (i, j) covers [i, i+1) × [j, j+1)). Direction is unit length.
    Ray Generate(float px, float py) const;

  private:
    Vec3 origin_, forward_, right_, up_;
    float tanHalfY_, tanHalfX_;
    int width_, height_;
};

}  // namespace lm
