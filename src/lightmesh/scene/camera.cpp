#include "lightmesh/scene/camera.h"

#include "lightmesh/util/error.h"

namespace lm {

CameraRays::CameraRays(const Camera& camera, int width, int height)
    : width_(width), height_(height) {
    if (width <= 0 || height <= 0) ThrowError("image size %dx%d: must be positive", width, height);
    const Vec3 view = camera.lookAt - camera.position;
    if (!IsFinite(view) || !(LengthSquared(view) > 0))
        ThrowError("camera: look_at equals position, so there is no view direction");
    if (!(camera.fovY > 0 && camera.fovY < 180))
        ThrowError("camera: field of view must be between 0 and 180 degrees, got %g", camera.fovY);
    forward_ = Normalize(view);
    const Vec3 side = Cross(forward_, camera.up);
    if (!(Length(side) > 1e-6f * Length(camera.up)))
        ThrowError("camera: up is parallel to the view direction");
    right_ = Normalize(side);
    up_ = Cross(right_, forward_);
    origin_ = camera.position;
    tanHalfY_ = std::tan(camera.fovY * 0.5f * Pi / 180.0f);
    tanHalfX_ = tanHalfY_ * static_cast<float>(width) / static_cast<float>(height);
}

Ray CameraRays::Generate(float px, float py) const {
    const float sx = (2.0f * px / static_cast<float>(width_) - 1.0f) * tanHalfX_;
    const float sy = (1.0f - 2.0f * py / static_cast<float>(height_)) * tanHalfY_;
    return Ray{origin_, Normalize(forward_ + right_ * sx + up_ * sy), 0.0f, Infinity};
}

}  // namespace lm
