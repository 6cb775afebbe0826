// texturing_test.cpp -- textured models end to end: the import finds the image and the
// texture coordinates, the scene reads it once, shading reads the texel under a hit.
#include "lightmesh/render/texturing.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "lightmesh/render/render_job.h"
#include "lightmesh/scene/scene_file.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace texturing_test {
namespace {

namespace fs = std::filesystem;
const std::string DataDir = std::string(LIGHTMESH_TEST_DATA) + "/textures";

Scene Load(const std::string& spec, bool textures = true, std::vector<std::string>* warnings = nullptr) {
    SceneLoadOptions o;
    o.textures = textures;
    std::vector<std::string> ignored;
    return LoadScene(spec, o, warnings ? warnings : &ignored);
}

/// The diffuse colour shading sees where a ray down -z meets the quad at (x, y).
Color DiffuseAt(const Scene& scene, const Accelerator& accel, float x, float y) {
    const Ray ray{Vec3(x, y, 5), Vec3(0, 0, -1), 0, Infinity};
    Hit hit;
    EXPECT_TRUE(accel.Intersect(ray, &hit));
    const Material& m = scene.materials[scene.mesh.materialIds[hit.prim]];
    return TexturedDiffuse(scene, m, ray, hit, 1e-4f);
}

void ExpectNear(const Color& a, const Color& b) {
    EXPECT_NEAR(a.r, b.r, 1e-3f);
    EXPECT_NEAR(a.g, b.g, 1e-3f);
    EXPECT_NEAR(a.b, b.b, 1e-3f);
}

// quad.obj: map_Kd texels.png, red and green on top, blue and white below.
TEST(Texturing, TheColourUnderEachTexelOfAnObjMtlQuad) {
    const Scene scene = Load(DataDir + "/quad.obj");
    ASSERT_EQ(scene.textures.size(), 1u);
    ASSERT_EQ(scene.mesh.uvs.size(), scene.mesh.positions.size());
    const auto accel = CreateAccelerator("brute", scene.mesh);
    ExpectNear(DiffuseAt(scene, *accel, -0.5f, 0.5f), Color(1, 0, 0));
    ExpectNear(DiffuseAt(scene, *accel, 0.5f, 0.5f), Color(0, 1, 0));
    ExpectNear(DiffuseAt(scene, *accel, -0.5f, -0.5f), Color(0, 0, 1));
    ExpectNear(DiffuseAt(scene, *accel, 0.5f, -0.5f), Color(1, 1, 1));
}

// texture_transform.gltf: the same quad and image, KHR_texture_transform scaling the base
// colour's coordinates to the image's top-right block: green everywhere.
TEST(Texturing, AGltfTextureTransformMovesTheImage) {
    const Scene scene = Load(DataDir + "/texture_transform.gltf");
    ASSERT_EQ(scene.textures.size(), 1u);
    const auto accel = CreateAccelerator("brute", scene.mesh);
    for (float x : {-0.5f, 0.5f})
        for (float y : {-0.5f, 0.5f}) ExpectNear(DiffuseAt(scene, *accel, x, y), Color(0, 1, 0));
}

TEST(Texturing, AWideFootprintReadsACoarserLevel) {
    const Scene scene = Load(DataDir + "/quad.obj");
    const auto accel = CreateAccelerator("brute", scene.mesh);
    const Ray ray{Vec3(-0.5f, 0.5f, 5), Vec3(0, 0, -1), 0, Infinity};
    Hit hit;
    ASSERT_TRUE(accel->Intersect(ray, &hit));
    const Material& m = scene.materials[scene.mesh.materialIds[hit.prim]];
    // A footprint as wide as the quad: the 1 x 1 level, the four texels' mean.
    const Color far = TexturedDiffuse(scene, m, ray, hit, 2.0f / hit.t);
    EXPECT_NEAR(far.r, 0.5f, 0.01f);
    EXPECT_NEAR(far.b, 0.5f, 0.01f);
}

TEST(Texturing, NoTexturesLeavesFlatColoursAndNoCoordinates) {
    const Scene scene = Load(DataDir + "/quad.obj", false);
    EXPECT_TRUE(scene.textures.empty());
    EXPECT_TRUE(scene.mesh.uvs.empty());
    for (const Material& m : scene.materials) EXPECT_EQ(m.texture, -1);
}

TEST(Texturing, AScenesRenderTexturesKeyTurnsThemOff) {
    const fs::path dir = fs::temp_directory_path() / "lightmesh_texturing_test";
    fs::create_directories(dir);
    const std::string json = (dir / "scene.json").string();
    std::ofstream(json) << R"({"lights": [{"position": [0, 0, 5]}], "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
        "meshes": [{"file": ")" << DataDir << R"(/quad.obj"}], "render": {"textures": false}})";
    const Scene scene = Load(json);
    EXPECT_TRUE(scene.textures.empty());
    EXPECT_TRUE(scene.mesh.uvs.empty());
    // Anything but true or false is an error at its JSON path.
    std::ofstream(json) << R"({"lights": [{"position": [0, 0, 5]}], "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
        "meshes": [{"file": ")" << DataDir << R"(/quad.obj"}], "render": {"textures": "off"}})";
    try {
        Load(json);
        ADD_FAILURE() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("/render/textures: expected true or false"), std::string::npos) << e.what();
    }
    fs::remove_all(dir);
}

