// light_keys.cpp -- a scene file's spot and sun keys on a light: "spot" makes a point light
// a spot, "sun" makes the light the sun (docs/scene-format.md, "Spots and the sun").
#include <cmath>

#include "lightmesh/scene/file_cameras_lights.h"
#include "lightmesh/scene/scene_load.h"

namespace lm::scene_load {

using namespace json;

namespace {

/// A non-zero finite direction, made unit.
Vec3 ReadDirection(const Reader& r, const Json& j, const std::string& path) {
    if (!j.is_array() || j.size() != 3)
        r.Fail(path, "expected 3 numbers, got " + (j.is_array() ? StringPrintf("%zu numbers", j.size()) : Describe(j)));
    Vec3 v;
    for (int i = 0; i < 3; ++i) v[i] = Float(r, j[i], Index(path, i));
    const float length = Length(v);
    if (!(length > 0) || !std::isfinite(length))
        r.Fail(path, "must be a non-zero direction, got " + FormatVec(v));
    return v;  // as stated: SetSpotCone and SetSun normalise it
}

/// An angle in degrees within [lo, hi] (lo included only if `loIncluded`).
float ReadDegrees(const Reader& r, const Json& j, const std::string& path, double lo, bool loIncluded, double hi) {
    const double deg = Number(r, j, path);
    if (!((loIncluded ? deg >= lo : deg > lo) && deg <= hi))
        r.Fail(path, StringPrintf("must be %s %g and at most %g degrees, got %s", loIncluded ? "at least" : "above", lo,
                                  hi, NumberText(j).c_str()));
    return static_cast<float>(deg);
}

}  // namespace

void ReadSpotKey(const Reader& r, const Json& j, const std::string& path, PointLight* light) {
    Object o(r, j, path);
    const Vec3 direction = ReadDirection(r, o.Require("direction"), o.Child("direction"));
    float outer = 45.0f, inner = 0.0f;  // glTF's defaults
    if (const Json* v = o.Find("outer")) outer = ReadDegrees(r, *v, o.Child("outer"), 0, false, 90);
    if (const Json* v = o.Find("inner")) {
        inner = ReadDegrees(r, *v, o.Child("inner"), 0, true, 90);
        if (inner > outer)
            r.Fail(o.Child("inner"), StringPrintf("must not exceed \"outer\" (%g degrees), got %s", double(outer),
                                                  NumberText(*v).c_str()));
    }
    o.Finish();
    SetSpotCone(direction, inner, outer, light);
}

void ReadSunKey(const Reader& r, const Json& j, const std::string& path, PointLight* light) {
    Object o(r, j, path);
    const Vec3 direction = ReadDirection(r, o.Require("direction"), o.Child("direction"));
    float angle = kSunAngleDegrees;
    if (const Json* v = o.Find("angle")) angle = ReadDegrees(r, *v, o.Child("angle"), 0, true, kMaxSunAngleDegrees);
    o.Finish();
    SetSun(direction, angle, light);
}

}  // namespace lm::scene_load
