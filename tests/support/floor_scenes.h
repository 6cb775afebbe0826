// floor_scenes.h -- tiny scenes built in code for the renderer's and shadow methods' tests.
#pragma once

#include "lightmesh/geometry/triangle.h"
#include "lightmesh/scene/scene.h"
#include "lightmesh/scene/shapes.h"
#include "lightmesh/shadow/shadow.h"

namespace lm::testing {

/// A square floor y = 0 of half-size `half`, material 0 (kd 0.5 grey), one point light
/// above it, a camera looking down at the floor at an angle.
inline Scene FloorScene(float half = 10.0f) {
    Scene s;
    s.name = "test:floor";
    s.materials = {{"floor", Color(0.5f), Color(0.0f), 1.0f, Color(0.0f)}};
    s.mesh.positions = {{-half, 0, -half}, {half, 0, -half}, {half, 0, half}, {-half, 0, half}};
    s.mesh.triangles = {{0, 2, 1}, {0, 3, 2}};
    s.mesh.materialIds = {0, 0};
    s.lights = {{{0.5f, 4.0f, 0.25f}, Color(16.0f, 12.0f, 8.0f), Falloff::InverseSquare}};
    s.camera = Camera{{0, 3, 4}, {0, 0, 0}, {0, 1, 0}, 50.0f};
    s.ambient = Color(0.1f, 0.2f, 0.3f);
    s.background = Color(0.0f, 0.0f, 1.0f);
    s.render.width = 48;
    s.render.height = 36;
    return s;
}

/// Adds a closed box (material 1, appended if missing) to a scene.
inline void AddBox(Scene* s, const Vec3& lo, const Vec3& hi) {
    if (s->materials.size() < 2) s->materials.push_back({"box", Color(0.7f), Color(0.0f), 1.0f, Color(0.0f)});
    ShapeBuilder(&s->mesh).Box(lo, hi, 1);
}

/// A shading point on the floor y = 0 of FloorScene, seen from above.
inline ShadingPoint FloorPoint(float x, float z) {
    ShadingPoint sp;
    sp.p = Vec3(x, 0, z);
    sp.n = Vec3(0, 1, 0);
    sp.origin = Vec3(x, 1e-5f, z);
    return sp;
}

/// The same point as the renderer makes it on FloorScene(half): the floor triangle it lies
/// on, and the origin the renderer's offset away (so the light mesh's cell patches, which
/// rely on both, are used for it).
inline ShadingPoint RenderedFloorPoint(float x, float z, float half = 10.0f) {
    ShadingPoint sp = FloorPoint(x, z);
    sp.prim = x >= z ? 0 : 1;  // triangle 0 is (-h, -h), (h, h), (h, -h): the side x >= z
    sp.origin = sp.p + sp.n * SurfaceOffset(Vec3(-half, 0, -half), Vec3(half, 0, half), Vec3(half, 0, -half));
    return sp;
}

}  // namespace lm::testing
