// Tests of a scene file without "camera" or "lights": its mesh files' own cameras and lights
// (tests/data/cameras_lights, make_test_files.py says what each file holds), moved by their
// entries' transforms, the scene file's own winning, --camera through a scene file, and the
// automatic camera and lights when no mesh file has any.
#include "lightmesh/scene/scene_file.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "lightmesh/geometry/affine.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace scene_file_cameras_lights_test {
namespace {

const std::string kData = std::string(LIGHTMESH_TEST_DATA) + "/cameras_lights";
const std::string kLit = kData + "/lit_scene.gltf";
const std::string kBoxes = std::string(LIGHTMESH_TEST_DATA) + "/scene_file/two_boxes.obj";

/// A scene file's text, read as if it were kData/scene.json.
Scene LoadText(const std::string& text, const std::string& camera = "", std::vector<std::string>* warnings = nullptr) {
    SceneLoadOptions options;
    options.text = text;
    options.camera = camera;
    std::vector<std::string> ignored;
    return LoadScene(kData + "/scene.json", options, warnings ? warnings : &ignored);
}

Scene LoadBare(const std::string& file, const std::string& camera = "") {
    SceneLoadOptions options;
    options.camera = camera;
    std::vector<std::string> ignored;
    return LoadScene(file, options, &ignored);
}

/// The message of the Error loading the scene text throws ("<no error>" if none).
std::string LoadTextError(const std::string& text, const std::string& camera) {
    try {
        LoadText(text, camera);
    } catch (const Error& e) {
        return e.what();
    }
    return "<no error>";
}

std::string Mesh(const std::string& file, const std::string& extra = "") {
    return "{\"file\": \"" + file + "\"" + extra + "}";
}

bool HasNote(const Scene& scene, const std::string& text) {
    for (const std::string& n : scene.report.notes)
        if (n.find(text) != std::string::npos) return true;
    return false;
}

void ExpectSameCamera(const Camera& a, const Camera& b) {
    EXPECT_EQ(a.position, b.position);
    EXPECT_EQ(a.lookAt, b.lookAt);
    EXPECT_EQ(a.up, b.up);
    EXPECT_EQ(a.fovY, b.fovY);
}

void ExpectSameLights(const std::vector<PointLight>& a, const std::vector<PointLight>& b) {
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
        SCOPED_TRACE(i);
        EXPECT_EQ(a[i].name, b[i].name);
        EXPECT_EQ(a[i].kind, b[i].kind);
        EXPECT_EQ(a[i].position, b[i].position);
        EXPECT_EQ(a[i].intensity.r, b[i].intensity.r);
        EXPECT_EQ(a[i].intensity.g, b[i].intensity.g);
        EXPECT_EQ(a[i].intensity.b, b[i].intensity.b);
        EXPECT_EQ(a[i].falloff, b[i].falloff);
        EXPECT_EQ(a[i].radius, b[i].radius);
        EXPECT_EQ(a[i].range, b[i].range);
        EXPECT_EQ(a[i].spot.direction, b[i].spot.direction);
        EXPECT_EQ(a[i].spot.cosInner, b[i].spot.cosInner);
        EXPECT_EQ(a[i].spot.cosOuter, b[i].spot.cosOuter);
        EXPECT_EQ(a[i].sun.direction, b[i].sun.direction);
        EXPECT_EQ(a[i].sun.angle, b[i].sun.angle);
    }
}

void ExpectNear(const Vec3& a, const Vec3& b, float tolerance) {
    EXPECT_NEAR(a.x, b.x, tolerance) << a.x << " " << a.y << " " << a.z;
    EXPECT_NEAR(a.y, b.y, tolerance) << a.x << " " << a.y << " " << a.z;
    EXPECT_NEAR(a.z, b.z, tolerance) << a.x << " " << a.y << " " << a.z;
}

TEST(SceneFileCamerasLights, IdentityTransformGivesTheModelsCameraAndLights) {
    // lit_scene brings its own floor, so the bare file gets no ground slab: the scene file
    // (without "ground") has the same bounds, hence the same light radii and sun placement.
    for (const std::string& file : {kLit, kData + "/lit_scene.dae"}) {
        SCOPED_TRACE(file);
        const Scene bare = LoadBare(file);
        const Scene scene = LoadText("{\"meshes\": [" + Mesh(file) + "]}");
        ExpectSameCamera(scene.camera, bare.camera);
        ExpectSameLights(scene.lights, bare.lights);
        EXPECT_TRUE(HasNote(scene, "no \"camera\": the camera 0 \"Main\" of \"" + file + "\" (/meshes/0; of ")) << file;
        EXPECT_TRUE(HasNote(scene, "no \"lights\": the lights of its mesh files (/meshes/0): 1 point, ")) << file;
    }
}

