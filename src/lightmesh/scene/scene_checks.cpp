// scene_checks.cpp -- what every scene must satisfy before a ray is traced, whatever its
// source: coordinates within what single precision and Embree take, a camera that forms
// an image, lights outside closed solids, materials and triangles that agree.
#include "lightmesh/scene/scene_load.h"

#include <cmath>
#include <optional>

#include "lightmesh/geometry/instances.h"
#include "lightmesh/geometry/mesh.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm::scene_load {

using namespace json;  // Reader

std::string FormatVec(const Vec3& v) {
    return StringPrintf("(%.4g, %.4g, %.4g)", v.x, v.y, v.z);
}

std::string DroppedMessage(const CleanReport& c) {
    // "1 degenerate (zero-area) triangle", "6,510 duplicate triangles".
    auto count = [](size_t n, const char* kind) {
        return FormatCount(n) + " " + kind + (n == 1 ? " triangle" : " triangles");
    };
    if (c.degenerate && c.duplicate)
        return "dropped " + FormatCount(c.degenerate) + " degenerate (zero-area) and " +
               count(c.duplicate, "duplicate");
    if (c.degenerate) return "dropped " + count(c.degenerate, "degenerate (zero-area)");
    return "dropped " + count(c.duplicate, "duplicate");
}

float Reach(const Vec3& p) {
    return MaxComponent(Abs(p));
}

/// "coordinates reach R, beyond ...": why a mesh reaching `reach` cannot be rendered.
std::string CoordinatesBeyondLimit(float reach) {
    return StringPrintf("coordinates reach %g, beyond the ±%g that single-precision rendering allows "
                        "(scale the model down)",
                        double(reach), double(kMaxCoordinate));
}

/// "" when p can be used in a ray, else why not.
std::string CoordinateProblem(const Vec3& p, const char* what) {
    if (!IsFinite(p)) return StringPrintf("%s %s is not finite", what, FormatVec(p).c_str());
    if (!(Reach(p) <= kMaxCoordinate))
        return StringPrintf("%s %s is beyond the ±%g that single-precision rendering allows",
                            what, FormatVec(p).c_str(), double(kMaxCoordinate));
    return "";
}

/// Why the camera cannot form an image, or "" if it can; `*key` is the key to blame.
/// The same criteria as CameraRays.
std::string CameraProblem(const Camera& c, std::string* key) {
    const Vec3 view = c.lookAt - c.position;
    *key = "look_at";
    if (!(LengthSquared(view) > 0) || !IsFinite(view))
        return "equals the position, so the camera has no view direction";
    *key = "fov";
    if (!(c.fovY > 0 && c.fovY < 180))
        return StringPrintf("must be between 0 and 180 degrees, got %g", c.fovY);
    *key = "up";
    if (!(LengthSquared(c.up) > 0)) return "must not be zero";
    if (!(Length(Cross(Normalize(view), c.up)) > 1e-6f * Length(c.up)))
        return "is parallel to the view direction (from position to look_at)";
    return "";
}

/// Segments between the mesh and the lights have directions up to the span of both: it
/// must stay below Embree's limit too (1.8e18).
std::string SpanProblem(const Scene& scene) {
    Bounds3 b = scene.mesh.Bounds();
    for (const PointLight& l : scene.lights) b.Extend(l.position);
    b.Extend(scene.camera.position);
    const float span = MaxComponent(b.Diagonal());
    if (!(span <= 1.8e18f))
        return StringPrintf("the scene (meshes, ground, camera and lights) spans %g, more than the "
                            "1.8e+18 that single-precision ray queries allow",
                            double(span));
    return "";
}

