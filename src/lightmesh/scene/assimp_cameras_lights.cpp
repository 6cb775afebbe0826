// assimp_cameras_lights.cpp -- the cameras and lights of an Assimp scene, each placed by its
// node's global transform (the walk of assimp_import.cpp records them), in world space.
#include <assimp/camera.h>
#include <assimp/light.h>
#include <assimp/scene.h>

#include <algorithm>
#include <cctype>

#include "lightmesh/scene/mesh_import_internal.h"

namespace lm::mesh_import {
namespace {

Vec3 ToVec3(const aiVector3D& v) { return Vec3(v.x, v.y, v.z); }

aiMatrix4x4 ToAi(const NodeTransform& t) {
    const float* a = t.m;
    return aiMatrix4x4(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8], a[9], a[10], a[11], a[12], a[13], a[14],
                       a[15]);
}

Vec3 TransformPoint(const aiMatrix4x4& m, const aiVector3D& p) { return ToVec3(m * p); }

Vec3 TransformDirection(const aiMatrix4x4& m, const aiVector3D& d) {
    return Vec3(m.a1 * d.x + m.a2 * d.y + m.a3 * d.z, m.b1 * d.x + m.b2 * d.y + m.b3 * d.z,
                m.c1 * d.x + m.c2 * d.y + m.c3 * d.z);
}

std::string Extension(const std::string& path) {
    const size_t dot = path.find_last_of('.');
    std::string ext = dot == std::string::npos || path.find('/', dot) != std::string::npos ? "" : path.substr(dot);
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    return ext;
}

/// What Assimp 5.2's reader for this format stores in mHorizontalFOV (FileCamera::Fov).
FileCamera::Fov FovConvention(const std::string& ext) {
    if (ext == ".gltf" || ext == ".glb") return FileCamera::Fov::GltfYfovTimesAspect;
    if (ext == ".dae" || ext == ".fbx") return FileCamera::Fov::FullHorizontal;
    return FileCamera::Fov::HalfHorizontal;
}

}  // namespace

void WantedNodeNames(const aiScene& scene, NodeTransforms* wanted) {
    for (unsigned i = 0; scene.mCameras && i < scene.mNumCameras; ++i)
        if (scene.mCameras[i]) wanted->emplace(scene.mCameras[i]->mName.C_Str(), std::nullopt);
    for (unsigned i = 0; scene.mLights && i < scene.mNumLights; ++i)
        if (scene.mLights[i]) wanted->emplace(scene.mLights[i]->mName.C_Str(), std::nullopt);
}

void ReadCamerasAndLights(const aiScene& scene, const std::string& path, const NodeTransforms& placed,
                          LoadedMesh* out) {
    const std::string ext = Extension(path);
    const bool gltf = ext == ".gltf" || ext == ".glb";
    for (unsigned i = 0; scene.mCameras && i < scene.mNumCameras; ++i) {
        const aiCamera* c = scene.mCameras[i];
        if (!c) continue;
        const auto it = placed.find(c->mName.C_Str());
        if (it == placed.end() || !it->second) continue;  // no node places it: not in the scene
        const aiMatrix4x4 m = ToAi(*it->second);
        FileCamera fc;
        fc.name = c->mName.C_Str();
        // Assimp 5.2's glTF reader also copies the node's translation into mPosition, which
        // the node's transform then applies a second time: a glTF camera sits at its node.
        fc.position = TransformPoint(m, gltf ? aiVector3D(0, 0, 0) : c->mPosition);
        fc.lookAt = TransformDirection(m, c->mLookAt);
        fc.up = TransformDirection(m, c->mUp);
        fc.horizontalFov = c->mHorizontalFOV;
        fc.aspect = c->mAspect;
        fc.fov = FovConvention(ext);
        fc.orthographic = c->mOrthographicWidth > 0;
        out->cameras.push_back(std::move(fc));
    }
    for (unsigned i = 0; scene.mLights && i < scene.mNumLights; ++i) {
        const aiLight* l = scene.mLights[i];
        if (!l) continue;
        const auto it = placed.find(l->mName.C_Str());
        if (it == placed.end() || !it->second) continue;
        const aiMatrix4x4 m = ToAi(*it->second);
        FileLight fl;
        fl.name = l->mName.C_Str();
        switch (l->mType) {
            case aiLightSource_POINT: fl.type = FileLight::Type::Point; break;
            case aiLightSource_SPOT: fl.type = FileLight::Type::Spot; break;
            case aiLightSource_DIRECTIONAL: fl.type = FileLight::Type::Directional; break;
            case aiLightSource_AREA: fl.type = FileLight::Type::Unsupported, fl.unsupported = "an area light"; break;
            case aiLightSource_AMBIENT: fl.type = FileLight::Type::Unsupported, fl.unsupported = "an ambient light"; break;
            default: fl.type = FileLight::Type::Unsupported, fl.unsupported = "of an unknown type"; break;
        }
        fl.position = TransformPoint(m, l->mPosition);
        fl.direction = TransformDirection(m, l->mDirection);
        fl.color = Color(l->mColorDiffuse.r, l->mColorDiffuse.g, l->mColorDiffuse.b);
        fl.constant = l->mAttenuationConstant;
        fl.linear = l->mAttenuationLinear;
        fl.quadratic = l->mAttenuationQuadratic;
        fl.range = it->second->lightRange;
        fl.inner = l->mAngleInnerCone;
        fl.outer = l->mAngleOuterCone;
        out->lights.push_back(std::move(fl));
    }
}

}  // namespace lm::mesh_import
