// camera_overrides.h -- the camera given on the command line (--camera-position, --look-at,
// --fov, --up), laid over the scene's: each option replaces the one camera key it names, as
// the scene file's "camera" object would (docs/scene-format.md), and the other keys keep the
// scene's (or the automatic framing's) values.
#pragma once

#include <optional>
#include <string>

#include "lightmesh/geometry/affine.h"
#include "lightmesh/scene/scene.h"

namespace lm {

/// The camera keys given as options; unset ones keep the scene's.
struct CameraOverrides {
    std::optional<Vec3> position;  ///< --camera-position X,Y,Z
    std::optional<Vec3> lookAt;    ///< --look-at X,Y,Z
    std::optional<Vec3> up;        ///< --up X,Y,Z, or --up x|y|z (that axis)
    std::optional<float> fovY;     ///< --fov DEG (vertical, in (0, 180))
    bool Any() const { return position || lookAt || up || fovY; }
};

/// "X,Y,Z" (three finite numbers, commas between them, spaces allowed) as a point or a
/// direction; throws Error naming `flag`: "--look-at: expected X,Y,Z (3 numbers), got 1,2".
Vec3 ParseVec3Option(const std::string& flag, const std::string& text);

/// The axis a letter names: "x" 0, "y" 1, "z" 2 (upper case too); -1 for anything else.
int AxisOfLetter(const std::string& text);

/// --up's value: a letter (that axis's unit vector) or X,Y,Z.
Vec3 ParseUpOption(const std::string& text);

/// --fov's value: a number strictly between 0 and 180 degrees.
float ParseFovOption(const std::string& text);

/// The rotation that turns a bare mesh's up axis (0 x, 1 y, 2 z: --up x|y|z) to +y, the up
/// of the automatic framing: z up turns about x by -90 degrees ((x, y, z) to (x, z, -y), so a
/// Z-up model's front, -y, faces the camera at +z), x up about z by +90 degrees ((x, y, z)
/// to (-y, x, z)); the identity for y. Its entries are 0 and ±1, so it is exact, and a scene
/// file's "matrix" of the same numbers (--save-scene writes it) moves the model identically.
Affine UpAxisToY(int axis);

/// Replaces the camera keys `o` gives and checks the result as a scene file's camera is
/// checked; an error names the option that made the camera unusable ("--look-at: equals the
/// camera position, so the camera has no view direction").
void ApplyCameraOverrides(const CameraOverrides& o, Camera* camera);
/// The same on a loaded scene, whose span (meshes, lights and the moved camera) is then
/// checked as the loader checks it ("--camera-position: the scene ... spans ...").
void ApplyCameraOverrides(const CameraOverrides& o, Scene* scene);

}  // namespace lm
