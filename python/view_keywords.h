// view_keywords.h -- the Python module's keywords that choose what is loaded and where the
// camera is: the CLI's --camera, --smooth-normals, --camera-position, --look-at, --up and
// --fov with underscores. The values are checked by the library's code the CLI uses
// (scene/camera_overrides.h), worded with the keyword ("fov=: must be ...").
#pragma once

#include <pybind11/pybind11.h>

#include <optional>
#include <string>
#include <vector>

#include "lightmesh/scene/camera_overrides.h"
#include "lightmesh/scene/scene.h"
#include "lightmesh/scene/scene_file.h"

namespace lm::python {

/// The keywords, for "did you mean" and the docstrings.
extern const std::vector<std::string> kViewKeywords;
/// Their lines of the docstrings' option list.
extern const char* const kViewKeywordsDoc;

/// The view keywords of one call.
struct ViewKeywords {
    std::optional<std::string> camera;   ///< camera=: a mesh file's own camera, as --camera takes it
    std::string cameraShown;             ///< camera='s value as given (repr), for messages
    std::optional<float> smoothNormals;  ///< smooth_normals=: --smooth-normals' degrees
    CameraOverrides overrides;           ///< camera_position=, look_at=, up=, fov=
    ViewKeywords();
};

/// A value as JSON takes it: NumPy scalars become Python ones.
pybind11::object Plain(const pybind11::handle& v);

/// Reads the keyword `name` into *k if it is one of kViewKeywords (false if not); throws
/// Error naming it for a bad value.
bool ParseViewKeyword(const std::string& name, const pybind11::handle& v, ViewKeywords* k);

/// LoadScene(spec, load) with the keywords, as `lightmesh render` loads with the options:
/// a mesh file's own camera and smooth normals, the camera keywords laid over the loaded
/// camera (for a mesh file, a letter up= turns the model and fov= frames it). Releases the
/// GIL while loading.
Scene LoadWithView(const std::string& spec, const ViewKeywords& k, SceneLoadOptions load,
                   std::vector<std::string>* warnings);

/// Scene.render's camera keywords on the loaded scene `spec` for one render: checked and
/// laid over scene->camera (the caller restores it). For a mesh file a letter up= is
/// refused (it turns the model as it is loaded: a load option) and fov= does not frame it
/// again.
void MoveCameraForOneRender(const std::string& spec, const ViewKeywords& k, Scene* scene);

}  // namespace lm::python