TEST(SceneFileCamerasLights, TheEntrysTransformMovesTheCameraAndLights) {
    const Affine t = Affine::Translate(Vec3(1, 2, 3)) * Affine::Rotate(Vec3(0, 1, 0), 90) * Affine::Scale(Vec3(2));
    const Scene bare = LoadBare(kLit);
    const Scene scene = LoadText(
        "{\"meshes\": [" +
        Mesh(kLit, R"(, "transform": {"scale": 2, "rotate": [0, 1, 0, 90], "translate": [1, 2, 3]})") + "]}");
    // The camera: its position moved, its view and up directions turned; the field of view
    // is the file's (a camera node's scale does not change its projection).
    ExpectNear(scene.camera.position, t.ApplyPoint(bare.camera.position), 1e-4f);
    ExpectNear(scene.camera.position, Vec3(13, 8, 3), 1e-4f);
    ExpectNear(Normalize(scene.camera.lookAt - scene.camera.position),
               Normalize(t.ApplyVector(bare.camera.lookAt - bare.camera.position)), 1e-5f);
    ExpectNear(scene.camera.up, Normalize(t.ApplyVector(bare.camera.up)), 1e-5f);
    EXPECT_EQ(scene.camera.fovY, bare.camera.fovY);
    // The lights: positions moved, directions turned, intensities and cones the file's;
    // point lights and spots sized by the 2 % rule from the moved scene's bounds.
    ASSERT_EQ(scene.lights.size(), bare.lights.size());
    const Bounds3 bounds = scene.mesh.Bounds();
    for (size_t i = 0; i < scene.lights.size(); ++i) {
        SCOPED_TRACE(i);
        const PointLight &l = scene.lights[i], &b = bare.lights[i];
        EXPECT_EQ(l.kind, b.kind);
        EXPECT_EQ(l.intensity.r, b.intensity.r);
        EXPECT_EQ(l.falloff, b.falloff);
        if (l.kind == LightKind::Sun) {
            ExpectNear(l.sun.direction, Normalize(t.ApplyVector(b.sun.direction)), 1e-5f);
            EXPECT_EQ(l.sun.angle, b.sun.angle);
            continue;
        }
        ExpectNear(l.position, t.ApplyPoint(b.position), 1e-4f);
        EXPECT_FLOAT_EQ(l.radius, DefaultLightRadius(bounds, l.position));
        if (l.kind == LightKind::Spot) {
            ExpectNear(l.spot.direction, Normalize(t.ApplyVector(b.spot.direction)), 1e-5f);
            EXPECT_EQ(l.spot.cosInner, b.spot.cosInner);
            EXPECT_EQ(l.spot.cosOuter, b.spot.cosOuter);
        }
    }
    // The bulb at (0, 4, 4) in the file: scaled to (0, 8, 8), turned to (8, 8, 0), moved.
    ExpectNear(scene.lights[0].position, Vec3(9, 10, 3), 1e-4f);
}

TEST(SceneFileCamerasLights, TheSceneFilesOwnCameraAndLightsWin) {
    const std::string camera = R"("camera": {"position": [1, 2, 30], "look_at": [0, 0, 0], "fov": 30})";
    const std::string lights = R"("lights": [{"position": [0, 20, 0], "intensity": 7}])";
    const std::string meshes = "\"meshes\": [" + Mesh(kLit) + "]";
    const Scene bare = LoadBare(kLit);

    const Scene both = LoadText("{" + camera + ", " + lights + ", " + meshes + "}");
    EXPECT_EQ(both.camera.position, Vec3(1, 2, 30));
    EXPECT_EQ(both.camera.fovY, 30.0f);
    ASSERT_EQ(both.lights.size(), 1u);
    EXPECT_EQ(both.lights[0].position, Vec3(0, 20, 0));
    EXPECT_FALSE(HasNote(both, "no \"camera\""));
    EXPECT_FALSE(HasNote(both, "no \"lights\""));

    // Each is taken on its own: the file's camera with the scene's lights, and back.
    const Scene ownLights = LoadText("{" + lights + ", " + meshes + "}");
    ExpectSameCamera(ownLights.camera, bare.camera);
    ASSERT_EQ(ownLights.lights.size(), 1u);
    const Scene ownCamera = LoadText("{" + camera + ", " + meshes + "}");
    EXPECT_EQ(ownCamera.camera.position, Vec3(1, 2, 30));
    ExpectSameLights(ownCamera.lights, bare.lights);
}

