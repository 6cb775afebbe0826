#include "lightmesh/scene/demo_scene.h"

#include <cmath>

#include "lightmesh/scene/shapes.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace {

// The default scene of the main job and of many tests: a garden gazebo like the paper's
// "Gazebo" (Tables 3-4): eight columns, railings with thin balusters, an octagonal roof,
// on a ground slab with a few objects around it. Thin balusters and rails cast shadows
// narrower than a light-mesh cell at CC 100, thick columns and the roof cast wide ones;
// everything is a closed solid, so the inside-object test ("СТ") applies. Units: metres.
Scene MakeGazebo() {
    Scene scene;
    scene.name = "builtin:gazebo";
    enum : uint32_t { Ground, Stone, Wood, Roof, Marble, Mirror, Crate };
    scene.materials = {
        {"ground", Color(0.55f, 0.6f, 0.45f), Color(0.0f), 1.0f, Color(0.0f)},
        {"stone", Color(0.7f, 0.68f, 0.62f), Color(0.05f), 10.0f, Color(0.0f)},
        {"wood", Color(0.55f, 0.35f, 0.2f), Color(0.1f), 20.0f, Color(0.0f)},
        {"roof", Color(0.6f, 0.18f, 0.12f), Color(0.15f), 30.0f, Color(0.0f)},
        {"marble", Color(0.85f, 0.85f, 0.82f), Color(0.3f), 60.0f, Color(0.0f)},
        {"mirror", Color(0.05f), Color(0.6f), 200.0f, Color(0.7f)},
        {"crate", Color(0.7f, 0.55f, 0.3f), Color(0.05f), 10.0f, Color(0.0f)},
    };
    ShapeBuilder b(&scene.mesh);

    // Ground: a closed slab, so nodes below it count as inside a solid.
    b.Box({-7, -0.3f, -7}, {7, 0, 7}, Ground);
    // Platform.
    b.Cylinder({0, 0, 0}, 2.4f, 0.25f, 8, Stone);

    const int n = 8;
    const float R = 2.1f, colH = 2.4f, floorY = 0.25f;
    auto at = [&](int i, float radius, float y) {
        // Column i sits at angle (i + 0.5)·45°, so one side faces the camera squarely.
        const float a = 2.0f * Pi * (static_cast<float>(i) + 0.5f) / n;
        return Vec3(radius * std::sin(a), y, radius * std::cos(a));
    };
    for (int i = 0; i < n; ++i) b.Cylinder(at(i, R, floorY), 0.12f, colH, 12, Wood);
    // Railings between columns, except the entrance (between columns 0 and 7, facing +z).
    for (int i = 0; i < n - 1; ++i) {
        const Vec3 a = at(i, R, 0), c = at(i + 1, R, 0);
        const Vec3 topA = a + Vec3(0, floorY + 0.9f, 0), topC = c + Vec3(0, floorY + 0.9f, 0);
        const Vec3 lowA = a + Vec3(0, floorY + 0.15f, 0), lowC = c + Vec3(0, floorY + 0.15f, 0);
        b.Beam(topA, topC, 0.07f, Wood);
        b.Beam(lowA, lowC, 0.05f, Wood);
        for (int k = 1; k <= 5; ++k) {
            const float s = static_cast<float>(k) / 6.0f;
            const Vec3 p = a + (c - a) * s;
            b.Beam(p + Vec3(0, floorY + 0.15f, 0), p + Vec3(0, floorY + 0.9f, 0), 0.035f, Wood);
        }
    }
    // Roof: an eave ring (ring beams on the column tops), a slab and an octagonal pyramid.
    const float topY = floorY + colH;
    for (int i = 0; i < n; ++i)
        b.Beam(at(i, R, topY + 0.06f), at((i + 1) % n, R, topY + 0.06f), 0.12f, Wood);
    b.Cylinder({0, topY + 0.12f, 0}, 2.7f, 0.1f, 8, Roof);
    b.Cone({0, topY + 0.22f, 0}, 2.7f, 1.3f, 8, Roof);
    b.Sphere({0, topY + 1.52f + 0.1f, 0}, 0.12f, 6, 8, Marble);

    // Objects around: a mirror ball, a crate, a bench, a lamp post (thin pole), a statue.
    b.Sphere({3.6f, 0.6f, 1.6f}, 0.6f, 16, 24, Mirror);
    b.OrientedBox({-3.5f, 0.45f, 1.8f}, {0.45f * std::cos(0.4f), 0, 0.45f * std::sin(0.4f)},
                  {0, 0.45f, 0}, {-0.45f * std::sin(0.4f), 0, 0.45f * std::cos(0.4f)}, Crate);
    b.Box({0.9f, 0.4f, 3.3f}, {2.7f, 0.48f, 3.8f}, Wood);
    b.Box({1.0f, 0, 3.4f}, {1.15f, 0.4f, 3.7f}, Wood);
    b.Box({2.45f, 0, 3.4f}, {2.6f, 0.4f, 3.7f}, Wood);
    b.Cylinder({-2.8f, 0, 3.6f}, 0.05f, 2.2f, 8, Stone);
    b.Sphere({-2.8f, 2.35f, 3.6f}, 0.18f, 8, 12, Marble);
    b.Box({-0.4f, 0, -4.2f}, {0.4f, 0.8f, -3.4f}, Stone);
    b.Sphere({0, 1.25f, -3.8f}, 0.45f, 12, 16, Marble);

    // Radii: what DefaultLightRadius gives lights without a stated size, 2 % of each light's
    // distance to the centre of the scene's box ([-7, -0.3, -7] - [7, 4.39, 7]), written out
    // so the scene states its lights' sizes like a scene file would (a test holds the two
    // together): 0.02 · 8.644 and 0.02 · 8.197.
    constexpr float kKeyRadius = 0.173f, kFillRadius = 0.164f;
    scene.lights = {
        // A warm key light behind-left, so shadows fall towards the camera, and a cool fill.
        {{-5.5f, 8.0f, -3.0f}, Color(85.0f, 80.0f, 70.0f), Falloff::InverseSquare, kKeyRadius},
        {{7.0f, 5.5f, -2.5f}, Color(22.0f, 25.0f, 32.0f), Falloff::InverseSquare, kFillRadius},
    };
    scene.camera = Camera{{7.5f, 4.6f, 9.5f}, {0.0f, 1.3f, 0.0f}, {0, 1, 0}, 42.0f};
    scene.ambient = Color(0.06f, 0.065f, 0.075f);
    scene.background = Color(0.55f, 0.7f, 0.9f);
    scene.render.width = 800;
    scene.render.height = 600;
    scene.report.sources.push_back(scene.name);
    return scene;
}

}  // namespace

std::vector<std::string> BuiltinSceneNames() { return {"gazebo"}; }

Scene MakeBuiltinScene(std::string_view name) {
    if (name == "gazebo") return MakeGazebo();
    ThrowError("unknown built-in scene \"builtin:%.*s\" (available: builtin:gazebo)",
               static_cast<int>(name.size()), name.data());
}

}  // namespace lm
