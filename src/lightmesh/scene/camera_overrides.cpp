// camera_overrides.cpp -- the command line's camera options (camera_overrides.h).
#include "lightmesh/scene/camera_overrides.h"

#include <cmath>
#include <cstdlib>
#include <limits>

#include "lightmesh/scene/scene_load.h"
#include "lightmesh/util/error.h"

namespace lm {

Vec3 ParseVec3Option(const std::string& flag, const std::string& text) {
    Vec3 v;
    const char* p = text.c_str();
    for (int i = 0; i < 3; ++i) {
        while (*p == ' ') ++p;
        char* end = nullptr;
        const double x = std::strtod(p, &end);
        if (end == p) ThrowError("%s: expected X,Y,Z (3 numbers), got %s", flag.c_str(), Printable(text).c_str());
        if (!std::isfinite(x) || std::abs(x) > scene_load::kMaxCoordinate)
            ThrowError("%s: every number must be finite and within ±1e18, got %s", flag.c_str(),
                       Printable(text).c_str());
        v[i] = static_cast<float>(x);
        p = end;
        while (*p == ' ') ++p;
        if (i < 2) {
            if (*p != ',') ThrowError("%s: expected X,Y,Z (3 numbers), got %s", flag.c_str(), Printable(text).c_str());
            ++p;
        }
    }
    if (*p != 0) ThrowError("%s: expected X,Y,Z (3 numbers), got %s", flag.c_str(), Printable(text).c_str());
    return v;
}

int AxisOfLetter(const std::string& text) {
    if (text.size() != 1) return -1;
    const char c = static_cast<char>(text[0] | 0x20);
    return c >= 'x' && c <= 'z' ? c - 'x' : -1;
}

Vec3 ParseUpOption(const std::string& text) {
    if (const int axis = AxisOfLetter(text); axis >= 0) {
        Vec3 v;
        v[axis] = 1;
        return v;
    }
    return ParseVec3Option("--up", text);
}

float ParseFovOption(const std::string& text) {
    char* end = nullptr;
    const double fov = std::strtod(text.c_str(), &end);
    if (end == text.c_str() || *end != 0 || !(fov > 0 && fov < 180) || !(static_cast<float>(fov) < 180))
        ThrowError("--fov: must be a number of degrees between 0 and 180 (both excluded), got %s",
                   Printable(text).c_str());
    return static_cast<float>(fov);
}

Affine UpAxisToY(int axis) {
    Affine a;
    if (axis == 2) a.m[1][1] = 0, a.m[1][2] = 1, a.m[2][1] = -1, a.m[2][2] = 0;
    if (axis == 0) a.m[0][0] = 0, a.m[0][1] = -1, a.m[1][0] = 1, a.m[1][1] = 0;
    return a;
}

void ApplyCameraOverrides(const CameraOverrides& o, Camera* camera) {
    if (o.position) camera->position = *o.position;
    if (o.lookAt) camera->lookAt = *o.lookAt;
    if (o.up) camera->up = *o.up;
    if (o.fovY) camera->fovY = *o.fovY;
    std::string key;
    const std::string problem = scene_load::CameraProblem(*camera, &key);
    if (problem.empty()) return;
    // The option to blame: the one the problem names if given, else the one that moved the
    // camera into it (a --camera-position on the scene's look_at).
    const char* flag = key == "look_at" ? (o.lookAt ? "--look-at" : "--camera-position")
                       : key == "fov"   ? "--fov"
                                        : "--up";
    if (key == "look_at")
        ThrowError("%s: the camera position equals the point looked at, so the camera has no view direction", flag);
    if (key == "up" && !o.up)
        ThrowError("%s: the view direction is now parallel to the scene's up direction; give --up too",
                   o.lookAt ? "--look-at" : "--camera-position");
    ThrowError("%s: %s", flag, problem.c_str());
}

void ApplyCameraOverrides(const CameraOverrides& o, Scene* scene) {
    ApplyCameraOverrides(o, &scene->camera);
    if (o.position)
        if (const std::string p = scene_load::SpanProblem(*scene); !p.empty()) ThrowError("--camera-position: %s", p.c_str());
}

}  // namespace lm
