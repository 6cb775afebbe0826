// cmd_info.cpp -- `lightmesh info`.
#include "commands.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <utility>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/geometry/cutouts.h"
#include "lightmesh/geometry/instances.h"
#include "lightmesh/util/log.h"

namespace lm::cli {

namespace {
// A spot's cone or the sun's direction and size, under its light's line.
std::string LightKindLine(const lm::PointLight& l) {
    const double deg = 180.0 / 3.14159265358979323846;
    if (l.kind == lm::LightKind::Spot)
        return lm::StringPrintf("           spot towards [%g %g %g], cone %g° inside %g°", l.spot.direction.x,
                                l.spot.direction.y, l.spot.direction.z, std::acos(l.spot.cosInner) * deg,
                                std::acos(l.spot.cosOuter) * deg);
    return lm::StringPrintf("           the sun, shining towards [%g %g %g], angular radius %g° (a far sphere)",
                            l.sun.direction.x, l.sun.direction.y, l.sun.direction.z, l.sun.angle * deg);
}
}  // namespace


int RunInfo(const CommonOptions& common, const std::string& accelName, int grid) {
    ApplyLogLevel(common);
    lm::Scene scene = LoadWithWarnings(common);
    const lm::Bounds3 b = scene.mesh.Bounds();
    lm::EdgeReport edges = lm::AnalyzeEdges(scene.mesh);
    // Instances: each counted as its prototype (copies share no vertex).
    std::vector<size_t> placed;  // instances per prototype
    if (scene.mesh.instances) {
        const auto& inst = *scene.mesh.instances;
        placed.assign(inst.Prototypes().size(), 0);
        for (const lm::MeshInstance& in : inst.Instances()) ++placed[in.prototype];
        for (size_t p = 0; p < placed.size(); ++p) {
            const lm::EdgeReport e = lm::AnalyzeEdges(inst.Prototypes()[p]);
            edges.edges += e.edges * placed[p], edges.open += e.open * placed[p];
            edges.nonManifold += e.nonManifold * placed[p];
        }
    }
    std::printf("scene      %s\n", scene.name.c_str());
    // Each file once, with how many times the scene places it.
    std::vector<std::pair<std::string, size_t>> sources;
    std::unordered_map<std::string, size_t> sourceIndex;
    for (const std::string& s : scene.report.sources) {
        const auto [it, added] = sourceIndex.emplace(s, sources.size());
        if (added) sources.emplace_back(s, 1);
        else ++sources[it->second].second;
    }
    for (const auto& [s, n] : sources)
        std::printf("source     %s%s\n", s.c_str(), n > 1 ? lm::StringPrintf(" (placed %s times)", Count(n).c_str()).c_str() : "");
    std::printf("triangles  %s (removed: %s degenerate, %s duplicate; meshes excluded: %zu)\n",
                Count(scene.mesh.PrimCount()).c_str(), Count(scene.report.degenerateRemoved).c_str(),
                Count(scene.report.duplicatesRemoved).c_str(), scene.report.meshesExcluded);
    if (scene.mesh.instances) {
        const auto& inst = *scene.mesh.instances;
        size_t protoTriangles = 0;
        for (const lm::TriangleMesh& p : inst.Prototypes()) protoTriangles += p.TriangleCount();
        const size_t flatBytes = inst.FlattenedBytes();  // what the instanced triangles take flattened
        std::printf("instances  %s of %zu prototype%s (%s triangles), standing for %s triangles; %s (flattened: %s); "
                    "%s flat triangles\n",
                    Count(inst.Instances().size()).c_str(), inst.Prototypes().size(),
                    inst.Prototypes().size() == 1 ? "" : "s", Count(protoTriangles).c_str(),
                    Count(inst.TriangleCount()).c_str(), lm::FormatBytes(inst.Bytes()).c_str(),
                    lm::FormatBytes(flatBytes).c_str(), Count(scene.mesh.TriangleCount()).c_str());
    }
    size_t protoVertices = 0;
    if (scene.mesh.instances)
        for (const lm::TriangleMesh& p : scene.mesh.instances->Prototypes()) protoVertices += p.positions.size();
    std::printf("vertices   %s%s%s\n", Count(scene.mesh.positions.size()).c_str(),
                protoVertices ? lm::StringPrintf(" and %s in prototypes", Count(protoVertices).c_str()).c_str() : "",
                scene.mesh.normals.empty() && (!protoVertices || scene.mesh.instances->Prototypes()[0].normals.empty())
                    ? ""
                    : " (with shading normals)");
    std::printf("bounds     [%g %g %g] - [%g %g %g], size %g x %g x %g\n", b.lo.x, b.lo.y, b.lo.z,
                b.hi.x, b.hi.y, b.hi.z, b.Diagonal().x, b.Diagonal().y, b.Diagonal().z);
    std::printf("edges      %s: %s open, %s non-manifold -> %s\n", Count(edges.edges).c_str(),
                Count(edges.open).c_str(), Count(edges.nonManifold).c_str(),
                edges.Closed() ? "every object is a closed solid"
                               : "not all objects are closed solids (the inside-object test is unreliable there)");
    // The scene file's "render": {"light_radius"} replaces every light's own radius when rendering.
    const std::optional<float>& radiusOverride = scene.render.areaLight.radius;
    std::printf("lights     %zu%s\n", scene.lights.size(),
                radiusOverride ? lm::StringPrintf(" (rendered with every radius %g: the scene's \"light_radius\")",
                                                  static_cast<double>(*radiusOverride)).c_str()
                               : "");
    // Many lights: the first kListed and a summary of the rest (-v lists them all).
    constexpr size_t kListed = 16;
    const size_t listed = common.verbose ? scene.lights.size() : std::min(scene.lights.size(), kListed);
    for (size_t i = 0; i < listed; ++i) {
        const lm::PointLight& l = scene.lights[i];
        std::printf("  light %zu  at [%g %g %g], intensity [%g %g %g], falloff %s, radius %g%s%s\n", i, l.position.x,
                    l.position.y, l.position.z, l.intensity.r, l.intensity.g, l.intensity.b,
                    l.falloff == lm::Falloff::None ? "none" : "inverse_square", l.radius,
                    l.radius == 0 ? " (a point)" : "",
                    std::isfinite(l.range) ? lm::StringPrintf(", range %g", static_cast<double>(l.range)).c_str() : "");
        if (l.kind != lm::LightKind::Point) std::printf("%s\n", LightKindLine(l).c_str());
    }
    if (listed < scene.lights.size()) {
        float rlo = INFINITY, rhi = 0, glo = INFINITY, ghi = 0;
        size_t ranged = 0;
        for (size_t i = listed; i < scene.lights.size(); ++i) {
            const lm::PointLight& l = scene.lights[i];
            rlo = std::min(rlo, l.radius), rhi = std::max(rhi, l.radius);
            if (std::isfinite(l.range)) ++ranged, glo = std::min(glo, l.range), ghi = std::max(ghi, l.range);
        }
        auto span = [](float lo, float hi) {
            return lo == hi ? lm::StringPrintf("%g", static_cast<double>(lo))
                            : lm::StringPrintf("%g to %g", static_cast<double>(lo), static_cast<double>(hi));
        };
        std::printf("  and %s more: radius %s, %s with a range%s (-v lists every light)\n",
                    Count(scene.lights.size() - listed).c_str(), span(rlo, rhi).c_str(), Count(ranged).c_str(),
                    ranged ? (" (" + span(glo, ghi) + ")").c_str() : "");
    }
    std::vector<size_t> uses(scene.materials.size());
    for (uint32_t m : scene.mesh.materialIds) ++uses[m];
    for (size_t p = 0; p < placed.size(); ++p)
        for (uint32_t m : scene.mesh.instances->Prototypes()[p].materialIds) uses[m] += placed[p];
    std::printf("materials  %zu\n", scene.materials.size());
    for (size_t i = 0; i < scene.materials.size(); ++i) {
        const lm::Material& m = scene.materials[i];
        std::string images;
        if (m.texture >= 0) images += lm::StringPrintf(", texture %d", m.texture);
        if (m.alphaTexture >= 0 && m.alphaSource != lm::Material::AlphaSource::None)
            images += lm::StringPrintf(", cut-out by image %d below %g", m.alphaTexture, static_cast<double>(m.alphaCutoff));
        std::printf("  %-12s kd [%g %g %g], ks [%g %g %g], phong %g, mirror [%g %g %g]%s; %s triangles\n",
                    m.name.c_str(), m.kd.r, m.kd.g, m.kd.b, m.ks.r, m.ks.g, m.ks.b, m.phong,
                    m.mirror.r, m.mirror.g, m.mirror.b, images.c_str(), Count(uses[i]).c_str());
    }
    if (!scene.textures.empty()) {
        size_t bytes = 0;
        for (const auto& t : scene.textures) bytes += t->Bytes();
        std::printf("textures   %zu image%s, %s with mip-maps; %s cut-out triangles%s\n", scene.textures.size(),
                    scene.textures.size() == 1 ? "" : "s", lm::FormatBytes(bytes).c_str(),
                    Count(scene.mesh.cutouts ? scene.mesh.cutouts->Count() : 0).c_str(),
                    scene.mesh.cutouts ? (" (their texel cells' table " + lm::FormatBytes(scene.mesh.cutouts->Bytes()) + ")").c_str() : "");
        for (size_t i = 0; i < scene.textures.size(); ++i)
            std::printf("  image %zu  %d x %d%s\n", i, scene.textures[i]->Width(), scene.textures[i]->Height(),
                        scene.textures[i]->HasAlpha() ? ", with alpha" : "");
    }
    const lm::Camera& cam = scene.camera;
    std::printf("camera     at [%g %g %g] looking at [%g %g %g], fov %g\n", cam.position.x,
                cam.position.y, cam.position.z, cam.lookAt.x, cam.lookAt.y, cam.lookAt.z, cam.fovY);
    lm::AccelOptions accelOptions = scene.render.accelOptions;
    if (grid >= 0) accelOptions.gridResolution = grid;
    const std::string name = accelName.empty() ? scene.render.accel : accelName;
    if (grid >= 0)
        if (const std::string unused = lm::UnusedSettingWarning("grid", name); !unused.empty())
            lm::LogWarning(unused);
    const auto t = Clock::now();
    auto accel = lm::CreateAccelerator(name, scene.mesh, accelOptions);
    std::printf("accel      %s, built in %.3f s\n", name.c_str(), SecondsSince(t));
    PrintFigures("  figures", accel->Figures());
    return 0;
}

}  // namespace lm::cli
