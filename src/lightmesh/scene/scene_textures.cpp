// scene_textures.cpp -- a model's images read into the scene (scene_load.h: AttachTextures).
#include <algorithm>

#include "lightmesh/scene/scene_load.h"

#include "lightmesh/geometry/cutouts.h"

namespace lm::scene_load {

void AttachTextures(const json::Reader& r, const std::string& model, bool enabled, TextureCache* cache,
                    LoadedMesh* loaded, Scene* scene) {
    bool any = false;
    auto get = [&](int index) {
        if (index < 0 || !enabled) return -1;
        return cache->Get(loaded->textures[static_cast<size_t>(index)], model, &scene->textures,
                          [&](const std::string& w) { r.Warn(w); });
    };
    for (Material& m : loaded->materials) {
        m.texture = get(m.texture);
        m.alphaTexture = get(m.alphaTexture);
        if (m.alphaTexture < 0) m.alphaSource = Material::AlphaSource::None;
        any = any || m.texture >= 0 || m.alphaTexture >= 0;
    }
    if (!any) loaded->mesh.uvs.clear();
}

void BuildCutouts(Scene* scene) {
    scene->mesh.cutouts.reset();
    std::vector<CutoutMaterial> entries;
    std::vector<int32_t> entryOf(scene->materials.size(), -1);
    for (size_t i = 0; i < scene->materials.size(); ++i) {
        const Material& m = scene->materials[i];
        if (m.alphaTexture < 0 || m.alphaSource == Material::AlphaSource::None) continue;
        const auto& image = scene->textures[static_cast<size_t>(m.alphaTexture)];
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
    if (entries.empty() || scene->mesh.uvs.empty()) return;
    std::vector<int32_t> perTriangle(scene->mesh.TriangleCount(), -1);
    bool any = false;
    for (size_t t = 0; t < perTriangle.size(); ++t) {
        const uint32_t m = scene->mesh.materialIds[t];
        if (m < entryOf.size()) perTriangle[t] = entryOf[m];
        any = any || perTriangle[t] >= 0;
    }
    if (any) scene->mesh.cutouts = std::make_shared<const CutoutMask>(perTriangle, std::move(entries));
}

}  // namespace lm::scene_load