/// Why every triangle is degenerate, when single precision is to blame.
std::string PrecisionHint(const TriangleMesh& mesh) {
    Bounds3 b;
    for (const Vec3& p : mesh.positions)
        if (IsFinite(p)) b.Extend(p);
    if (mesh.positions.empty() || !IsFinite(b.lo) || !IsFinite(b.hi)) return "";
    const float reach = std::max(Reach(b.lo), Reach(b.hi));
    const float extent = b.MaxExtent();
    // Edges this long overflow the normal's cross product to infinity (CleanMesh).
    if (reach > kMaxCoordinate) return ": its " + CoordinatesBeyondLimit(reach);
    if (reach > 0 && reach < 1e-30f)
        return StringPrintf(": its coordinates are at most %g, below what single precision "
                            "resolves (scale the model up)",
                            double(reach));
    // All vertices equal far from the origin, or a span below float's resolution there.
    if ((extent == 0 && reach >= 1e6f) || (extent > 0 && extent < reach * 1e-6f))
        return StringPrintf(": at coordinates around %g single precision cannot tell its "
                            "vertices apart (they span %g; move the model nearer the origin)",
                            double(reach), double(extent));
    return "";
}

void CheckExtent(const Reader& r, const std::string& path, const Scene& scene) {
    const Bounds3 b = scene.mesh.Bounds();
    if (!IsFinite(b.lo) || !IsFinite(b.hi) || !IsFinite(b.Diagonal()))
        r.Fail(path, "the scene's bounding box is not finite (coordinates too large?)");
    if (!(b.MaxExtent() > 0)) r.Fail(path, "the scene has zero extent");
    // Beyond ±1e18, ray set-up, light-mesh node positions and shading overflow to inf or NaN.
    const float reach = std::max(MaxComponent(Abs(b.lo)), MaxComponent(Abs(b.hi)));
    if (reach > kMaxCoordinate) r.Fail(path, "the scene's " + CoordinatesBeyondLimit(reach));
}

/// Whether p is inside a closed solid of the mesh: the number of surfaces crossed on the
/// way out of the scene's box is odd along each of six spread-out directions -- the parity
/// rule of the light mesh's inside test (СТ). Unanimity, rather than a majority, keeps an
/// open shape (a lampshade, a room without a ceiling) from being taken for a solid. Counted
/// over every triangle, an open surface crossed on some ways out (a floor under a box) makes
/// those counts even, so the test is made again over the closed parts alone (*parts,
/// found on first need): inside either way is inside.
bool InsideASolid(const TriangleMesh& mesh, const Bounds3& box, const Vec3& p, std::optional<ClosedParts>* parts) {
    if (!box.Contains(p)) return false;
    const float reach = 1.01f * Length(box.Diagonal()) + 1.0f;
    const Vec3 directions[6] = {{1, 0.37f, 0.21f},  {-0.29f, 1, 0.43f},   {0.31f, -0.23f, 1},
                                {-1, -0.41f, 0.17f}, {0.19f, -1, -0.33f}, {-0.27f, 0.13f, -1}};
    auto inside = [&](const ClosedParts* only) {
        for (const Vec3& d : directions) {
            const Vec3 out = p + Normalize(d) * reach;
            if (!IsFinite(out)) return false;  // no room to test in float; assume outside
            const Ray segment = Segment(p, out);
            if (((only ? CountCrossings(mesh, segment, *only) : CountCrossings(mesh, segment)) & 1) == 0) return false;
        }
        return true;
    };
    if (inside(nullptr)) return true;
    if (!*parts) *parts = FindClosedParts(mesh);
    return inside(&**parts);
}

