// scene_file_cameras_lights.cpp -- a scene file without "camera" or "lights" takes them
// from its mesh files, as a bare mesh file does (framing.cpp): the camera of the first
// file that has cameras, the lights of every file, each moved by its entry's transform.
#include "lightmesh/scene/scene_file_parts.h"
#include "lightmesh/scene/scene_load.h"

#include <cmath>
#include <set>

#include "lightmesh/util/error.h"

namespace lm::scene_load {

using namespace json;  // Reader, Quoted

namespace {

/// `fc` moved by the entry's transform (a camera's node under the entry's node).
FileCamera Moved(const MeshEntry& e, FileCamera fc) {
    if (!e.hasTransform) return fc;
    fc.position = e.transform.ApplyPoint(fc.position);
    fc.lookAt = e.transform.ApplyVector(fc.lookAt);
    fc.up = e.transform.ApplyVector(fc.up);
    return fc;
}

FileLight Moved(const MeshEntry& e, FileLight fl) {
    if (!e.hasTransform) return fl;
    fl.position = e.transform.ApplyPoint(fl.position);
    fl.direction = e.transform.ApplyVector(fl.direction);
    return fl;
}

/// SelectFileCamera's "the file has ..." with the file named.
std::string NameTheFile(const std::string& problem, const std::string& file) {
    const std::string prefix = "the file ";
    return problem.rfind(prefix, 0) == 0 ? Quoted(file) + " " + problem.substr(prefix.size()) : problem;
}

/// "/meshes/0" or "/meshes/0 and /meshes/2", at most kListed paths.
std::string EntryList(const std::vector<std::string>& paths) {
    constexpr size_t kListed = 4;
    std::string list;
    for (size_t k = 0; k < paths.size() && k < kListed; ++k)
        list += (k == 0 ? "" : (k + 1 == paths.size() ? " and " : ", ")) + paths[k];
    if (paths.size() > kListed) list += StringPrintf(" and %zu more", paths.size() - kListed);
    return list;
}

}  // namespace

bool UseMeshFileCamera(const Reader& r, const std::vector<EntryCamerasLights>& kept,
                       const SceneLoadOptions& options, float aspect, Scene* scene) {
    const EntryCamerasLights* from = nullptr;
    for (const EntryCamerasLights& k : kept)
        if (!k.cameras.empty()) {
            from = &k;
            break;
        }
    if (!from) {
        if (!options.camera.empty())
            r.Fail("", "--camera " + options.camera +
                           ": none of the scene's mesh files has cameras (without \"camera\" it is framed "
                           "automatically)");
        return false;
    }
    const MeshEntry& e = *from->entry;
    const std::vector<FileCamera>& cameras = from->cameras;
    std::string problem;
    const int index = SelectFileCamera(cameras, options.camera, &problem);
    if (index < 0 && options.camera.empty()) {
        scene->report.notes.push_back(StringPrintf(
            "no \"camera\": the %zu camera%s of %s (%s) %s orthographic (lightmesh renders perspective cameras): "
            "framing the scene instead",
            cameras.size(), cameras.size() == 1 ? "" : "s", Quoted(e.file).c_str(), e.path.c_str(),
            cameras.size() == 1 ? "is" : "are"));
        return false;
    }
    if (index < 0) r.Fail(e.path, "--camera " + options.camera + ": " + NameTheFile(problem, e.file));
    const FileCamera fc = Moved(e, cameras[static_cast<size_t>(index)]);
    std::string which;
    problem = TakeFileCamera(fc, index, aspect, &scene->camera, &which);
    if (!problem.empty()) r.Fail(e.path, Quoted(e.file) + "'s " + which + " cannot be used: " + problem);
    const Camera& cam = scene->camera;
    scene->report.notes.push_back(StringPrintf(
        "no \"camera\": the %s of %s (%s; of %zu%s) at %s looking towards %s, %.4g° vertical field of view",
        which.c_str(), Quoted(e.file).c_str(), e.path.c_str(), cameras.size(),
        cameras.size() > 1 ? "; --camera NAME|INDEX picks another" : "", FormatVec(cam.position).c_str(),
        FormatVec(cam.lookAt).c_str(), static_cast<double>(cam.fovY)));
    return true;
}

bool UseMeshFileLights(const Reader& r, const std::vector<EntryCamerasLights>& kept, const Bounds3& bounds,
                       Scene* scene) {
    size_t points = 0, spots = 0, suns = 0;
    std::vector<PointLight> lights;
    std::vector<std::string> from;
    std::set<std::string> said;  // a file placed twice warns once
    for (const EntryCamerasLights& k : kept) {
        const MeshEntry& e = *k.entry;
        size_t unsupported = 0, linear = 0, used = 0;
        std::string firstUnsupported;
        for (size_t i = 0; i < k.lights.size(); ++i) {
            const FileLight fl = Moved(e, k.lights[i]);
            if (fl.type == FileLight::Type::Unsupported) {
                if (unsupported++ == 0) firstUnsupported = "\"" + fl.name + "\" is " + fl.unsupported;
                continue;
            }
            PointLight l;
            if (std::string p = LightFromFile(fl, bounds, &l); !p.empty())
                r.Fail(e.path, StringPrintf("%s's light %zu \"%s\" cannot be used: %s", Quoted(e.file).c_str(), i,
                                            fl.name.c_str(), p.c_str()));
            if (l.kind != LightKind::Sun) {
                if (std::string p = CoordinateProblem(l.position, "the light"); !p.empty())
                    r.Fail(e.path, StringPrintf("%s's light %zu \"%s\": %s", Quoted(e.file).c_str(), i,
                                                fl.name.c_str(), p.c_str()));
                linear += fl.linear != 0;
            }
            (l.kind == LightKind::Sun ? suns : l.kind == LightKind::Spot ? spots : points)++;
            lights.push_back(std::move(l));
            ++used;
        }
        if (unsupported) {
            const std::string w = StringPrintf(
                "%s: %zu of the file's lights left out (%s; lightmesh renders point, spot and directional lights)",
                e.resolved.c_str(), unsupported, firstUnsupported.c_str());
            if (said.insert(w).second) r.Warn(w);
        }
        if (linear) {
            const std::string w = StringPrintf(
                "%s: %zu of the file's lights have a linear attenuation term, which lightmesh leaves out "
                "(inverse-square or no falloff)",
                e.resolved.c_str(), linear);
            if (said.insert(w).second) r.Warn(w);
        }
        if (used) from.push_back(e.path);
    }
    if (lights.empty()) return false;
    scene->lights = std::move(lights);
    scene->report.notes.push_back(StringPrintf(
        "no \"lights\": the lights of its mesh files (%s): %zu point, %zu spot, %zu directional (the sun: angular "
        "radius %g°); point lights and spots get radius %d %% of their distance to the scene's centre "
        "(--light-radius 0 makes them points)",
        EntryList(from).c_str(), points, spots, suns, static_cast<double>(kSunAngleDegrees),
        static_cast<int>(std::lround(100 * kDefaultLightRadiusShare))));
    return true;
}

}  // namespace lm::scene_load