TEST(SceneFileCamerasLights, TheFirstFileWithCamerasAndEveryFilesLights) {
    // two_boxes.obj has neither: the camera is the second entry's; lit_scene placed twice
    // brings its three lights twice, each copy moved by its own entry.
    const Scene scene = LoadText("{\"meshes\": [" + Mesh(kBoxes) + ", " + Mesh(kLit) + ", " +
                                 Mesh(kLit, R"(, "transform": {"translate": [0, 0, 50]})") + "]}");
    EXPECT_TRUE(HasNote(scene, "of \"" + kLit + "\" (/meshes/1; of 2;"));
    EXPECT_TRUE(HasNote(scene, "no \"lights\": the lights of its mesh files (/meshes/1 and /meshes/2): 2 point, 2 "
                               "spot, 2 directional"));
    ASSERT_EQ(scene.lights.size(), 6u);
    ExpectNear(scene.lights[3].position, scene.lights[0].position + Vec3(0, 0, 50), 1e-4f);
}

TEST(SceneFileCamerasLights, CameraPicksAmongTheMeshFilesCameras) {
    const std::string text = "{\"meshes\": [" + Mesh(kLit) + "]}";
    const Scene top = LoadBare(kLit, "Top");
    for (const std::string& choice : {"Top", "1"}) {
        SCOPED_TRACE(choice);
        const Scene scene = LoadText(text, choice);
        ExpectSameCamera(scene.camera, top.camera);
        EXPECT_TRUE(HasNote(scene, "no \"camera\": the camera 1 \"Top\" of \"" + kLit + "\""));
    }
}

TEST(SceneFileCamerasLights, CameraErrorsAreOneLine) {
    const std::string spec = kData + "/scene.json";
    // The scene file sets its camera: --camera has nothing to pick.
    EXPECT_EQ(LoadTextError(R"({"camera": {"position": [0, 2, 9], "look_at": [0, 0, 0]}, "meshes": [)" + Mesh(kLit) +
                                "]}",
                            "Top"),
              spec +
                  " /camera: --camera Top picks one of a mesh file's own cameras; this scene file sets its "
                  "\"camera\" (leave the key out to use its mesh files' cameras)");
    // No mesh file has cameras.
    EXPECT_EQ(LoadTextError("{\"meshes\": [" + Mesh(kBoxes) + "]}", "0"),
              spec + ": --camera 0: none of the scene's mesh files has cameras (without \"camera\" it is framed "
                     "automatically)");
    // The file that has cameras has none such.
    EXPECT_EQ(LoadTextError("{\"meshes\": [" + Mesh(kBoxes) + ", " + Mesh(kLit) + "]}", "Nope"),
              spec + " /meshes/1: --camera Nope: \"" + kLit +
                  "\" has no camera named \"Nope\" (its cameras: \"Main\", \"Top\")");
    EXPECT_EQ(LoadTextError("{\"meshes\": [" + Mesh(kLit) + "]}", "2"),
              spec + " /meshes/0: --camera 2: \"" + kLit + "\" has 2 cameras (indices 0 to 1), no camera 2");
}

TEST(SceneFileCamerasLights, WithoutAnyTheMeshesAreFramedAndLit) {
    // A mesh file without cameras or lights: the automatic camera and the key and fill
    // lights, as for the bare file (whose box is the same: the scene file adds no ground).
    const Scene bare = LoadBare(kBoxes);
    const Scene scene = LoadText("{\"meshes\": [" + Mesh(kBoxes) + "]}");
    ExpectSameCamera(scene.camera, bare.camera);
    ExpectSameLights(scene.lights, bare.lights);
    EXPECT_TRUE(HasNote(scene, "no \"camera\" in the scene file or its mesh files: framing the meshes automatically"));
    EXPECT_TRUE(HasNote(scene, "no \"lights\" in the scene file or its mesh files: a key and a fill light"));
}

}  // namespace
}  // namespace scene_file_cameras_lights_test
}  // namespace lm
