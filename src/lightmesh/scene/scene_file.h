// scene_file.h -- loads a scene: "builtin:NAME", a JSON scene file, or a bare mesh file.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "lightmesh/scene/mesh_loader.h"
#include "lightmesh/scene/scene.h"

namespace lm {

/// The instancing rule: a mesh file referenced at least twice (with the same exclusions and
/// material) whose mesh holds at least kInstanceMinTriangles triangles, and whose copies
/// together hold at least kInstanceMinTotal, is imported once and placed as instances.
constexpr size_t kInstanceMinTriangles = 64;
constexpr size_t kInstanceMinTotal = 65536;

/// The crease angle a bare mesh file without normals is smoothed with unless told otherwise
/// (--smooth-normals): curved surfaces shade smooth, and edges sharper than 60° (a box's)
/// stay creases.
inline constexpr float kBareMeshSmoothNormals = 60.0f;

struct SceneLoadOptions {
    /// Unknown or duplicate keys in a scene file are errors instead of warnings.
    bool strict = false;
    /// The image size the caller will render at when it overrides the scene's (e.g. from
    /// --width/--height); 0 means the scene's own. Only used to frame bare meshes (and scene
    /// files without "camera"), so the whole model is in view whatever the aspect ratio.
    int frameWidth = 0, frameHeight = 0;
    /// Bare meshes only: the model's up axis (0 x, 1 y, 2 z; --up x|y|z). The model is
    /// turned so that axis points up (+y, UpAxisToY in camera_overrides.h) before it is
    /// framed, so a Z-up STL stands on the ground. Scene files place their meshes themselves.
    int upAxis = 1;
    /// The vertical field of view the framing of a bare mesh (or a scene file without
    /// "camera") fits the model into (--fov); 0: the framing's own (40 degrees).
    float frameFovY = 0;
    /// For tests and fuzzing (fuzz/fuzz_entry_points.cpp): the text of a JSON scene file,
    /// parsed instead of reading `spec`, which still names it in messages and locates its
    /// mesh files.
    std::optional<std::string> text = std::nullopt;
    /// Whether the materials' images are read and used (--no-textures: false; a scene
    /// file's "render": {"textures": false} turns them off as well). Off, no image is read
    /// and the scene is shaded with the materials' flat colours, as without textures.
    bool textures = true;
    /// References to one mesh file that InstancesSaveMemory's rule picks become instances of
    /// one prototype (TriangleMesh::instances); false flattens every reference.
    bool instancing = true;
    /// Who turned instancing off, for the message that refuses copies past the memory
    /// budget ("--no-instancing"; bench names itself).
    std::string noInstancingBy = "--no-instancing";
    /// Which of a mesh file's own cameras frames it (--camera): "" the first, digits an
    /// index from 0, else a camera's name. Files without cameras are framed automatically
    /// (then a non-empty value is an error). A scene file without "camera" takes it from
    /// the first of its mesh files that has cameras (none: framed, and a non-empty value
    /// is an error); with "camera", or for builtin:, a non-empty value is an error.
    std::string camera = "";
    /// Smooth normals, with this crease angle in degrees (0 to 180; 0: none, face normals),
    /// for the meshes of mesh files that have none (--smooth-normals), over a scene file's
    /// "smooth_normals" keys. Negative (not given): kBareMeshSmoothNormals for a bare mesh
    /// file, each entry's key (default none) in a scene file.
    float smoothNormals = -1.0f;
    /// For tests and fuzzing: loads the mesh files of a JSON scene instead of LoadMeshFile.
    std::function<LoadedMesh(const std::string& path, const MeshLoadOptions&)> loadMesh = nullptr;
};

/// The share of a light's distance to the scene's centre that a light with no stated size
/// gets as its radius (DefaultLightRadius): 2 %.
inline constexpr float kDefaultLightRadiusShare = 0.02f;

/// The radius a light at `position` gets when nothing gives it one (a scene file's light
/// without "radius", the lights that frame a bare mesh): kDefaultLightRadiusShare of its
/// distance to the centre of `sceneBounds`. Soft shadows are what lightmesh is for, and a
/// size proportional to the distance makes every such light subtend the same small angle
/// from the scene's middle (half-angle asin 0.02, about 1.1 degrees) wherever it is and
/// whatever the scene's units: a bulb 2 m from the middle of a room gets 4 cm, a sun far
/// away a proportionally large disc. A light at the very centre gets 0, a point.
float DefaultLightRadius(const Bounds3& sceneBounds, const Vec3& position);

/// Loads "builtin:NAME", a JSON scene file (*.json; the format is described at the top of
/// scene_file.cpp), or a bare mesh file in any format Assimp reads. A bare mesh is framed
/// automatically: a camera that sees the whole model, a ground plane under it and two
/// point lights above it, each choice recorded in scene.report.notes. Lights that do not
/// state their size (a scene file's light without "radius", the framing's lights) get
/// DefaultLightRadius, also recorded in the notes.
///
/// Every scene is then cleaned (degenerate and duplicate triangles dropped, counted in
/// scene.report, with a warning) and validated: at least one triangle, a finite non-zero
/// extent, at least one light, a usable camera, render options in range.
///
/// Warnings (unknown keys with their JSON path, dropped triangles, importer complaints)
/// are appended to *warnings, or logged with LogWarning when `warnings` is null. Throws
/// Error for bad input; its message names the file and, for scene files, the JSON path:
/// `scene.json /lights/1/position: expected 3 numbers, got 2`.
/// The folder scene files call "cache:": $XDG_CACHE_HOME/lightmesh/models, else
/// $HOME/.cache/lightmesh/models.
std::string ModelCacheDir();

Scene LoadScene(const std::string& spec, const SceneLoadOptions& options,
                std::vector<std::string>* warnings);

/// Reads `jsonText`, an object of the keys of a scene file's "render" (the settings
/// table's), into *options as LoadScene reads a scene file's "render": the same checks,
/// and each key's origin recorded ("<origin> /width"). For front ends that take the render
/// settings as named values (the Python module's keyword arguments); unknown keys are
/// errors. Throws Error naming `origin` and the key: "<origin> /width: must be ...".
void ReadRenderSettings(const std::string& origin, const std::string& jsonText, RenderOptions* options,
                        std::vector<std::string>* warnings = nullptr);

}  // namespace lm