/// Fails on the first light inside a closed solid that the camera is outside of: it would
/// light nothing the camera sees, and the light mesh method (paper §4) assumes every light
/// is outside the objects. A camera inside a closed surface itself is in a room (walls,
/// floor and ceiling of single faces, closed): its lights are inside it too, and light
/// what the camera sees; for them the parity rule cannot tell a room from a solid, so
/// they are not refused. (The inside flags of СТ then count a node inside the room as
/// outside with two lights or more: no surface lies between it and the room's lights.
/// With one light, its vote is outvoted by the two exits through the room's walls, every
/// node of the room is flagged inside, and СТ falls back to P's shadow rays.)
void CheckLightsOutsideSolids(const Reader& r, const Scene& scene, const std::string& lightsPath) {
    const Bounds3 box = scene.mesh.Bounds();
    std::optional<ClosedParts> parts;
    if (InsideASolid(scene.mesh, box, scene.camera.position, &parts)) return;
    for (size_t i = 0; i < scene.lights.size(); ++i) {
        if (!box.Contains(scene.lights[i].position)) continue;
        if (InsideASolid(scene.mesh, box, scene.lights[i].position, &parts))
            r.Fail(lightsPath.empty() ? std::string() : Index(lightsPath, i) + "/position",
                   "the light " + FormatVec(scene.lights[i].position) +
                       " is inside a closed object, so it would light nothing (lights must be "
                       "outside solids: move it or the object)");
    }
}

/// "no triangles", with the reason when one is known.
std::string NoTrianglesMessage(const SceneReport& report, const TriangleMesh& mesh) {
    if (report.degenerateRemoved > 0) {
        if (std::string hint = PrecisionHint(mesh); !hint.empty())
            return StringPrintf("all %zu triangles are degenerate in single precision%s",
                                report.degenerateRemoved, hint.c_str());
        return StringPrintf(
            "the scene has zero extent: all %zu triangles are degenerate (zero area)",
            report.degenerateRemoved);
    }
    if (report.meshesExcluded > 0)
        return StringPrintf("the scene has no triangles: all %zu meshes were excluded",
                            report.meshesExcluded);
    return "the scene has no triangles";
}

/// Checks that hold for every scene, whatever its source.
void Validate(const Scene& scene) {
    const std::string& name = scene.name;
    if (scene.lights.empty()) ThrowErrorAt({name}, "the scene has no lights");
    for (size_t i = 0; i < scene.lights.size(); ++i) {
        const PointLight& l = scene.lights[i];
        const Color& c = l.intensity;
        if (!IsFinite(l.position) || !std::isfinite(c.r) || !std::isfinite(c.g) ||
            !std::isfinite(c.b) || c.r < 0 || c.g < 0 || c.b < 0)
            ThrowError(
                "%s: light %zu has a non-finite position or a negative or non-finite intensity",
                name.c_str(), i);
        if (!(std::isfinite(l.radius) && l.radius >= 0))
            ThrowError("%s: light %zu has a negative or non-finite radius (%g)", name.c_str(), i,
                       static_cast<double>(l.radius));
        if (!(l.range > 0))
            ThrowError("%s: light %zu has a range of %g: must be greater than 0", name.c_str(), i,
                       static_cast<double>(l.range));
    }
    std::string key;
    if (std::string problem = CameraProblem(scene.camera, &key); !problem.empty())
        ThrowErrorAt({name}, "camera %s %s", key.c_str(), problem.c_str());
    if (scene.mesh.materialIds.size() != scene.mesh.triangles.size())
        ThrowErrorAt({name}, "every triangle needs a material");
    for (uint32_t id : scene.mesh.materialIds)
        if (id >= scene.materials.size())
            ThrowErrorAt({name}, "a triangle refers to material %u, which does not exist",
                       id);
    for (const Vec3& p : scene.mesh.positions)
        if (!IsFinite(p)) ThrowErrorAt({name}, "a vertex has a non-finite coordinate");
    if (!scene.mesh.instances) return;
    for (const TriangleMesh& proto : scene.mesh.instances->Prototypes()) {
        if (proto.materialIds.size() != proto.triangles.size()) ThrowErrorAt({name}, "every triangle needs a material");
        for (uint32_t id : proto.materialIds)
            if (id >= scene.materials.size())
                ThrowErrorAt({name}, "a triangle refers to material %u, which does not exist", id);
    }
    const Bounds3 b = scene.mesh.instances->Bounds();
    if (!IsFinite(b.lo) || !IsFinite(b.hi)) ThrowErrorAt({name}, "a vertex has a non-finite coordinate");
}

}  // namespace lm::scene_load
