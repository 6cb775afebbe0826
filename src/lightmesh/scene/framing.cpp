// framing.cpp -- a bare mesh file made a scene: a camera that sees the whole model, a
// ground slab (none when the model brings its own floor at its base) and two lights; and
// the ground slab that scene files ask for too.
#include "lightmesh/scene/scene_load.h"

#include <algorithm>
#include <cmath>

#include "lightmesh/scene/camera_overrides.h"
#include "lightmesh/scene/file_cameras_lights.h"
#include "lightmesh/scene/mesh_loader.h"
#include "lightmesh/scene/shapes.h"
#include "lightmesh/util/error.h"

namespace lm::scene_load {

using namespace json;  // Reader

namespace {

/// How far below a flat level model its ground goes, in the model's largest extent.
constexpr float kFlatModelGroundDrop = 0.1f;

/// The area of the triangles lying in the plane y = box.lo.y (within 1e-5 of the model's
/// size) and facing up (+y by their winding): a floor the model brings along.
float UpwardAreaAtBase(const TriangleMesh& mesh, const Bounds3& box) {
    const float eps = 1e-5f * box.MaxExtent();
    double area = 0;
    for (const auto& t : mesh.triangles) {
        const Vec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
        if (std::abs(a.y - box.lo.y) > eps || std::abs(b.y - box.lo.y) > eps ||
            std::abs(c.y - box.lo.y) > eps)
            continue;
        const Vec3 n = Cross(b - a, c - a);
        if (n.y > 0) area += 0.5 * static_cast<double>(n.y);
    }
    return static_cast<float>(area);
}

/// The file's camera `options.camera` picks ("": the first) as the scene's, with a note;
/// false when the file has none (an error if --camera asked for one).
bool UseFileCamera(const Reader& r, const LoadedMesh& loaded, const SceneLoadOptions& options, float aspect,
                   Scene* scene) {
    if (loaded.cameras.empty()) {
        if (!options.camera.empty())
            r.Fail("", "--camera " + options.camera + ": the file has no cameras (it is framed automatically)");
        return false;
    }
    std::string problem;
    const int index = SelectFileCamera(loaded.cameras, options.camera, &problem);
    if (index < 0 && options.camera.empty()) {
        scene->report.notes.push_back(StringPrintf(
            "the file's %zu camera%s orthographic (lightmesh renders perspective cameras): framing it instead",
            loaded.cameras.size(), loaded.cameras.size() == 1 ? " is" : "s are"));
        return false;
    }
    if (index < 0) r.Fail("", "--camera " + options.camera + ": " + problem);
    const FileCamera& fc = loaded.cameras[static_cast<size_t>(index)];
    std::string which;
    problem = TakeFileCamera(fc, index, aspect, &scene->camera, &which);
    if (!problem.empty()) r.Fail("", "the file's " + which + " cannot be used: " + problem);
    const Camera& cam = scene->camera;
    scene->report.notes.push_back(StringPrintf(
        "the file's %s (of %zu%s) at %s looking towards %s, %.4g° vertical field of view", which.c_str(),
        loaded.cameras.size(), loaded.cameras.size() > 1 ? "; --camera NAME|INDEX picks another" : "",
        FormatVec(cam.position).c_str(), FormatVec(cam.lookAt).c_str(), static_cast<double>(cam.fovY)));
    return true;
}

/// The file's lights as the scene's (file_cameras_lights.h's rules), with a note; false
/// when it has none that lightmesh renders. `box` is the model's (point lights' default
/// radii); suns are placed once the ground is in (PlaceSuns).
bool UseFileLights(const Reader& r, const LoadedMesh& loaded, const Bounds3& box, Scene* scene) {
    size_t unsupported = 0, points = 0, spots = 0, suns = 0, linear = 0;
    std::string firstUnsupported;
    std::vector<PointLight> lights;
    for (size_t i = 0; i < loaded.lights.size(); ++i) {
        const FileLight& fl = loaded.lights[i];
        if (fl.type == FileLight::Type::Unsupported) {
            if (unsupported++ == 0) firstUnsupported = "\"" + fl.name + "\" is " + fl.unsupported;
            continue;
        }
        PointLight l;
        if (std::string p = LightFromFile(fl, box, &l); !p.empty())
            r.Fail("", StringPrintf("the file's light %zu \"%s\" cannot be used: %s", i, fl.name.c_str(), p.c_str()));
        if (l.kind != LightKind::Sun) {
            if (std::string p = CoordinateProblem(l.position, "the light"); !p.empty())
                r.Fail("", StringPrintf("the file's light %zu \"%s\": %s", i, fl.name.c_str(), p.c_str()));
            linear += fl.linear != 0;
        }
        (l.kind == LightKind::Sun ? suns : l.kind == LightKind::Spot ? spots : points)++;
        lights.push_back(std::move(l));
    }
    if (unsupported)
        r.Warn(StringPrintf("%s: %zu of the file's lights left out (%s; lightmesh renders point, spot and "
                            "directional lights)",
                            scene->name.c_str(), unsupported, firstUnsupported.c_str()));
    if (linear)
        r.Warn(StringPrintf("%s: %zu of the file's lights have a linear attenuation term, which lightmesh leaves out "
                            "(inverse-square or no falloff)",
                            scene->name.c_str(), linear));
    if (lights.empty()) return false;
    scene->lights = std::move(lights);
    scene->report.notes.push_back(StringPrintf(
        "the file's lights: %zu point, %zu spot, %zu directional (the sun: angular radius %g°); point lights and "
        "spots get radius %d %% of their distance to the model's centre (--light-radius 0 makes them points)",
        points, spots, suns, static_cast<double>(kSunAngleDegrees),
        static_cast<int>(std::lround(100 * kDefaultLightRadiusShare))));
    return true;
}

}  // namespace

std::string TakeFileCamera(const FileCamera& fc, int index, float aspect, Camera* camera, std::string* which) {
    *which = fc.name.empty() ? StringPrintf("camera %d", index) : StringPrintf("camera %d \"%s\"", index, fc.name.c_str());
    std::string problem = CameraFromFile(fc, aspect, camera);
    if (problem.empty()) {
        std::string key;
        problem = CameraProblem(*camera, &key);
    }
    if (problem.empty()) problem = CoordinateProblem(camera->position, "the camera position");
    return problem;
}

void AddGround(Scene* scene, const Bounds3& box, int axis, float height, float sizeFactor,
               uint32_t material) {
    // A thin closed slab whose top face is the ground, rather than a bare quad: every
    // object stays a closed solid (the inside test, "СТ", relies on it) and nodes below
    // the ground count as inside it. Axes u, v, up are right-handed, so faces point out.
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    const Vec3 extent = box.Diagonal();
    float side = sizeFactor * std::max(extent[u], extent[v]);
    if (!(side > 0)) side = sizeFactor * box.MaxExtent();
    const float thickness = 0.01f * side;
    Vec3 centre = box.Center(), eu, ev, eup;
    centre[axis] = height - 0.5f * thickness;
    eu[u] = 0.5f * side;
    ev[v] = 0.5f * side;
    eup[axis] = 0.5f * thickness;
    TriangleMesh slab;
    ShapeBuilder(&slab).OrientedBox(centre, eu, ev, eup, material);
    // Keep the scene's vertex normals (Append drops them all if one part has none); the
    // slab's shared corners get the up normal, right for the top face that is seen.
    if (scene->mesh.HasShadingNormals()) {
        Vec3 n;
        n[axis] = 1;
        slab.normals.assign(slab.positions.size(), n);
    }
    scene->mesh.Append(slab);
    scene->ground = GroundSlab{axis, height, sizeFactor, material};
}

Material GroundMaterial() {
    Material m;
    m.name = "ground";
    m.kd = Color(0.7f);
    return m;
}


/// The automatic camera: a three-quarter view from the front (+z), a little right and
/// above, looking at the box's centre from the nearest distance at which all 8 corners of
/// the box fall inside 90% of the image (a corner c, relative to the centre, at depth
/// d − c·back projects to |c·right| / depth ≤ 0.9·tan(half field of view)).
void FrameCamera(const Reader& r, const Bounds3& box, float aspect, float fovY, Scene* scene) {
    const Vec3 center = box.Center();
    const float radius = 0.5f * Length(box.Diagonal());
    auto& notes = scene->report.notes;
    Camera& cam = scene->camera;
    cam.fovY = fovY > 0 ? fovY : 40.0f;
    const float tanY = 0.9f * std::tan(0.5f * cam.fovY * Pi / 180.0f), tanX = tanY * aspect;
    const Vec3 back = Normalize(Vec3(0.5f, 0.45f, 1.0f));  // from the centre towards the camera
    const Vec3 right = Normalize(Cross(-back, Vec3(0, 1, 0)));
    const Vec3 up = Cross(right, -back);
    float distance = 0;
    for (int k = 0; k < 8; ++k) {
        const Vec3 c = Vec3((k & 1) ? box.hi.x : box.lo.x, (k & 2) ? box.hi.y : box.lo.y,
                            (k & 4) ? box.hi.z : box.lo.z) -
                       center;
        const float depthOffset = Dot(c, back);
        distance = std::max({distance, depthOffset + 0.05f * radius,
                             depthOffset + std::abs(Dot(c, right)) / tanX,
                             depthOffset + std::abs(Dot(c, up)) / tanY});
    }
    cam.lookAt = center;
    cam.position = center + back * distance;
    cam.up = Vec3(0, 1, 0);
    notes.push_back(
        StringPrintf("camera at %s looking at the model's centre %s, %g° vertical field of view",
                     FormatVec(cam.position).c_str(), FormatVec(center).c_str(), cam.fovY));

    if (std::string p = CoordinateProblem(cam.position, "the camera position"); !p.empty())
        r.Fail("", "automatic framing: " + p +
                       " (the model is too large to frame: scale it down or write a .json scene)");
}

/// Two lights above the model: a key light front-left, a weaker fill light right.
void AddKeyAndFillLights(const Reader& r, const Bounds3& box, Scene* scene) {
    const Vec3 center = box.Center();
    const float radius = 0.5f * Length(box.Diagonal());
    // With inverse-square falloff, intensities scale with distance² so the model receives
    // about 0.9 and 0.3 of full irradiance whatever its size.
    // Each is a small sphere, sized by the rule for lights without a stated size (from the
    // model's box, which the lights are placed by), so the shadows are soft by default.
    const Vec3 keyPosition = center + Vec3(-1.5f, 3.5f, 2.0f) * radius;
    const Vec3 fillPosition = center + Vec3(2.5f, 2.5f, 0.5f) * radius;
    const float keyRadius = DefaultLightRadius(box, keyPosition);
    const float fillRadius = DefaultLightRadius(box, fillPosition);
    scene->lights.push_back({keyPosition, Color(0.9f * LengthSquared(keyPosition - center)), Falloff::InverseSquare,
                            keyRadius});
    scene->lights.push_back({fillPosition, Color(0.3f * LengthSquared(fillPosition - center)),
                            Falloff::InverseSquare, fillRadius});
    scene->report.notes.push_back(StringPrintf(
        "key light at %s and fill light at %s, inverse-square falloff, radius %.3g and %.3g (%d %% of their "
        "distance to the model's centre; --light-radius 0 makes them points)",
        FormatVec(keyPosition).c_str(), FormatVec(fillPosition).c_str(), static_cast<double>(keyRadius),
        static_cast<double>(fillRadius), static_cast<int>(std::lround(100 * kDefaultLightRadiusShare))));
    for (const PointLight& l : scene->lights)
        if (std::string p = CoordinateProblem(l.position, "a light"); !p.empty())
            r.Fail("", "automatic framing: " + p +
                           " (the model is too large to frame: scale it down or write a .json scene)");
}

/// A bare mesh: frame it with a camera, a ground plane and two lights.
Scene LoadBareMesh(const std::string& spec, const SceneLoadOptions& options,
                   std::vector<std::string>* warnings) {
    const Reader r(spec, SceneLoadOptions{}.strict, warnings);
    MeshLoadOptions load;
    load.smoothAngle = options.smoothNormals >= 0 ? options.smoothNormals : kBareMeshSmoothNormals;
    LoadedMesh loaded = LoadMeshFile(spec, load);  // its errors already name the file
    for (const std::string& w : loaded.warnings) r.Warn(w);

    // --up x|z: the model turned so that axis points up (+y), before anything is framed;
    // its own cameras and lights turn with it.
    if (options.upAxis != 1) {
        const Affine turn = UpAxisToY(options.upAxis);
        TransformMesh(&loaded.mesh, turn);
        for (FileCamera& c : loaded.cameras) {
            c.position = turn.ApplyPoint(c.position);
            c.lookAt = turn.ApplyVector(c.lookAt);
            c.up = turn.ApplyVector(c.up);
        }
        for (FileLight& l : loaded.lights) {
            l.position = turn.ApplyPoint(l.position);
            l.direction = turn.ApplyVector(l.direction);
        }
    }

    Scene scene;
    scene.name = spec;
    scene.report.sources.push_back(spec);
    TextureCache textureCache;
    AttachTextures(r, spec, options.textures, &textureCache, &loaded, &scene);
    scene.mesh = std::move(loaded.mesh);
    scene.materials = std::move(loaded.materials);
    const CleanReport clean = CleanMesh(&scene.mesh);
    scene.report.degenerateRemoved = clean.degenerate;
    scene.report.duplicatesRemoved = clean.duplicate;
    if (clean.degenerate || clean.duplicate) r.Warn(spec + ": " + DroppedMessage(clean));
    if (scene.mesh.TriangleCount() == 0) r.Fail("", NoTrianglesMessage(scene.report, scene.mesh));
    CheckExtent(r, "", scene);

    const Bounds3 box = scene.mesh.Bounds();
    auto& notes = scene.report.notes;
    notes.push_back(loaded.cameras.empty() && loaded.lights.empty()
                        ? "no scene file: framing the model automatically (write a .json scene to choose)"
                        : "no scene file: the model's own cameras and lights where it has them, framing and a "
                          "ground for the rest (--save-scene writes a .json scene to edit)");
    notes.push_back(options.upAxis == 1 ? std::string("up axis: +y, as in OBJ and glTF")
                                        : StringPrintf("up axis: +%c (--up), turned to +y", "xyz"[options.upAxis]));

    // Camera: the file's (--camera picks one), else a three-quarter view (FrameCamera).
    const bool hinted = options.frameWidth > 0 && options.frameHeight > 0;
    const float aspect =
        hinted ? static_cast<float>(options.frameWidth) / static_cast<float>(options.frameHeight)
               : static_cast<float>(scene.render.width) / static_cast<float>(scene.render.height);
    if (!UseFileCamera(r, loaded, options, aspect, &scene)) FrameCamera(r, box, aspect, options.frameFovY, &scene);
    // Ground: under the model's lowest point, three times its horizontal size -- unless the
    // model has its own floor there (a playground's lawn), which a slab would meet exactly
    // coplanar: z-fighting, and back-ends disagreeing on which of the two is hit.
    const float floorShare = UpwardAreaAtBase(scene.mesh, box) /
                             std::max(box.Diagonal().x * box.Diagonal().z, 1e-30f);
    if (floorShare >= 0.5f) {
        notes.push_back(StringPrintf(
            "no ground plane added: the model has its own floor at y = %g (%.0f%% of its "
            "footprint faces up there)",
            box.lo.y, std::min(100.0f, 100.0f * floorShare)));
    } else {
        const uint32_t groundMaterial = static_cast<uint32_t>(scene.materials.size());
        scene.materials.push_back(GroundMaterial());
        // A flat model lying level (a card, a leaf facing down: under 0.1 % of its size
        // high): a ground at its height would coincide with it, so it goes below.
        const bool flat = box.Diagonal().y <= 1e-3f * box.MaxExtent();
        if (flat) {
            const float height = box.lo.y - kFlatModelGroundDrop * box.MaxExtent();
            AddGround(&scene, box, 1, height, 3.0f, groundMaterial);
            notes.push_back(StringPrintf(
                "ground plane at y = %g, %g %% of the model's width below it (the model is flat and level: a "
                "ground at its height would coincide with it), 3x the model's width",
                height, 100.0 * kFlatModelGroundDrop));
        } else if (floorShare > 0) {
            // Some of the model's base faces up: sink the slab a little below it.
            const float height = box.lo.y - 0.002f * box.MaxExtent();
            AddGround(&scene, box, 1, height, 3.0f, groundMaterial);
            notes.push_back(StringPrintf(
                "ground plane at y = %g, just below the model's lowest point (part of its base "
                "faces up there), 3x the model's width",
                height));
        } else {
            AddGround(&scene, box, 1, box.lo.y, 3.0f, groundMaterial);
            notes.push_back(StringPrintf(
                "ground plane at y = %g (the model's lowest point), 3x the model's width",
                box.lo.y));
        }
        const Bounds3 all = scene.mesh.Bounds();
        if (!(std::max(Reach(all.lo), Reach(all.hi)) <= kMaxCoordinate))
            r.Fail("", StringPrintf("automatic framing: the ground slab reaches %g, beyond the ±%g that "
                                    "single-precision rendering allows (scale the model down or "
                                    "write a .json scene)",
                                    double(std::max(Reach(all.lo), Reach(all.hi))),
                                    double(kMaxCoordinate)));
    }

    if (!UseFileLights(r, loaded, box, &scene)) AddKeyAndFillLights(r, box, &scene);
    PlaceSuns(&scene, scene.mesh.Bounds());
    for (const PointLight& l : scene.lights)
        if (l.kind == LightKind::Sun)
            if (std::string p = CoordinateProblem(l.position, "the sun's far sphere"); !p.empty())
                r.Fail("", p + StringPrintf(" (the model is too large for the sun's distance, %g times its size)",
                                            double(kSunDistanceFactor)));
    if (std::string p = SpanProblem(scene); !p.empty()) r.Fail("", p);
    BuildCutouts(&scene);
    return scene;
}

}  // namespace lm::scene_load