// A file material the scene file replaces by name reads no image.
TEST(Texturing, AMaterialTheSceneReplacesReadsNoImage) {
    const fs::path dir = fs::temp_directory_path() / "lightmesh_texturing_replaced";
    fs::create_directories(dir);
    const std::string json = (dir / "scene.json").string();
    std::ofstream(json) << R"({"lights": [{"position": [0, 0, 5]}], "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0]},
        "materials": {"texels": {"kd": 0.5}}, "meshes": [{"file": ")" << DataDir << R"(/quad.obj"}]})";
    const Scene scene = Load(json);
    EXPECT_TRUE(scene.textures.empty());
    EXPECT_TRUE(scene.mesh.uvs.empty());
    fs::remove_all(dir);
}

TEST(Texturing, AMissingImageGetsOneWarningAndTheFlatColour) {
    const fs::path dir = fs::temp_directory_path() / "lightmesh_texturing_missing";
    fs::create_directories(dir);
    std::ofstream(dir / "m.mtl") << "newmtl a\nKd 0.2 0.4 0.6\nmap_Kd gone.png\nnewmtl b\nKd 0.1 0.1 0.1\nmap_Kd gone.png\n";
    std::ofstream(dir / "m.obj") << "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n"
                                    "usemtl a\nf 1/1 2/2 3/3\nusemtl b\nf 1/1 3/3 4/1\n";
    std::vector<std::string> warnings;
    const Scene scene = Load((dir / "m.obj").string(), true, &warnings);
    size_t textureWarnings = 0;
    for (const std::string& w : warnings) textureWarnings += w.find("gone.png") != std::string::npos;
    EXPECT_EQ(textureWarnings, 1u);
    EXPECT_TRUE(scene.textures.empty());
    EXPECT_TRUE(scene.mesh.uvs.empty());
    bool found = false;
    for (const Material& m : scene.materials) found = found || (m.name == "a" && m.kd == Color(0.2f, 0.4f, 0.6f));
    EXPECT_TRUE(found);
    fs::remove_all(dir);
}

TEST(Texturing, AGltfImageEmbeddedAsADataUriIsRead) {
    const Scene scene = Load(DataDir + "/checker_mask.gltf");
    ASSERT_EQ(scene.textures.size(), 1u);
    EXPECT_EQ(scene.textures[0]->Width(), 8);
    EXPECT_TRUE(scene.textures[0]->HasAlpha());
}

// Textures change nothing for an untextured scene: no coordinates, the same image.
TEST(Texturing, AnUntexturedSceneRendersTheSameWithAndWithout) {
    const Scene on = Load("builtin:gazebo"), off = Load("builtin:gazebo", false);
    EXPECT_TRUE(on.mesh.uvs.empty());
    RenderOptions o = on.render;
    o.width = 64, o.height = 48, o.shadows = "rt", o.accel = "grid";
    const Image a = RenderJob(on, o).Render().image, b = RenderJob(off, o).Render().image;
    EXPECT_EQ(a.pixels, b.pixels);
}

}  // namespace
}  // namespace texturing_test
}  // namespace lm
