// cutout_scenes.h -- the alpha cut-out test scene the back-ends' and shadow methods' tests share.
#pragma once

#include <string>
#include <vector>

#include "lightmesh/scene/scene_file.h"

namespace lm::testing {

/// The folder of the texture and cut-out test files (tests/data/textures).
inline std::string TextureDataDir() { return std::string(LIGHTMESH_TEST_DATA) + "/textures"; }

/// checker_mask.gltf (a 4 × 4 quad at y = 1 whose alpha is an 8 × 8 checker, MASK at 0.5)
/// above a ground slab, lit from straight above by a light of radius 0.3; `textures` false
/// loads it with solid surfaces (--no-textures).
inline Scene CheckerScene(bool textures = true) {
    SceneLoadOptions o;
    o.textures = textures;
    o.text = R"({"camera": {"position": [0, 10, 10], "look_at": [0, 0, 0]},
                 "lights": [{"position": [0, 50, 0], "intensity": 2500, "radius": 0.3}],
                 "meshes": [{"file": "checker_mask.gltf"}],
                 "ground": {"height": 0, "size": 3}})";
    std::vector<std::string> warnings;
    return LoadScene(TextureDataDir() + "/checker_scene.json", o, &warnings);
}

}  // namespace lm::testing
