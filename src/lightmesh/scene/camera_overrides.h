// camera_overrides.h -- the camera given as options (the command line's --camera-position,
// --look-at, --fov, --up; the Python module's keywords of the same names), laid over the
// scene's: each option replaces the one camera key it names, as the scene file's "camera"
// object would (docs/scene-format.md), and the other keys keep the scene's (or the automatic
// framing's) values. Also the checks of the scene-loading options both front ends take
// (--smooth-normals), so both refuse the same values with the same words.
#pragma once

#include <optional>
#include <string>

#include "lightmesh/geometry/affine.h"
#include "lightmesh/scene/scene.h"
#include "lightmesh/scene/scene_file.h"

namespace lm {

/// What the options are called in messages: the command line's flags by default; the
/// Python module names its keywords ("camera_position=").
struct CameraOptionNames {
    std::string position = "--camera-position";
    std::string lookAt = "--look-at";
    std::string up = "--up";
    std::string fov = "--fov";
};

/// The camera keys given as options; unset ones keep the scene's.
struct CameraOverrides {
    std::optional<Vec3> position;  ///< --camera-position X,Y,Z
    std::optional<Vec3> lookAt;    ///< --look-at X,Y,Z
    std::optional<Vec3> up;        ///< --up X,Y,Z, or --up x|y|z (that axis)
    std::optional<float> fovY;     ///< --fov DEG (vertical, in (0, 180))
    /// The axis `up` was given as a letter (0 x, 1 y, 2 z), else -1: for a bare mesh file
    /// it names the model's up axis instead (PrepareCameraOverrides).
    int upAxis = -1;
    CameraOptionNames names;
    bool Any() const { return position || lookAt || up || fovY; }
};

/// "X,Y,Z" (three finite numbers, commas between them, spaces allowed) as a point or a
/// direction; throws Error naming `flag`: "--look-at: expected X,Y,Z (3 numbers), got 1,2".
Vec3 ParseVec3Option(const std::string& flag, const std::string& text);

/// Three numbers given for the option `name` as a point or a direction: each finite and
/// within ±1e18, else Error "<name>: every number must be finite ..., got <shown>".
Vec3 Vec3Option(const std::string& name, const double (&v)[3], const std::string& shown);

/// The axis a letter names: "x" 0, "y" 1, "z" 2 (upper case too); -1 for anything else.
int AxisOfLetter(const std::string& text);

/// --up's value: a letter (that axis's unit vector) or X,Y,Z.
Vec3 ParseUpOption(const std::string& text);

/// --fov's value: a number strictly between 0 and 180 degrees.
float ParseFovOption(const std::string& text);

/// A field of view of `degrees` given for the option `name`: strictly between 0 and 180,
/// else Error "<name>: must be a number of degrees between 0 and 180 ..., got <shown>".
float FovOption(const std::string& name, double degrees, const std::string& shown);

/// --smooth-normals' value: a crease angle from 0 to 180 degrees (both included). "" when
/// `degrees` is one, else why not, without the option's name ("must be between 0 and 180,
/// got 200", `shown` being the value as given).
std::string SmoothNormalsProblem(double degrees, const std::string& shown);

/// Whether `spec` names a bare mesh file (not "builtin:NAME", not a .json scene file): the
/// scenes the automatic framing frames and --camera picks a file's own camera for.
bool IsMeshFileSpec(const std::string& spec);

/// The overrides sorted out for loading `spec`, before it is read. For a bare mesh file an
/// up given as a letter names the model's up axis (load->upAxis: the model is turned, the
/// camera's up stays +y) and a field of view is also the framing's (load->frameFovY). Then
/// what can be judged without the scene: a zero up, a position equal to the point looked
/// at. Throws Error naming the option (o->names).
void PrepareCameraOverrides(const std::string& spec, CameraOverrides* o, SceneLoadOptions* load);

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
