// render_view.cpp -- `render`'s view of the scene from the command line: the camera options
// (scene/camera_overrides.h), --save-scene, and --width or --height alone keeping the
// scene's aspect ratio.
#include <cmath>

#include "commands.h"
#include "lightmesh/util/log.h"

namespace lm::cli {

void AddViewOptions(CLI::App* cmd, RenderCommand* render) {
    const char* group = "Camera (each replaces the scene file's or the automatic framing's key)";
    cmd->add_option("--camera-position", render->cameraPosition,
                    "Camera position X,Y,Z (scene key camera/position)")
        ->type_name("X,Y,Z")
        ->group(group);
    cmd->add_option("--look-at", render->lookAt, "The point the camera looks at, X,Y,Z (camera/look_at)")
        ->type_name("X,Y,Z")
        ->group(group);
    cmd->add_option("--up", render->up,
                    "The camera's up direction X,Y,Z (camera/up; default 0,1,0), or x, y or z: that axis; for a "
                    "mesh file without a scene file, x or z names the model's up axis: the model is turned so "
                    "it stands on the ground (default y)")
        ->type_name("X,Y,Z|x|y|z")
        ->group(group);
    cmd->add_option("--fov", render->fov,
                    "Vertical field of view in degrees, between 0 and 180 (camera/fov; default 45, 40 for a "
                    "framed mesh file, which is framed for the --fov given)")
        ->type_name("DEG")
        ->group(group);
    cmd->add_option("--save-scene", render->saveScene,
                    "Also write the scene as rendered (camera, lights, ground, materials, render settings, mesh "
                    "files) as a .json scene file that renders the same image")
        ->type_name("FILE.json");
}

lm::CameraOverrides CameraFromCommand(const RenderCommand& cmd, CommonOptions* load) {
    lm::CameraOverrides o;
    if (cmd.cameraPosition) o.position = lm::ParseVec3Option("--camera-position", *cmd.cameraPosition);
    if (cmd.lookAt) o.lookAt = lm::ParseVec3Option("--look-at", *cmd.lookAt);
    if (cmd.fov) o.fovY = lm::ParseFovOption(*cmd.fov);
    if (cmd.up) {
        o.up = lm::ParseUpOption(*cmd.up);
        o.upAxis = lm::AxisOfLetter(*cmd.up);
    }
    // A bare mesh's letter --up, and --fov, reach the framing; what can be judged without the
    // scene is checked before it is read.
    lm::SceneLoadOptions framing;
    framing.upAxis = load->upAxis;
    framing.frameFovY = load->frameFovY;
    lm::PrepareCameraOverrides(cmd.common.scene, &o, &framing);
    load->upAxis = framing.upAxis;
    load->frameFovY = framing.frameFovY;
    return o;
}

namespace {

// The side that keeps the scene's sceneW x sceneH aspect ratio next to `given` (the other
// side), within the settings table's range for `other`.
int OtherSide(int given, int num, int den, int sceneW, int sceneH, const char* flag, const char* other) {
    const long long side = std::llround(static_cast<double>(given) * num / den);
    const lm::RenderSetting& s = lm::RenderSettingFor(other);
    if (side < s.lo || side > s.hi)
        lm::ThrowError("%s %d: the %s that keeps the scene's aspect ratio (%dx%d) would be %lld, outside %g..%g; "
                       "give %s too",
                       flag, given, other, sceneW, sceneH, side, s.lo, s.hi, s.flag);
    return static_cast<int>(side);
}

}  // namespace

void KeepAspectRatio(const RenderCommand& cmd, const lm::RenderOptions& scene, lm::RenderOptions* options) {
    if (cmd.width && !cmd.height) {
        options->height = OtherSide(*cmd.width, scene.height, scene.width, scene.width, scene.height, "--width", "height");
        options->origins["height"] = lm::SourceLoc::Option("--width");
    } else if (cmd.height && !cmd.width) {
        options->width = OtherSide(*cmd.height, scene.width, scene.height, scene.width, scene.height, "--height", "width");
        options->origins["width"] = lm::SourceLoc::Option("--height");
    }
}

}  // namespace lm::cli
