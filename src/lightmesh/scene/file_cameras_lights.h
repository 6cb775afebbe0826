// file_cameras_lights.h -- the cameras and lights a model file brings (glTF, COLLADA, FBX,
// .blend, ... through Assimp), in world space, and how a framed model uses them: the file's
// camera in place of the automatic one, its lights in place of the key and fill lights.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "lightmesh/math/bounds.h"
#include "lightmesh/scene/scene.h"

namespace lm {

/// A camera of the file, its node's global transform applied.
struct FileCamera {
    std::string name;
    Vec3 position, lookAt, up;  ///< world space: a point, a direction, a direction
    /// The field of view as Assimp gives it (aiCamera::mHorizontalFOV, radians) and the
    /// file's aspect ratio (width / height; 0, negative or NaN: the image's).
    float horizontalFov = 0, aspect = 0;
    /// What Assimp 5.2's reader of the file's format puts in mHorizontalFOV: its documented
    /// half horizontal angle (Blender, and formats not listed), the full horizontal angle
    /// (COLLADA's xfov, FBX's FieldOfView), or glTF's yfov × aspect (aspect 1 when the file
    /// gives none), which is read back as the vertical angle.
    enum class Fov : uint8_t { HalfHorizontal, FullHorizontal, GltfYfovTimesAspect };
    Fov fov = Fov::HalfHorizontal;
    /// An orthographic camera (aiCamera::mOrthographicWidth > 0), which lightmesh does not
    /// render: the default choice passes over it, --camera naming it is an error.
    bool orthographic = false;
};

/// A light of the file, its node's global transform applied.
struct FileLight {
    enum class Type : uint8_t { Point, Spot, Directional, Unsupported };
    std::string name;
    Type type = Type::Point;
    std::string unsupported;  ///< what kind an Unsupported light is ("area", "ambient")
    Vec3 position, direction;  ///< world space (direction: where the light shines, not unit)
    /// Assimp's diffuse colour (glTF: colour × intensity, candela or lux) and attenuation
    /// 1 / (constant + linear·d + quadratic·d²).
    Color color;
    float constant = 1, linear = 0, quadratic = 0;
    float inner = 0, outer = 0;  ///< a spot's cone half-angles, radians
    /// glTF's "range" of a point light or spot (NaN: none, no limit).
    float range = std::numeric_limits<float>::quiet_NaN();
};

/// The angular radius the sun gets when nothing states one: 0.2665°, the sun's (its
/// diameter is about 0.533° seen from the Earth).
inline constexpr float kSunAngleDegrees = 0.2665f;
/// How far the sun's sphere stands from the scene's centre, in the scene's bounding radius:
/// far enough that its direction varies by 1e-4 rad (0.006°, 2 % of the sun's angular
/// radius) across the scene; near enough for float: positions stay exact to 1e-7 of that
/// distance, a direction error of 1e-11 rad.
inline constexpr float kSunDistanceFactor = 1e4f;

/// Places every Sun of scene->lights (LightKind::Sun, `sun` set) as the far sphere light
/// that renders it: centre c − direction·D (c the centre of `bounds`, D = kSunDistanceFactor
/// × the bounds' half diagonal, at least 1e-3), radius D·sin(angle) (the sphere subtends
/// exactly the angle from c), falloff none.
void PlaceSuns(Scene* scene, const Bounds3& bounds);

/// A spot's cone from its stated direction (non-zero, finite) and half-angles in degrees,
/// and the sun's direction and angular radius: one derivation for scene files and model
/// files, so a scene saved with the stated values loads to the same bits.
void SetSpotCone(const Vec3& direction, float innerDegrees, float outerDegrees, PointLight* light);
void SetSun(const Vec3& direction, float angleDegrees, PointLight* light);

/// The camera `select` names among `cameras` ("" the first perspective one; digits an
/// index from 0; else a name), or -1 and *problem (one line, no file name) when there is
/// none such ("" with only orthographic cameras: -1 and an empty *problem).
int SelectFileCamera(const std::vector<FileCamera>& cameras, const std::string& select, std::string* problem);

/// The file's camera as the scene's, for an image of aspect `imageAspect`. "" or why it
/// cannot be used: a zero or non-finite view direction (a node scaled to 0), an up
/// parallel to it, a field of view not in (0°, 180°).
std::string CameraFromFile(const FileCamera& fc, float imageAspect, Camera* out);

/// The file's light as the scene's; the rules (docs/scene-format.md, "Lights of model
/// files"): glTF's candela (point, spot) are the intensity with inverse-square falloff,
/// its lux (directional) the sun's irradiance; other formats' colour divided by the
/// attenuation's quadratic term (inverse square) or, without one, its constant term (no
/// falloff). A point light or spot gets DefaultLightRadius from `bounds`, and glTF's
/// "range" as its PointLight::range (a hard cut-off). "" or why it
/// cannot be used (negative or non-finite colour, a spot's or sun's direction zero, a
/// spot's inner cone wider than its outer, an outer cone above 90°).
std::string LightFromFile(const FileLight& fl, const Bounds3& bounds, PointLight* out);

}  // namespace lm
