// camera_overrides.cpp -- the camera options and the shared load-option checks
// (camera_overrides.h).
#include "lightmesh/scene/camera_overrides.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>

#include "lightmesh/scene/json_reader.h"
#include "lightmesh/scene/scene_load.h"
#include "lightmesh/util/error.h"

namespace lm {

Vec3 ParseVec3Option(const std::string& flag, const std::string& text) {
    double v[3];
    const char* p = text.c_str();
    for (int i = 0; i < 3; ++i) {
        while (*p == ' ') ++p;
        char* end = nullptr;
        v[i] = std::strtod(p, &end);
        if (end == p) ThrowError("%s: expected X,Y,Z (3 numbers), got %s", flag.c_str(), Printable(text).c_str());
        p = end;
        while (*p == ' ') ++p;
        if (i < 2) {
            if (*p != ',') ThrowError("%s: expected X,Y,Z (3 numbers), got %s", flag.c_str(), Printable(text).c_str());
            ++p;
        }
    }
    if (*p != 0) ThrowError("%s: expected X,Y,Z (3 numbers), got %s", flag.c_str(), Printable(text).c_str());
    return Vec3Option(flag, v, text);
}

Vec3 Vec3Option(const std::string& name, const double (&v)[3], const std::string& shown) {
    Vec3 out;
    for (int i = 0; i < 3; ++i) {
        if (!std::isfinite(v[i]) || std::abs(v[i]) > scene_load::kMaxCoordinate)
            ThrowError("%s: every number must be finite and within ±1e18, got %s", name.c_str(),
                       Printable(shown).c_str());
        out[i] = static_cast<float>(v[i]);
    }
    return out;
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
    if (end == text.c_str() || *end != 0) return FovOption("--fov", std::nan(""), text);
    return FovOption("--fov", fov, text);
}

float FovOption(const std::string& name, double degrees, const std::string& shown) {
    if (!(degrees > 0 && degrees < 180) || !(static_cast<float>(degrees) < 180))
        ThrowError("%s: must be a number of degrees between 0 and 180 (both excluded), got %s", name.c_str(),
                   Printable(shown).c_str());
    return static_cast<float>(degrees);
}

std::string SmoothNormalsProblem(double degrees, const std::string& shown) {
    // In single precision, as it is stored (and as the CLI's ranges compare).
    const float f = static_cast<float>(degrees);
    if (f >= 0 && f <= 180) return "";
    return "must be between 0 and 180, got " + Printable(shown);
}

bool IsMeshFileSpec(const std::string& spec) {
    return spec.rfind("builtin:", 0) != 0 && json::Lower(std::filesystem::path(spec).extension().string()) != ".json";
}

void PrepareCameraOverrides(const std::string& spec, CameraOverrides* o, SceneLoadOptions* load) {
    const bool meshFile = IsMeshFileSpec(spec);
    if (meshFile && o->upAxis >= 0) {
        load->upAxis = o->upAxis;  // the model turned to stand on that axis; the camera's up stays +y
        o->up.reset();
        o->upAxis = -1;
    }
    // Framing (a bare mesh, or a scene file without "camera") fits the model into the fov.
    if (spec.rfind("builtin:", 0) != 0 && o->fovY) load->frameFovY = *o->fovY;
    if (o->up && !(LengthSquared(*o->up) > 0)) ThrowError("%s: must not be zero", o->names.up.c_str());
    if (o->position && o->lookAt && *o->position == *o->lookAt)
        ThrowError("%s: the camera position equals the point looked at, so the camera has no view direction",
                   o->names.lookAt.c_str());
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
    const CameraOptionNames& n = o.names;
    const char* moved = o.lookAt ? n.lookAt.c_str() : n.position.c_str();
    const char* flag = key == "look_at" ? moved : key == "fov" ? n.fov.c_str() : n.up.c_str();
    if (key == "look_at")
        ThrowError("%s: the camera position equals the point looked at, so the camera has no view direction", flag);
    if (key == "up" && !o.up)
        ThrowError("%s: the view direction is now parallel to the scene's up direction; give %s too", moved,
                   n.up.c_str());
    ThrowError("%s: %s", flag, problem.c_str());
}

void ApplyCameraOverrides(const CameraOverrides& o, Scene* scene) {
    ApplyCameraOverrides(o, &scene->camera);
    if (o.position)
        if (const std::string p = scene_load::SpanProblem(*scene); !p.empty())
            ThrowError("%s: %s", o.names.position.c_str(), p.c_str());
}

}  // namespace lm
