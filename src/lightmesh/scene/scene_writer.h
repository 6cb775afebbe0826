// scene_writer.h -- a rendered scene written back as a scene file (--save-scene): the camera,
// the lights (intensity, falloff, radius, range), the ground, the render settings and the
// mesh files it was made of, so that loading the file renders the same image bytes. It is
// how a user starts editing an automatically framed model.
#pragma once

#include <string>

#include "lightmesh/scene/scene.h"

namespace lm {

/// Where the scene came from, and what its loader was told.
struct SceneSource {
    std::string spec;         ///< a .json scene file or a mesh file ("builtin:" cannot be saved)
    int upAxis = 1;           ///< a bare mesh's up axis (SceneLoadOptions::upAxis): written as its "matrix"
    bool textures = true;     ///< false: --no-textures (written as "render": {"textures": false})
    bool instancing = true;   ///< false: --no-instancing
    /// --smooth-normals (SceneLoadOptions::smoothNormals; negative: not given): written as
    /// each mesh entry's "smooth_normals" (a bare mesh's: kBareMeshSmoothNormals when not given).
    float smoothNormals = -1.0f;
};

/// Throws Error naming `flag` when `source` cannot be written as a scene file (a builtin
/// scene, made by code: no file to reference), or `path` is not a .json file name.
void CheckSceneSaveable(const std::string& path, const SceneSource& source, const char* flag);

/// The scene file's text. `scene` is the scene as loaded (camera and lights as rendered),
/// `options` the render's merged settings: width and height always, the other knobs of the
/// settings table where they were set (RenderOptions::origins), so defaults stay defaults.
/// A scene file's other keys (meshes, materials, ground, names) are kept as they were, its
/// relative mesh paths made relative to `path`'s folder; a bare mesh becomes one mesh entry
/// (with the --up turn as its "matrix") and its ground an explicit "ground". Floats are
/// written in the shortest form that reads back as the same float.
std::string SceneFileText(const Scene& scene, const RenderOptions& options, const SceneSource& source,
                          const std::string& path);

/// SceneFileText written to `path` atomically (util/system.h WriteFileAtomically).
void WriteSceneFile(const std::string& path, const Scene& scene, const RenderOptions& options,
                    const SceneSource& source);

}  // namespace lm
