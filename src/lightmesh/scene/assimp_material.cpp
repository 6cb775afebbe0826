// assimp_material.cpp -- materials: how an Assimp material becomes a Phong material of
// formula (1) (MaterialFromFile; the mapping is written out above it).
#include "lightmesh/scene/mesh_import_internal.h"

#include <assimp/material.h>

#include <algorithm>
#include <cmath>
#include <string>

namespace lm {
namespace mesh_import {
namespace {

Color ToColor(const aiColor3D& c) {
    auto clean = [](float v) { return std::isfinite(v) && v > 0 ? v : 0.0f; };
    return {clean(c.r), clean(c.g), clean(c.b)};
}

Color Lerp(const Color& a, const Color& b, float t) {
    return a * (1 - t) + b * t;
}

}  // namespace

// How an Assimp material becomes a Phong material of formula (1):
//  - kd: AI_MATKEY_BASE_COLOR (glTF's baseColorFactor) if present, else
//    AI_MATKEY_COLOR_DIFFUSE (OBJ's Kd, Collada's diffuse, ...).
//  - Metallic-roughness materials (AI_MATKEY_METALLIC_FACTOR present: glTF 2):
//      kd     = base·(1 − metallic)               (metals have no diffuse reflection)
//      ks     = lerp(0.04, base, metallic)·(1 − roughness)
//               (dielectrics reflect ~4 %, metals their colour; a rough surface has no
//               visible highlight)
//      phong  = 2/α² − 2 with α = roughness², clamped to [1, 1000] (the Blinn-Phong
//               exponent of a GGX lobe of the same width)
//      mirror = base only if metallic ≥ 0.9 and roughness ≤ 0.1 (obviously polished metal).
//  - Other materials (OBJ/MTL, PLY, Collada, FBX, ...):
//      ks     = AI_MATKEY_COLOR_SPECULAR × AI_MATKEY_SHININESS_STRENGTH (default 1)
//      phong  = AI_MATKEY_SHININESS (OBJ's Ns) if > 0, else 32; clamped to ≤ 10000
//      mirror = AI_MATKEY_COLOR_REFLECTIVE × AI_MATKEY_REFLECTIVITY, only if the
//               reflectivity is ≥ 0.5: exporters write small values by default, which
//               would make every surface a faint mirror. MTL has no reflectivity.
//  - Assimp's stand-in for files without materials (PLY, STL, an OBJ without .mtl; glTF's
//    default material) becomes our default grey (kd 0.8, no specular) rather than
//    Assimp's 0.6 grey, white, or glTF's black-diffuse "white metal".
//  Transparency, emission, textures and vertex colours are ignored; negative or
//  non-finite values become 0.
Material MaterialFromFile(const aiMaterial& am) {
    Material m;
    aiString aname;
    const std::string name =
        am.Get(AI_MATKEY_NAME, aname) == AI_SUCCESS ? std::string(aname.C_Str()) : std::string();

    aiColor3D base(0.8f, 0.8f, 0.8f);
    const bool hasBase = am.Get(AI_MATKEY_BASE_COLOR, base) == AI_SUCCESS;
    if (!hasBase) am.Get(AI_MATKEY_COLOR_DIFFUSE, base);
    float metallic = 0, roughness = 1;
    const bool pbr = am.Get(AI_MATKEY_METALLIC_FACTOR, metallic) == AI_SUCCESS;
    am.Get(AI_MATKEY_ROUGHNESS_FACTOR, roughness);

    const bool standIn =
        (name.empty() || name == AI_DEFAULT_MATERIAL_NAME) &&
        (!pbr || (base.r == 1 && base.g == 1 && base.b == 1 && metallic == 1 && roughness == 1));
    if (standIn) return m;  // the default grey
    m.name = name.empty() ? "unnamed" : name;

    const Color kd = ToColor(base);
    if (pbr) {
        metallic = std::isfinite(metallic) ? std::clamp(metallic, 0.0f, 1.0f) : 0.0f;
        roughness = std::isfinite(roughness) ? std::clamp(roughness, 0.0f, 1.0f) : 1.0f;
        m.kd = kd * (1 - metallic);
        m.ks = Lerp(Color(0.04f), kd, metallic) * (1 - roughness);
        const float alpha2 = std::max(roughness * roughness * roughness * roughness, 1e-6f);
        m.phong = std::clamp(2.0f / alpha2 - 2.0f, 1.0f, 1000.0f);
        if (metallic >= 0.9f && roughness <= 0.1f) m.mirror = kd;
    } else {
        m.kd = kd;
        aiColor3D spec(0, 0, 0);
        float strength = 1, shininess = 0, reflectivity = 0;
        am.Get(AI_MATKEY_COLOR_SPECULAR, spec);
        am.Get(AI_MATKEY_SHININESS_STRENGTH, strength);
        am.Get(AI_MATKEY_SHININESS, shininess);
        if (!std::isfinite(strength) || strength < 0) strength = 0;
        m.ks = ToColor(spec) * strength;
        if (std::isfinite(shininess) && shininess > 0) m.phong = std::min(shininess, 10000.0f);
        if (am.Get(AI_MATKEY_REFLECTIVITY, reflectivity) == AI_SUCCESS &&
            std::isfinite(reflectivity) && reflectivity >= 0.5f) {
            aiColor3D reflective(1, 1, 1);
            am.Get(AI_MATKEY_COLOR_REFLECTIVE, reflective);
            m.mirror = ToColor(reflective) * std::min(reflectivity, 1.0f);
        }
    }
    return m;
}

}  // namespace mesh_import
}  // namespace lm
