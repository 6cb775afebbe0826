// scene_textures.cpp -- a model's images read into the scene (scene_load.h: AttachTextures).
#include <algorithm>
#include <cmath>

#include "lightmesh/scene/scene_load.h"

#include "lightmesh/geometry/cutouts.h"
#include "lightmesh/geometry/instances.h"

namespace lm::scene_load {

void AttachTextures(const json::Reader& r, const std::string& model, bool enabled, TextureCache* cache,
                    LoadedMesh* loaded, Scene* scene) {
    // The images the materials use, decoded together (one child process for the model).
    std::vector<int> used;
    if (enabled)
        for (const Material& m : loaded->materials)
            for (int index : {m.texture, m.alphaTexture})
                if (index >= 0 && std::find(used.begin(), used.end(), index) == used.end()) used.push_back(index);
    std::vector<TextureSource> sources;
    for (int index : used) sources.push_back(std::move(loaded->textures[static_cast<size_t>(index)]));
    const std::vector<int> got =
        cache->GetAll(sources, model, &scene->textures, [&](const std::string& w) { r.Warn(w); });
    auto get = [&](int index) {
        const auto at = std::find(used.begin(), used.end(), index);
        return at == used.end() ? -1 : got[static_cast<size_t>(at - used.begin())];
    };
    bool any = false;
    for (Material& m : loaded->materials) {
        m.texture = get(m.texture);
        m.alphaTexture = get(m.alphaTexture);
        if (m.alphaTexture < 0) m.alphaSource = Material::AlphaSource::None;
        any = any || m.texture >= 0 || m.alphaTexture >= 0;
    }
    loaded->textures.clear();  // read into the scene (their bytes moved out above)
    if (!any) loaded->mesh.uvs.clear();
}

namespace {

/// Whether every texel the bilinear lookups on triangle `t` can read (its texture
/// coordinates' box, a texel more each way) is solid: then so is every value between them,
/// and the triangle is opaque. False past 65,536 texels (not looked at).
bool WhollySolid(const TriangleMesh& mesh, uint32_t t, const CutoutMaterial& m) {
    const auto& tri = mesh.triangles[t];
    float u0 = Infinity, u1 = -Infinity, v0 = Infinity, v1 = -Infinity;
    for (uint32_t k : tri) {
        u0 = std::min(u0, mesh.uvs[k].u), u1 = std::max(u1, mesh.uvs[k].u);
        v0 = std::min(v0, mesh.uvs[k].v), v1 = std::max(v1, mesh.uvs[k].v);
    }
    const int w = m.image->Width(), h = m.image->Height();
    if (!(u1 - u0 < 64.0f && v1 - v0 < 64.0f)) return false;
    const float x0 = std::floor(u0 * static_cast<float>(w) - 0.5f) - 1, x1 = std::floor(u1 * static_cast<float>(w) - 0.5f) + 2;
    const float y0 = std::floor((1 - v1) * static_cast<float>(h) - 0.5f) - 1,
                y1 = std::floor((1 - v0) * static_cast<float>(h) - 0.5f) + 2;
    if (!((x1 - x0 + 1) * (y1 - y0 + 1) <= 65536.0f)) return false;
    for (int y = static_cast<int>(y0); y <= static_cast<int>(y1); ++y)
        for (int x = static_cast<int>(x0); x <= static_cast<int>(x1); ++x)
            if (!(m.image->TexelOpacity(x, y, m.wrapU, m.wrapV, m.fromRed ? 0 : 3) * m.scale >= m.cutoff))
                return false;
    return true;
}

}  // namespace

void BuildCutouts(Scene* scene) {
    scene->mesh.cutouts.reset();
    scene->mesh.cutouts = MakeCutouts(scene->mesh, *scene, scene->mesh.instances);
}

std::shared_ptr<const CutoutMask> MakeCutouts(const TriangleMesh& mesh, const Scene& scene,
                                              std::shared_ptr<const InstancedMeshes> instances) {
    bool instancedCutouts = false;
    if (instances)
        for (const TriangleMesh& p : instances->Prototypes()) instancedCutouts |= p.cutouts != nullptr;
    if (!instancedCutouts) instances.reset();
    std::vector<CutoutMaterial> entries;
    std::vector<int32_t> entryOf(scene.materials.size(), -1);
    for (size_t i = 0; i < scene.materials.size(); ++i) {
        const Material& m = scene.materials[i];
        if (m.alphaTexture < 0 || m.alphaSource == Material::AlphaSource::None) continue;
        const auto& image = scene.textures[static_cast<size_t>(m.alphaTexture)];
        const bool hasAlpha = image->HasAlpha();
        if (m.alphaSource == Material::AlphaSource::AlphaIfAny && !hasAlpha) continue;
        CutoutMaterial c;
        c.image = image;
        c.cutoff = m.alphaCutoff;
        c.scale = m.alphaScale;
        c.wrapU = m.wrapU, c.wrapV = m.wrapV;
        c.fromRed = m.alphaSource == Material::AlphaSource::OpacityMap && !hasAlpha;
        entryOf[i] = static_cast<int32_t>(entries.size());
        entries.push_back(std::move(c));
    }
    std::vector<int32_t> perTriangle(mesh.TriangleCount(), -1);
    bool any = false;
    if (!entries.empty() && !mesh.uvs.empty()) {
        for (size_t t = 0; t < perTriangle.size(); ++t) {
            const uint32_t m = mesh.materialIds[t];
            if (m < entryOf.size()) perTriangle[t] = entryOf[m];
            // A triangle whose image is solid under all of it is opaque: no alpha test on its
            // hits, and it may certify umbrae.
            if (perTriangle[t] >= 0 &&
                WhollySolid(mesh, static_cast<uint32_t>(t), entries[static_cast<size_t>(perTriangle[t])]))
                perTriangle[t] = -1;
            any = any || perTriangle[t] >= 0;
        }
    }
    if (!any && !instances) return nullptr;
    return std::make_shared<const CutoutMask>(perTriangle, std::move(entries), std::move(instances));
}

}  // namespace lm::scene_load
