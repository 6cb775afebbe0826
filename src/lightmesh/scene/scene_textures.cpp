// scene_textures.cpp -- a model's images read into the scene (scene_load.h: AttachTextures).
#include <algorithm>

#include "lightmesh/scene/scene_load.h"

namespace lm::scene_load {

void AttachTextures(const json::Reader& r, const std::string& model, bool enabled, TextureCache* cache,
                    LoadedMesh* loaded, Scene* scene) {
    bool any = false;
    for (Material& m : loaded->materials) {
        if (m.texture < 0) continue;
        m.texture = enabled ? cache->Get(loaded->textures[static_cast<size_t>(m.texture)], model,
                                         &scene->textures, [&](const std::string& w) { r.Warn(w); })
                            : -1;
        any = any || m.texture >= 0;
    }
    if (!any) loaded->mesh.uvs.clear();
}

}  // namespace lm::scene_load
