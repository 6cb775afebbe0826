// file_cameras_lights.cpp -- a model file's cameras and lights made the scene's: the
// camera's field of view from Assimp's conventions, the lights' units and cones, the sun as
// a far sphere light.
#include "lightmesh/scene/file_cameras_lights.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "lightmesh/scene/scene_file.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace {

constexpr double kDegrees = 180.0 / 3.14159265358979323846;

bool FiniteColor(const Color& c) {
    return std::isfinite(c.r) && std::isfinite(c.g) && std::isfinite(c.b) && c.r >= 0 && c.g >= 0 && c.b >= 0;
}

}  // namespace

void SetSpotCone(const Vec3& direction, float innerDegrees, float outerDegrees, PointLight* light) {
    light->kind = LightKind::Spot;
    light->spot.statedDirection = direction;
    light->spot.direction = direction / Length(direction);
    light->spot.innerDegrees = innerDegrees;
    light->spot.outerDegrees = outerDegrees;
    light->spot.cosInner = std::cos(innerDegrees * Pi / 180.0f);
    light->spot.cosOuter = std::max(std::cos(outerDegrees * Pi / 180.0f), 0.0f);
}

void SetSun(const Vec3& direction, float angleDegrees, PointLight* light) {
    light->kind = LightKind::Sun;
    light->falloff = Falloff::None;
    light->sun.statedDirection = direction;
    light->sun.direction = direction / Length(direction);
    light->sun.angleDegrees = angleDegrees;
    light->sun.angle = angleDegrees * Pi / 180.0f;
}

void PlaceSuns(Scene* scene, const Bounds3& bounds) {
    const Vec3 centre = bounds.Center();
    const float distance = kSunDistanceFactor * std::max(0.5f * Length(bounds.Diagonal()), 1e-3f);
    for (PointLight& l : scene->lights) {
        if (l.kind != LightKind::Sun) continue;
        l.position = centre - l.sun.direction * distance;
        l.radius = distance * std::sin(l.sun.angle);
        l.falloff = Falloff::None;
        l.range = Infinity;
    }
}

int SelectFileCamera(const std::vector<FileCamera>& cameras, const std::string& select, std::string* problem) {
    if (cameras.empty()) {
        *problem = "the file has no cameras";
        return -1;
    }
    if (select.empty()) {
        for (size_t i = 0; i < cameras.size(); ++i)
            if (!cameras[i].orthographic) return static_cast<int>(i);
        problem->clear();
        return -1;
    }
    for (size_t i = 0; i < cameras.size(); ++i)
        if (cameras[i].name == select) return static_cast<int>(i);
    const bool digits = select.find_first_not_of("0123456789") == std::string::npos;
    if (digits) {
        const unsigned long long index = select.size() > 9 ? ~0ull : std::strtoull(select.c_str(), nullptr, 10);
        if (index < cameras.size()) return static_cast<int>(index);
        *problem = StringPrintf("the file has %zu camera%s (indices 0 to %zu), no camera %s", cameras.size(),
                                cameras.size() == 1 ? "" : "s", cameras.size() - 1, select.c_str());
        return -1;
    }
    std::string names;
    constexpr size_t kListed = 8;
    for (size_t i = 0; i < cameras.size() && i < kListed; ++i)
        names += (i ? ", " : "") + (cameras[i].name.empty() ? StringPrintf("%zu (unnamed)", i) : "\"" + cameras[i].name + "\"");
    if (cameras.size() > kListed) names += StringPrintf(" and %zu more", cameras.size() - kListed);
    *problem = "the file has no camera named \"" + select + "\" (its cameras: " + names + ")";
    return -1;
}

