// assimp_material.cpp -- materials: how an Assimp material becomes a Phong material of
// formula (1) (MaterialFromFile; the mapping is written out above it).
#include "lightmesh/scene/mesh_import_internal.h"

#include <assimp/GltfMaterial.h>
#include <assimp/material.h>
#include <assimp/scene.h>
#include <assimp/texture.h>

#include <algorithm>
#include <unistd.h>

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

TextureWrap ToWrap(aiTextureMapMode mode) {
    switch (mode) {
        case aiTextureMapMode_Clamp:
        case aiTextureMapMode_Decal: return TextureWrap::Clamp;
        case aiTextureMapMode_Mirror: return TextureWrap::Mirror;
        default: return TextureWrap::Repeat;
    }
}

/// The folder of `path`, with a trailing '/', or "" for a bare file name.
std::string FolderOf(const std::string& path) {
    const size_t slash = path.find_last_of('/');
    return slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
}

/// The image a material's texture slot of `type` names, appended to *textures: the bytes
/// the file embeds ("*N", or a name the scene's embedded textures carry), else a file
/// beside the model (Windows separators turned; tried as written, then by its base name in
/// the model's folder). Returns its index, or -1 when the slot is empty.
int FindTexture(const aiMaterial& am, aiTextureType type, const aiScene& scene, const std::string& modelPath,
                std::vector<TextureSource>* textures, TextureWrap* wrapU, TextureWrap* wrapV) {
    if (am.GetTextureCount(type) == 0) return -1;
    aiString apath;
    aiTextureMapMode modes[2] = {aiTextureMapMode_Wrap, aiTextureMapMode_Wrap};
    if (am.GetTexture(type, 0, &apath, nullptr, nullptr, nullptr, nullptr, modes) != AI_SUCCESS) return -1;
    std::string path = apath.C_Str();
    // Assimp's Blender reader names a procedural texture (marble, clouds, ...) so: not an
    // image, and nothing lightmesh draws; the material keeps its flat colour.
    if (path.empty() || path.rfind("Procedural,", 0) == 0) return -1;
    if (wrapU) *wrapU = ToWrap(modes[0]);
    if (wrapV) *wrapV = ToWrap(modes[1]);
    TextureSource source;
    if (const aiTexture* embedded = scene.GetEmbeddedTexture(path.c_str())) {
        source.name = path[0] == '*' ? "embedded image " + path.substr(1) : path;
        if (embedded->mHeight == 0) {
            source.bytes.assign(reinterpret_cast<const char*>(embedded->pcData), embedded->mWidth);
        } else if (embedded->pcData) {
            source.rawWidth = static_cast<int>(embedded->mWidth);
            source.rawHeight = static_cast<int>(embedded->mHeight);
            source.bytes.assign(reinterpret_cast<const char*>(embedded->pcData),
                                static_cast<size_t>(embedded->mWidth) * embedded->mHeight * 4);
        }
    } else {
        source.name = path;
        for (char& c : path)
            if (c == '\\') c = '/';
        if (path.rfind("file://", 0) == 0) path = path.substr(7);
        if (path.rfind("//", 0) == 0) path = path.substr(2);  // Blender's "relative to the .blend file"
        const std::string folder = FolderOf(modelPath);
        std::string file = !path.empty() && path[0] == '/' ? path : folder + path;
        if (access(file.c_str(), F_OK) != 0) {
            const std::string base = path.substr(path.find_last_of('/') + 1);
            if (access((folder + base).c_str(), F_OK) == 0) file = folder + base;
        }
        source.file = file;
    }
    for (size_t i = 0; i < textures->size(); ++i) {
        const TextureSource& t = (*textures)[i];
        if (t.file == source.file && t.name == source.name) return static_cast<int>(i);
    }
    textures->push_back(std::move(source));
    return static_cast<int>(textures->size() - 1);
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
//  - The base-colour texture (aiTextureType_BASE_COLOR, else DIFFUSE: glTF's
//    baseColorTexture, MTL's map_Kd, ...; the first UV channel, with the material's UV
//    transform applied by aiProcess_TransformUVCoords at import) makes the diffuse
//    reflectance textureScale × texel: glTF's factor × (1 − metallic), 1 for the others
//    (exporters write a default Kd beside map_Kd). kd stays the flat colour used where the
//    image cannot be read.
//  - Alpha cut-outs: glTF's alphaMode MASK (at alphaCutoff) and BLEND (as a mask at 0.5, with
//    a warning) on the base-colour image's alpha times baseColorFactor's; elsewhere an
//    opacity map (MTL map_d: its alpha, or its grey level) times the opacity (MTL d), else
//    the base-colour image's alpha channel where it has one.
//  Partial transparency, emission and vertex colours are ignored; negative or non-finite
//  values become 0.
Material MaterialFromFile(const aiMaterial& am, const aiScene& scene, const std::string& modelPath,
                          std::vector<TextureSource>* textures, std::vector<std::string>* warnings) {
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
    int texture = FindTexture(am, aiTextureType_BASE_COLOR, scene, modelPath, textures, &m.wrapU, &m.wrapV);
    if (texture < 0) texture = FindTexture(am, aiTextureType_DIFFUSE, scene, modelPath, textures, &m.wrapU, &m.wrapV);
    if (standIn && texture < 0) return m;  // the default grey
    m.name = name.empty() ? "unnamed" : name;
    m.texture = texture;

    // Alpha cut-outs (geometry/cutouts.h).
    aiString alphaMode;
    if (am.Get(AI_MATKEY_GLTF_ALPHAMODE, alphaMode) == AI_SUCCESS) {
        // glTF: MASK cuts at alphaCutoff (default 0.5); BLEND is rendered as a mask at 0.5;
        // OPAQUE ignores alpha. The opacity is baseColorFactor's alpha × the image's.
        const std::string mode = alphaMode.C_Str();
        if ((mode == "MASK" || mode == "BLEND") && texture >= 0) {
            float cutoff = 0.5f;
            if (mode == "MASK") am.Get(AI_MATKEY_GLTF_ALPHACUTOFF, cutoff);
            aiColor4D base4(1, 1, 1, 1);
            if (am.Get(AI_MATKEY_BASE_COLOR, base4) != AI_SUCCESS) am.Get(AI_MATKEY_COLOR_DIFFUSE, base4);
            m.alphaTexture = texture;
            m.alphaSource = Material::AlphaSource::Alpha;
            m.alphaCutoff = std::isfinite(cutoff) ? std::clamp(cutoff, 0.0f, 1.0f) : 0.5f;
            m.alphaScale = std::isfinite(base4.a) ? std::clamp(base4.a, 0.0f, 1.0f) : 1.0f;
            if (mode == "BLEND")
                warnings->push_back(modelPath + ": material \"" + m.name +
                                    "\": alphaMode BLEND is rendered as a cut-out at alpha 0.5 (lightmesh has no "
                                    "partial transparency)");
        }
    } else {
        // Others: an opacity map (MTL map_d) cuts at 0.5, times the opacity (MTL d); else a
        // base-colour image with an alpha channel does. A constant opacity alone (d < 1
        // without a map) is not a cut-out.
        float opacity = 1;
        am.Get(AI_MATKEY_OPACITY, opacity);
        TextureWrap wu, wv;
        const int map = FindTexture(am, aiTextureType_OPACITY, scene, modelPath, textures, &wu, &wv);
        if (map >= 0) {
            m.alphaTexture = map;
            m.alphaSource = Material::AlphaSource::OpacityMap;
            m.alphaScale = std::isfinite(opacity) ? std::clamp(opacity, 0.0f, 1.0f) : 1.0f;
        } else if (texture >= 0) {
            m.alphaTexture = texture;
            m.alphaSource = Material::AlphaSource::AlphaIfAny;
        }
    }

    const Color kd = ToColor(base);
    if (pbr) {
        metallic = std::isfinite(metallic) ? std::clamp(metallic, 0.0f, 1.0f) : 0.0f;
        roughness = std::isfinite(roughness) ? std::clamp(roughness, 0.0f, 1.0f) : 1.0f;
        m.kd = kd * (1 - metallic);
        m.textureScale = m.kd;
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
