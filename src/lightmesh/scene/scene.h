// scene.h -- what a scene is once loaded: triangles, materials, lights, camera, settings.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "lightmesh/geometry/mesh.h"
#include "lightmesh/settings/options.h"
#include "lightmesh/texture/texture.h"

namespace lm {

/// Phong material of formula (1): I = A·kd + Σ V·Ω + mirror·I_r, with
/// Ω = I_light·(kd·max(0, n·l) + ks·max(0, r·v)^phong).
struct Material {
    std::string name = "default";
    Color kd{0.8f};      ///< diffuse reflectance
    Color ks{0.0f};      ///< Phong specular reflectance
    float phong = 32.0f; ///< Phong exponent
    Color mirror{0.0f};  ///< mirror reflectance: weight of the reflected ray
    /// The base-colour texture: an index into Scene::textures (LoadedMesh::textures before
    /// the scene takes it), -1 for none. Where the mesh has texture coordinates, the
    /// diffuse reflectance is textureScale × the texel's colour (glTF: baseColorFactor ×
    /// baseColorTexture, times 1 − metallic; MTL's map_Kd alone); kd stays the flat colour
    /// used without one.
    int texture = -1;
    Color textureScale{1.0f};
    TextureWrap wrapU = TextureWrap::Repeat, wrapV = TextureWrap::Repeat;
    /// Alpha cut-out: an image (index like `texture`; -1: none) whose opacity, times
    /// alphaScale, below alphaCutoff makes a hole in the surface (geometry/cutouts.h).
    /// Which channel is the opacity: AlphaSource.
    enum class AlphaSource : uint8_t {
        None,
        Alpha,        ///< the alpha channel (glTF alphaMode MASK, or BLEND as a mask)
        AlphaIfAny,   ///< the alpha channel if the image has one below 1, else no cut-out (a
                      ///< base-colour image's alpha outside glTF)
        OpacityMap,   ///< the alpha channel if the image has one, else its red channel (MTL map_d)
    };
    int alphaTexture = -1;
    AlphaSource alphaSource = AlphaSource::None;
    float alphaCutoff = 0.5f;
    float alphaScale = 1.0f;
};

/// How a point light's intensity falls off with distance d.
enum class Falloff {
    None,           ///< Ω uses the intensity as it is (the paper's formula (1))
    InverseSquare,  ///< Ω uses intensity / d²
};

/// What a light is: a sphere shining every way (a point light, the paper's), the same within
/// a cone (a spot), or the sun (a light at infinity, represented as a far sphere: see
/// PointLight::sun).
enum class LightKind : uint8_t { Point, Spot, Sun };

/// A spot's cone: the light reaches a point whose direction from the light's centre makes
/// an angle θ with `direction` with the factor t² (glTF's KHR_lights_punctual), t =
/// clamp((cos θ − cosOuter) / max(cosInner − cosOuter, 1e-3), 0, 1): full inside the inner
/// cone, nothing outside the outer one, smooth between.
struct SpotCone {
    Vec3 direction{0, -1, 0};  ///< unit, where the light shines
    float cosInner = 1.0f;     ///< cos of the inner cone's half-angle (>= cosOuter)
    float cosOuter = 0.0f;     ///< cos of the outer cone's half-angle (> 0: below 90°)
    /// As stated (a scene file's "spot" keys, or the model file's in degrees): what
    /// --save-scene writes, so the saved file derives the same bits (SetSpotCone).
    Vec3 statedDirection{0, -1, 0};
    float innerDegrees = 0.0f, outerDegrees = 90.0f;
    /// The cone's factor for unit direction `l` from the point towards the light.
    float Factor(const Vec3& l) const {
        const float c = -(direction.x * l.x + direction.y * l.y + direction.z * l.z);
        const float denom = cosInner - cosOuter > 1e-3f ? cosInner - cosOuter : 1e-3f;
        float t = (c - cosOuter) / denom;
        t = t < 0 ? 0 : (t > 1 ? 1 : t);
        return t * t;
    }
};

/// The sun as the scene holds it: the direction its light travels and its angular radius.
/// It is rendered as a far sphere light (PlaceSun, scene_file.h): a PointLight whose centre
/// lies kSunDistanceFactor times the scene's bounding radius away against `direction`,
/// whose radius makes the sphere subtend `angle` from the scene, with no falloff, so its
/// intensity is the irradiance it gives a surface facing it.
struct SunLight {
    Vec3 direction{0, -1, 0};  ///< unit, where the light travels
    float angle = 0.0f;        ///< angular radius, radians
    Vec3 statedDirection{0, -1, 0};  ///< as stated, for --save-scene (SetSun)
    float angleDegrees = 0.0f;       ///< as stated, for --save-scene
};

struct PointLight {
    Vec3 position;
    Color intensity{1.0f};
    Falloff falloff = Falloff::InverseSquare;
    /// The radius of the sphere the light stands for, in scene units (finite, >= 0; 0: a
    /// point). Methods that soften shadows by the light's size read it through LightRadii
    /// (shadow/shadow.h), which applies the render's --light-radius override. Scene files
    /// without "radius" and framed bare meshes get DefaultLightRadius (scene_file.h).
    float radius = 0.0f;
    /// How far the light reaches, in scene units (> 0; infinite by default): a point
    /// farther than this from the centre gets nothing from it. Every method honours it
    /// alike: shading skips the light there, so no shadow method is asked for it (RT traces
    /// no ray, the light mesh evaluates no bit a point in range could need).
    float range = Infinity;
    /// A point light's kind (Point by default). A Spot's cone is `spot`; a Sun's direction
    /// and angle `sun` (its position, radius and falloff are the far sphere's).
    LightKind kind = LightKind::Point;
    SpotCone spot{};
    SunLight sun{};
    std::string name{};  ///< the file's name for it ("" for none), for notes and `info`
};

/// A pinhole camera.
struct Camera {
    Vec3 position{0, 0, 5};
    Vec3 lookAt{0, 0, 0};
    Vec3 up{0, 1, 0};
    float fovY = 45.0f;  ///< vertical field of view in degrees
};

/// What loading removed or found, for `lightmesh info` and warnings.
struct SceneReport {
    size_t degenerateRemoved = 0;
    size_t duplicatesRemoved = 0;
    size_t meshesExcluded = 0;
    std::vector<std::string> sources;  ///< mesh files loaded (or "builtin:...")
    std::vector<std::string> notes;    ///< choices made for the user (e.g. auto framing)
};

/// The ground slab a scene got (a scene file's "ground", or the framing's), as a scene
/// file states it: for --save-scene (scene_writer.h).
struct GroundSlab {
    int axis = 1;        ///< the up axis: 0 x, 1 y, 2 z
    float height = 0;    ///< the top face's coordinate along it
    float size = 3;      ///< the side, as a multiple of the box's longest horizontal extent
    uint32_t material = 0;
};

struct Scene {
    std::string name;   ///< file name or builtin:NAME, used in messages
    TriangleMesh mesh;  ///< every triangle in world space, ground plane included
    std::vector<Material> materials;  ///< indexed by TriangleMesh::materialIds
    /// The images the materials use (Material::texture), each read once.
    std::vector<std::shared_ptr<const Texture>> textures;
    std::vector<PointLight> lights;
    Camera camera;
    Color ambient{0.05f};
    Color background{0.0f};
    /// Render settings the scene asks for; command-line options override them.
    RenderOptions render;
    SceneReport report;
    /// The ground slab added under the meshes; none when absent.
    std::optional<GroundSlab> ground;
};

}  // namespace lm