std::string CameraFromFile(const FileCamera& fc, float imageAspect, Camera* out) {
    if (fc.orthographic) return "it is orthographic (lightmesh renders perspective cameras)";
    if (!IsFinite(fc.position)) return "its position is not finite";
    if (!IsFinite(fc.lookAt) || !(LengthSquared(fc.lookAt) > 0))
        return "it has no view direction (its node's transform is singular or not finite)";
    if (!IsFinite(fc.up) || !(Length(Cross(Normalize(fc.lookAt), fc.up)) > 1e-6f * Length(fc.up)))
        return "its up direction is zero or parallel to its view direction";
    // The file's aspect where it states a usable one, else the image's.
    const float aspect = std::isfinite(fc.aspect) && fc.aspect > 0 ? fc.aspect : imageAspect;
    double fovY = 0;
    const double half = fc.fov == FileCamera::Fov::FullHorizontal ? 0.5 * fc.horizontalFov : fc.horizontalFov;
    if (fc.fov == FileCamera::Fov::GltfYfovTimesAspect) {
        fovY = fc.horizontalFov / (std::isfinite(fc.aspect) && fc.aspect > 0 ? fc.aspect : 1.0f) * kDegrees;
    } else if (std::isfinite(half) && half > 0 && half < 0.5 * 3.14159265358979323846) {
        fovY = 2.0 * std::atan(std::tan(half) / aspect) * kDegrees;
    } else {
        return StringPrintf("its horizontal field of view is %g°: must be between 0 and 180°", 2.0 * half * kDegrees);
    }
    if (!(fovY > 0 && fovY < 180))
        return StringPrintf("its vertical field of view is %g°: must be between 0 and 180°", fovY);
    out->position = fc.position;
    out->lookAt = fc.position + Normalize(fc.lookAt);
    out->up = Normalize(fc.up);
    out->fovY = static_cast<float>(fovY);
    return "";
}

std::string LightFromFile(const FileLight& fl, const Bounds3& bounds, PointLight* out) {
    PointLight l;
    l.name = fl.name;
    if (!FiniteColor(fl.color))
        return StringPrintf("its colour (%g, %g, %g) is negative or not finite", fl.color.r, fl.color.g, fl.color.b);
    Vec3 direction;
    if (fl.type != FileLight::Type::Point) {
        if (!IsFinite(fl.direction) || !(LengthSquared(fl.direction) > 0))
            return "it has no direction (its node's transform is singular or not finite)";
        direction = Normalize(fl.direction);
    }
    if (fl.type == FileLight::Type::Directional) {
        // Lux: the irradiance of a surface facing it; any attenuation is meaningless at
        // infinity.
        l.intensity = fl.color;
        SetSun(fl.direction, kSunAngleDegrees, &l);
        *out = l;
        return "";
    }
    if (!IsFinite(fl.position)) return "its position is not finite";
    if (!(std::isfinite(fl.quadratic) && std::isfinite(fl.constant) && fl.quadratic >= 0 && fl.constant >= 0))
        return StringPrintf("its attenuation (constant %g, quadratic %g) is negative or not finite",
                            double(fl.constant), double(fl.quadratic));
    l.position = fl.position;
    if (fl.quadratic > 0) {
        l.falloff = Falloff::InverseSquare;
        l.intensity = fl.color * (1.0f / fl.quadratic);
    } else {
        l.falloff = Falloff::None;
        l.intensity = fl.color * (1.0f / (fl.constant > 0 ? fl.constant : 1.0f));
    }
    if (!FiniteColor(l.intensity)) return "its intensity (colour / attenuation) is not finite";
    l.radius = DefaultLightRadius(bounds, l.position);
    if (!std::isnan(fl.range)) {
        if (!(fl.range > 0) || !std::isfinite(fl.range))
            return StringPrintf("its range is %g: must be a finite number above 0", double(fl.range));
        l.range = fl.range;
    }
    if (fl.type == FileLight::Type::Spot) {
        if (!(std::isfinite(fl.inner) && std::isfinite(fl.outer)))
            return "its cone angles are not finite";
        if (!(fl.outer > 0 && fl.outer <= 0.5f * Pi + 1e-6f))
            return StringPrintf("its outer cone angle is %g°: must be above 0 and at most 90°", fl.outer * kDegrees);
        if (!(fl.inner >= 0 && fl.inner <= fl.outer))
            return StringPrintf("its inner cone angle %g° is not between 0 and its outer cone angle %g°",
                                fl.inner * kDegrees, fl.outer * kDegrees);
        // Half-angles in degrees (the outer one at most 90: radians a rounding above pi/2 pass).
        SetSpotCone(fl.direction, std::min(90.0f, static_cast<float>(fl.inner * kDegrees)),
                    std::min(90.0f, static_cast<float>(fl.outer * kDegrees)), &l);
    }
    *out = l;
    return "";
}

}  // namespace lm
