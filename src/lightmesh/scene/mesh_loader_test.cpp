// Tests of LoadMeshFile (Assimp import, node walk, materials, excludes).
#include "lightmesh/scene/mesh_loader.h"
#include "lightmesh/scene/mesh_import_internal.h"
#include "support/sanitized.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace lm {
namespace mesh_loader_test {
namespace {

namespace fs = std::filesystem;

const std::string DataDir = std::string(LIGHTMESH_TEST_DATA) + "/scene_file";

std::string TempFolder() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    const fs::path p = fs::path(::testing::TempDir()) /
                       ("lightmesh_" + std::string(info->test_suite_name()) + "_" + info->name());
    fs::remove_all(p);
    fs::create_directories(p);
    return p.string();
}

std::string WriteFile(const std::string& folder, const std::string& name, const std::string& text) {
    const std::string path = folder + "/" + name;
    std::ofstream(path, std::ios::binary) << text;
    return path;
}

bool Near(const Vec3& a, const Vec3& b, float eps = 1e-5f) {
    return Length(a - b) <= eps;
}
bool Near(const Color& a, const Color& b, float eps = 1e-5f) {
    return std::abs(a.r - b.r) <= eps && std::abs(a.g - b.g) <= eps && std::abs(a.b - b.b) <= eps;
}

/// The three corners of every triangle, for order-independent checks.
std::vector<std::array<Vec3, 3>> Corners(const TriangleMesh& mesh) {
    std::vector<std::array<Vec3, 3>> out;
    for (uint32_t t = 0; t < mesh.TriangleCount(); ++t)
        out.push_back({mesh.Vertex(t, 0), mesh.Vertex(t, 1), mesh.Vertex(t, 2)});
    return out;
}

bool HasTriangle(const TriangleMesh& mesh, const std::array<Vec3, 3>& expected) {
    for (const auto& c : Corners(mesh)) {
        for (int rot = 0; rot < 3; ++rot) {  // same winding, any starting corner
            if (Near(c[rot], expected[0]) && Near(c[(rot + 1) % 3], expected[1]) &&
                Near(c[(rot + 2) % 3], expected[2]))
                return true;
        }
    }
    return false;
}

std::string LoadError(const std::string& path) {
    try {
        LoadMeshFile(path);
    } catch (const MeshFileError& e) {
        return e.what();
    } catch (const std::exception& e) {
        return std::string("<not a MeshFileError> ") + e.what();
    }
    return "<no error>";
}

// The importer's known noise (scenes/real/garden.json: 845 messages) is counted in one line;
// other messages are shown.
TEST(MeshLoader, KnownImporterNoiseIsRecognised) {
    EXPECT_TRUE(mesh_import::KnownImporterNoise("<add reason>"));
    EXPECT_TRUE(mesh_import::KnownImporterNoise("BlendDNA: Did not find a field named `totloop` in structure `Mesh`"));
    EXPECT_TRUE(mesh_import::KnownImporterNoise("Validation warning: aiLight::mAttenuationXXX - all are zero"));
    EXPECT_FALSE(mesh_import::KnownImporterNoise("OBJ: Unable to locate material file gone.mtl"));
    EXPECT_FALSE(mesh_import::KnownImporterNoise("BlendDNA: something else"));
}

TEST(MeshLoader, ObjWithMtlMaterials) {
    const LoadedMesh m = LoadMeshFile(DataDir + "/two_boxes.obj");
    EXPECT_EQ(m.mesh.TriangleCount(), 16u);  // 6 quads → 12, plus the tetrahedron's 4
    EXPECT_EQ(m.meshesPlaced, 2u);
    EXPECT_EQ(m.meshesExcluded, 0u);
    EXPECT_TRUE(m.mesh.normals.empty()) << "no vn lines: no normals, none generated";
    EXPECT_TRUE(m.warnings.empty());
    ASSERT_EQ(m.materials.size(), 2u);  // only the materials in use, in order of use
    const Material& red = m.materials[0];
    EXPECT_EQ(red.name, "Red");
    EXPECT_TRUE(Near(red.kd, Color(0.8f, 0.1f, 0.1f)));
    EXPECT_TRUE(Near(red.ks, Color(0.5f)));  // Ks
    EXPECT_EQ(red.phong, 50.0f);             // Ns
    EXPECT_TRUE(red.mirror.IsBlack());
    EXPECT_EQ(m.materials[1].name, "Hidden");
    EXPECT_TRUE(Near(m.materials[1].kd, Color(0, 1, 0)));
    EXPECT_TRUE(m.materials[1].ks.IsBlack());
    for (uint32_t t = 0; t < 12; ++t) EXPECT_EQ(m.mesh.materialIds[t], 0u);
    for (uint32_t t = 12; t < 16; ++t) EXPECT_EQ(m.mesh.materialIds[t], 1u);
    const Bounds3 b = m.mesh.Bounds();
    EXPECT_TRUE(Near(b.lo, Vec3(-1, -1, -1)) && Near(b.hi, Vec3(4, 1, 1)));
}

TEST(MeshLoader, ExcludeByMaterialAndByName) {
    MeshLoadOptions byMaterial;
    byMaterial.excludeMaterials = {"Hid*", "Nothing?"};
    LoadedMesh m = LoadMeshFile(DataDir + "/two_boxes.obj", byMaterial);
    EXPECT_EQ(m.mesh.TriangleCount(), 12u);
    EXPECT_EQ(m.meshesExcluded, 1u);
    EXPECT_EQ(m.excludeMaterialsMatched, (std::vector<bool>{true, false}));
    ASSERT_EQ(m.materials.size(), 1u);
    EXPECT_EQ(m.materials[0].name, "Red");

    MeshLoadOptions byName;
    byName.excludeNames = {"Collision?ull"};
    m = LoadMeshFile(DataDir + "/two_boxes.obj", byName);
    EXPECT_EQ(m.mesh.TriangleCount(), 12u);
    EXPECT_EQ(m.meshesExcluded, 1u);
    EXPECT_EQ(m.excludeNamesMatched, std::vector<bool>{true});
    EXPECT_TRUE(Near(m.mesh.Bounds().hi, Vec3(1, 1, 1)));

    MeshLoadOptions everything;
    everything.excludeNames = {"*"};
    m = LoadMeshFile(DataDir + "/two_boxes.obj", everything);  // not an error: the caller decides
    EXPECT_EQ(m.mesh.TriangleCount(), 0u);
    EXPECT_EQ(m.meshesExcluded, 2u);
}

TEST(MeshLoader, PlyQuadIsTriangulated) {
    const LoadedMesh m = LoadMeshFile(DataDir + "/quad.ply");
    ASSERT_EQ(m.mesh.TriangleCount(), 2u);
    const Bounds3 b = m.mesh.Bounds();
    EXPECT_TRUE(Near(b.lo, Vec3(0, 0, 0)) && Near(b.hi, Vec3(1, 1, 0)));
    ASSERT_EQ(m.materials.size(), 1u);
    EXPECT_EQ(m.materials[0].kd, Color(0.8f)) << "no materials in the file: the default grey";
    EXPECT_TRUE(m.materials[0].ks.IsBlack());
    for (uint32_t t = 0; t < 2; ++t) {  // the quad's winding (counter-clockwise from +z) is kept
        EXPECT_GT(Cross(m.mesh.Vertex(t, 1) - m.mesh.Vertex(t, 0),
                        m.mesh.Vertex(t, 2) - m.mesh.Vertex(t, 0))
                      .z,
                  0);
    }
}

std::string Base64(const std::vector<unsigned char>& bytes) {
    static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    for (size_t i = 0; i < bytes.size(); i += 3) {
        const uint32_t n = (uint32_t(bytes[i]) << 16) |
                           (i + 1 < bytes.size() ? uint32_t(bytes[i + 1]) << 8 : 0) |
                           (i + 2 < bytes.size() ? uint32_t(bytes[i + 2]) : 0);
        out += table[(n >> 18) & 63];
        out += table[(n >> 12) & 63];
        out += i + 1 < bytes.size() ? table[(n >> 6) & 63] : '=';
        out += i + 2 < bytes.size() ? table[n & 63] : '=';
    }
    return out;
}

/// A glTF 2 file with one triangle mesh (positions, normals, indices in an embedded
/// base64 buffer) placed twice under a scaled root node:
///   Root (scale 2, 2, 2) ── InstanceA (translation 1, 0, 0) ── mesh "Tri"
///                        └─ InstanceB (translation 0, 0, 5) ── mesh "Tri"
/// Tri = (0,0,0) (1,0,0) (0,1,0), normals +z, material "Paint".
std::string TinyGltf() {
    const float positions[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const float normals[9] = {0, 0, 1, 0, 0, 1, 0, 0, 1};
    const uint16_t indices[4] = {0, 1, 2, 0};  // three indices + padding
    std::vector<unsigned char> buffer(80);
    std::memcpy(buffer.data(), positions, 36);
    std::memcpy(buffer.data() + 36, normals, 36);
    std::memcpy(buffer.data() + 72, indices, 8);
    return R"({
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [0]}],
  "nodes": [
    {"name": "Root", "children": [1, 2], "scale": [2, 2, 2]},
    {"name": "InstanceA", "mesh": 0, "translation": [1, 0, 0]},
    {"name": "InstanceB", "mesh": 0, "translation": [0, 0, 5]}
  ],
  "meshes": [{"name": "Tri", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
  "materials": [{"name": "Paint", "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 1], "metallicFactor": 0, "roughnessFactor": 0.5}}],
  "buffers": [{"byteLength": 80, "uri": "data:application/octet-stream;base64,)" +
           Base64(buffer) + R"("}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 72}, {"buffer": 0, "byteOffset": 72, "byteLength": 6}],
  "accessors": [
    {"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
    {"bufferView": 0, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC3"},
    {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}
  ]
})";
}

TEST(MeshLoader, GltfHierarchyInstancesAndBaseColour) {
    const std::string path = WriteFile(TempFolder(), "tiny.gltf", TinyGltf());
    const LoadedMesh m = LoadMeshFile(path);
    ASSERT_EQ(m.mesh.TriangleCount(), 2u) << "the shared mesh is expanded once per node";
    EXPECT_EQ(m.meshesPlaced, 2u);
    // World = Root · Instance: 2 · (p + translation).
    EXPECT_TRUE(HasTriangle(m.mesh, {Vec3(2, 0, 0), Vec3(4, 0, 0), Vec3(2, 2, 0)}));
    EXPECT_TRUE(HasTriangle(m.mesh, {Vec3(0, 0, 10), Vec3(2, 0, 10), Vec3(0, 2, 10)}));
    ASSERT_EQ(m.mesh.normals.size(), m.mesh.positions.size()) << "the file's normals are kept";
    for (const Vec3& n : m.mesh.normals) EXPECT_TRUE(Near(n, Vec3(0, 0, 1)));

    // Base colour → kd; a rough dielectric: ks = 0.04·(1 − roughness), phong = 2/r⁴ − 2.
    ASSERT_EQ(m.materials.size(), 1u);
    const Material& paint = m.materials[0];
    EXPECT_EQ(paint.name, "Paint");
    EXPECT_TRUE(Near(paint.kd, Color(0.2f, 0.4f, 0.6f)));
    EXPECT_TRUE(Near(paint.ks, Color(0.02f)));
    EXPECT_NEAR(paint.phong, 30.0f, 1e-3f);
    EXPECT_TRUE(paint.mirror.IsBlack());

    MeshLoadOptions options;
    options.excludeNames = {"*B"};
    const LoadedMesh a = LoadMeshFile(path, options);
    EXPECT_EQ(a.mesh.TriangleCount(), 1u);
    EXPECT_EQ(a.meshesExcluded, 1u);
    EXPECT_TRUE(HasTriangle(a.mesh, {Vec3(2, 0, 0), Vec3(4, 0, 0), Vec3(2, 2, 0)}));

    options.excludeNames = {"Root"};  // a node excludes its whole subtree
    EXPECT_EQ(LoadMeshFile(path, options).meshesExcluded, 2u);
    options.excludeNames = {"Tri"};  // mesh names match too
    EXPECT_EQ(LoadMeshFile(path, options).meshesExcluded, 2u);
    options.excludeNames = {};
    options.excludeMaterials = {"Pai?t"};
    EXPECT_EQ(LoadMeshFile(path, options).meshesExcluded, 2u);
}

TEST(MeshLoader, ErrorsNameTheFile) {
    const std::string folder = TempFolder();
    EXPECT_EQ(LoadError(folder + "/missing.obj"), folder + "/missing.obj: no such file");
    EXPECT_EQ(LoadError(folder), folder + ": is a directory, not a mesh file");
    EXPECT_EQ(LoadError("/dev/null"), "/dev/null: is not a regular file");
    WriteFile(folder, "empty.obj", "");
    EXPECT_EQ(LoadError(folder + "/empty.obj"), folder + "/empty.obj: the file is empty");
    WriteFile(folder, "lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n");
    EXPECT_EQ(LoadError(folder + "/lines.obj"),
              folder + "/lines.obj: no triangles (only points/lines)");
    WriteFile(folder, "nan.obj", "v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n");
    EXPECT_EQ(
        LoadError(folder + "/nan.obj"),
        folder +
            "/nan.obj: vertex 2 of mesh \"defaultobject\" has a non-finite coordinate (0, nan, 0)");
    WriteFile(folder, "garbage.gltf",
              "{\"asset\": {\"version\": \"2.0\"}, \"buffers\": [{\"byteLength\": 8");
    const std::string garbage = LoadError(folder + "/garbage.gltf");
    EXPECT_EQ(garbage.rfind(folder + "/garbage.gltf: ", 0), 0u) << garbage;
    // A truncated binary PLY: the header promises more than the file holds.
    WriteFile(folder, "short.ply",
              "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty "
              "float y\n"
              "property float z\nelement face 1\nproperty list uchar int "
              "vertex_indices\nend_header\n\x01\x02");
    const std::string truncated = LoadError(folder + "/short.ply");
    EXPECT_EQ(truncated.rfind(folder + "/short.ply: ", 0), 0u) << truncated;
    EXPECT_EQ(truncated.find("<no error>"), std::string::npos);
}

TEST(MeshLoader, TruncatedFilesThrowOnlyMeshFileErrors) {
    // Every prefix of a few files: each loads or throws MeshFileError naming the file.
    const std::string folder = TempFolder();
    std::ifstream in(DataDir + "/two_boxes.obj");
    const std::string obj((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string gltf = TinyGltf();
    for (const auto& [name, text] :
         {std::pair<std::string, std::string>{"cut.obj", obj}, {"cut.gltf", gltf}}) {
        for (size_t n = 0; n < text.size(); n += 7) {
            const std::string path = WriteFile(folder, name, text.substr(0, n));
            try {
                LoadMeshFile(path);
            } catch (const MeshFileError& e) {
                EXPECT_EQ(std::string(e.what()).rfind(path + ": ", 0), 0u) << e.what();
            }
        }
    }
}

TEST(MeshLoader, Glob) {
    EXPECT_TRUE(GlobMatch("*", ""));
    EXPECT_TRUE(GlobMatch("*", "anything"));
    EXPECT_TRUE(GlobMatch("Collision*", "Collision"));
    EXPECT_TRUE(GlobMatch("Collision*", "CollisionHull"));
    EXPECT_FALSE(GlobMatch("Collision*", "collisionHull")) << "case-sensitive";
    EXPECT_FALSE(GlobMatch("Collision*", "MyCollision"));
    EXPECT_TRUE(GlobMatch("*Mat", "SkyBoxMat"));
    EXPECT_TRUE(GlobMatch("a?c", "abc"));
    EXPECT_FALSE(GlobMatch("a?c", "ac"));
    EXPECT_TRUE(GlobMatch("*a*b*c*", "xxaxxbxxcxx"));
    EXPECT_FALSE(GlobMatch("*a*b*c*", "xxcxxbxxaxx"));
    EXPECT_TRUE(GlobMatch("a**b", "ab"));
    EXPECT_FALSE(GlobMatch("", "a"));
    EXPECT_TRUE(GlobMatch("", ""));
}

}  // namespace
}  // namespace mesh_loader_test
}  // namespace lm

namespace lm {
namespace mesh_loader_test {
namespace {

/// COLLADA: a triangle geometry placed by `instances` nodes, each nested `depth` levels deep.
std::string ColladaInstances(int instances, int depth) {
    std::string s =
        "<?xml version=\"1.0\"?>\n<COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" "
        "version=\"1.4.1\"><library_geometries><geometry id=\"g\"><mesh><source id=\"p\">"
        "<float_array id=\"pa\" count=\"9\">0 0 0 1 0 0 0 1 0</float_array><technique_common>"
        "<accessor source=\"#pa\" count=\"3\" stride=\"3\"><param name=\"X\" type=\"float\"/>"
        "<param name=\"Y\" type=\"float\"/><param name=\"Z\" type=\"float\"/></accessor>"
        "</technique_common></source><vertices id=\"v\"><input semantic=\"POSITION\" "
        "source=\"#p\"/></vertices><triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" "
        "offset=\"0\"/><p>0 1 2</p></triangles></mesh></geometry></library_geometries>"
        "<library_visual_scenes><visual_scene id=\"s\">";
    for (int i = 0; i < instances; ++i) {
        for (int d = 0; d < depth; ++d) s += "<node>";
        s += "<instance_geometry url=\"#g\"/>";
        for (int d = 0; d < depth; ++d) s += "</node>";
    }
    return s + "</visual_scene></library_visual_scenes><scene><instance_visual_scene url=\"#s\"/>"
               "</scene></COLLADA>\n";
}

std::string BudgetError(const std::string& path, const ImportBudget& budget) {
    try {
        ImportMeshInProcess(path, {}, budget);
    } catch (const MeshFileError& e) {
        return e.Reason();
    }
    return "<no error>";
}

// The walk checks its budgets while it expands instances, and says which.
TEST(MeshLoader, ImportBudgetsAreCheckedWhileInstancesAreExpanded) {
    const std::string folder = TempFolder();
    const std::string path = WriteFile(folder, "many.dae", ColladaInstances(50, 3));
    ImportBudget roomy = ImportBudget::ForThisMachine();
    EXPECT_EQ(ImportMeshInProcess(path, {}, roomy).mesh.TriangleCount(), 50u);

    ImportBudget b = roomy;
    b.instances = 20;
    EXPECT_EQ(BudgetError(path, b),
              "expanding its instances places more than 20 meshes (the importer's budget)");
    b = roomy;
    b.triangles = 10;
    b.memory = 1280;
    EXPECT_EQ(BudgetError(path, b),
              "expanding its instances gives more than 10 triangles, the budget for 1.2 KiB of "
              "memory (128 B per triangle; LIGHTMESH_MEMORY_LIMIT)");
    b = roomy;
    b.nodes = 100;
    EXPECT_EQ(BudgetError(path, b),
              "the node hierarchy has more than 100 node instances (the importer's budget)");
    b = roomy;
    b.depth = 3;
    EXPECT_EQ(BudgetError(path, b), "the node hierarchy is more than 3 levels deep (the limit)");
    // The child process gives the same errors as the walk in this process.
    EXPECT_EQ(LoadMeshFile(path).mesh.TriangleCount(), 50u);
}

// The child process returns everything the walk produced, byte for byte.
TEST(MeshLoader, ChildProcessImportEqualsInProcessImport) {
    const std::string folder = TempFolder();
    WriteFile(folder, "m.mtl", "newmtl red\nKd 0.8 0.1 0.1\nKs 0.2 0.2 0.2\nNs 40\n");
    const std::string path = WriteFile(
        folder, "m.obj",
        "mtllib m.mtl\no a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nusemtl red\n"
        "f 1//1 2//1 3//1\nf 1//1 3//1 4//1\no hidden\nv 5 5 5\nv 6 5 5\nv 5 6 5\nf 5 6 7\n");
    MeshLoadOptions options;
    options.excludeNames = {"hid*", "nothing"};
    const LoadedMesh child = LoadMeshFile(path, options);
    const LoadedMesh local = ImportMeshInProcess(path, options, ImportBudget::ForThisMachine());
    EXPECT_EQ(child.mesh.positions.size(), local.mesh.positions.size());
    EXPECT_TRUE(child.mesh.positions == local.mesh.positions);
    EXPECT_TRUE(child.mesh.normals == local.mesh.normals);
    EXPECT_TRUE(child.mesh.triangles == local.mesh.triangles);
    EXPECT_TRUE(child.mesh.materialIds == local.mesh.materialIds);
    ASSERT_EQ(child.materials.size(), local.materials.size());
    for (size_t i = 0; i < child.materials.size(); ++i) {
        EXPECT_EQ(child.materials[i].name, local.materials[i].name);
        EXPECT_EQ(child.materials[i].phong, local.materials[i].phong);
        EXPECT_EQ(child.materials[i].kd.r, local.materials[i].kd.r);
    }
    EXPECT_EQ(child.meshesExcluded, 1u);
    EXPECT_EQ(child.meshesPlaced, local.meshesPlaced);
    EXPECT_EQ(child.excludeNamesMatched, (std::vector<bool>{true, false}));
    EXPECT_EQ(child.warnings, local.warnings);
}

// The import deadline is 60 s + 2 s per MB but at most 10 minutes (a 20 GB file would
// otherwise have 11 hours), LIGHTMESH_IMPORT_TIMEOUT sets any other; a file of zeros is
// refused before the importer reads it, and an OBJ whose `o` objects Assimp would look up
// for longer than the deadline is refused with the estimate.
TEST(MeshLoader, ImportDeadlineAndEarlyRefusals) {
    const std::string folder = TempFolder();
    const std::string big = folder + "/big.obj";
    { std::ofstream(big, std::ios::binary) << "v 0 0 0\n"; }
    fs::resize_file(big, uint64_t(20) << 30);  // sparse: 20 GB of (mostly) zeros
    unsetenv("LIGHTMESH_IMPORT_TIMEOUT");
    EXPECT_EQ(mesh_import::ImportTimeoutSeconds(big), mesh_import::kMaxDefaultImportSeconds);
    EXPECT_EQ(mesh_import::kMaxDefaultImportSeconds, 600);
    EXPECT_NEAR(mesh_import::ImportTimeoutSeconds(WriteFile(folder, "small.obj", std::string(5'000'000, '#'))), 70.0, 0.01);
    setenv("LIGHTMESH_IMPORT_TIMEOUT", "3600", 1);
    EXPECT_EQ(mesh_import::ImportTimeoutSeconds(big), 3600);
    unsetenv("LIGHTMESH_IMPORT_TIMEOUT");
    fs::remove(big);

    const std::string zeros = folder + "/zeros.ply";
    { std::ofstream(zeros, std::ios::binary); }
    fs::resize_file(zeros, uint64_t(1) << 30);
    try {
        LoadMeshFile(zeros);
        ADD_FAILURE() << "no error";
    } catch (const MeshFileError& e) {
        EXPECT_EQ(e.Reason(), "its first 4,096 bytes are all zero (NUL): not a mesh file (a zeroed or sparse file?)");
    }
    fs::remove(zeros);
    // A binary STL may start with an 80-byte header of zeros: it is read.
    std::string stl(80, '\0');
    const uint32_t one = 1;
    stl.append(reinterpret_cast<const char*>(&one), 4);
    const float tri[12] = {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0};
    stl.append(reinterpret_cast<const char*>(tri), sizeof tri);
    stl.append(2, '\0');
    EXPECT_EQ(LoadMeshFile(WriteFile(folder, "zero-header.stl", stl)).mesh.TriangleCount(), 1u);
}

using lm::testing::kSanitizerSlowdown;

// OBJ files are read by lightmesh's parser (MTL by tinyobjloader), laid out as Assimp's
// reader lays them out. A 12 MB file of 200,000 one-triangle objects, which takes Assimp's
// reader minutes (it looks each `o` up among all before it), loads in well under 2 s, in
// the child process as always.
TEST(ObjReader, TwoHundredThousandObjectsLoadAtDiskSpeed) {
    const std::string folder = TempFolder();
    std::string obj;
    obj.reserve(12 << 20);
    for (int i = 0; i < 200000; ++i) {
        const std::string x = std::to_string(i % 1000), z = std::to_string(i / 1000);
        obj += "o t" + std::to_string(i) + "\nv " + x + " 0 " + z + "\nv " + x + ".5 0 " + z + "\nv " + x + " 1 " + z +
               "\nf -3 -2 -1\n";
    }
    const std::string path = WriteFile(folder, "objects.obj", obj);
    EXPECT_GT(obj.size(), 11000000u);
    const auto start = std::chrono::steady_clock::now();
    const LoadedMesh m = LoadMeshFile(path);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_EQ(m.mesh.TriangleCount(), 200000u);
    EXPECT_LT(seconds, 2.0 * kSanitizerSlowdown);  // about 0.45 s here
    // With an exclude pattern the objects stay apart, and are excluded by name.
    MeshLoadOptions options;
    options.excludeNames = {"t1?"};
    const LoadedMesh kept = LoadMeshFile(path, options);
    EXPECT_EQ(kept.meshesExcluded, 10u);
    EXPECT_EQ(kept.mesh.TriangleCount(), 199990u);
}

// The same meshes as Assimp's OBJ reader gives (LIGHTMESH_OBJ_READER=assimp), triangle by
// triangle, with objects, groups, materials switching inside an object, polygons, relative
// indices, normals and texture coordinates, and an unknown material. (Faces before any
// usemtl are left out: Assimp's reader gives them the last material of the file, lightmesh's
// its default material.)
TEST(ObjReader, GivesWhatAssimpsReaderGives) {
    const std::string folder = TempFolder();
    WriteFile(folder, "m.mtl",
              "newmtl red\nKd 0.8 0.1 0.1\nKs 0.2 0.2 0.2\nNs 40\n\nnewmtl plain\nd 1\n"
              "newmtl leaf\nKd 0.1 0.6 0.1\nmap_Kd -clamp on leaf.png\nmap_d leaf_alpha.png\n");
    const std::string path = WriteFile(
        folder, "mix.obj",
        "mtllib m.mtl\n# a comment\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nvn 0 1 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
        "o first\nusemtl red\nf 1//1 2//1 3//1\nusemtl plain\nf 2 4 3 5\nusemtl red\n"
        "f -5/-4 -4/-3 -3/-2\ng grp one\nusemtl leaf\nf 1/1/2 2/2/2 3/3/2 4/4/2\n"
        "o second\nusemtl nosuch\nf 3 4 5\ns 1\nl 1 2\n");
    for (const bool exclude : {false, true}) {
        MeshLoadOptions options;
        if (exclude) options.excludeNames = {"nothing"};  // keeps the objects apart
        const LoadedMesh ours = LoadMeshFile(path, options);
        setenv("LIGHTMESH_OBJ_READER", "assimp", 1);
        const LoadedMesh theirs = LoadMeshFile(path, options);
        unsetenv("LIGHTMESH_OBJ_READER");
        ASSERT_EQ(ours.mesh.TriangleCount(), theirs.mesh.TriangleCount());
        EXPECT_EQ(ours.mesh.TriangleCount(), 1u + 2u + 1u + 2u + 1u);
        EXPECT_EQ(ours.mesh.normals.empty(), theirs.mesh.normals.empty());
        EXPECT_EQ(ours.mesh.uvs.empty(), theirs.mesh.uvs.empty());
        for (uint32_t t = 0; t < ours.mesh.TriangleCount(); ++t) {
            for (int k = 0; k < 3; ++k) {
                const Vec3 a = ours.mesh.Vertex(t, k), b = theirs.mesh.Vertex(t, k);
                EXPECT_TRUE(a.x == b.x && a.y == b.y && a.z == b.z) << t << " " << k;
            }
            const Material &ma = ours.materials[ours.mesh.materialIds[t]],
                           &mb = theirs.materials[theirs.mesh.materialIds[t]];
            EXPECT_EQ(ma.name, mb.name) << t;
            EXPECT_EQ(ma.kd, mb.kd) << t;
            EXPECT_EQ(ma.ks, mb.ks) << t;
            EXPECT_EQ(ma.phong, mb.phong) << t;
            EXPECT_EQ(ma.texture >= 0, mb.texture >= 0) << t;
            EXPECT_EQ(ma.alphaTexture >= 0, mb.alphaTexture >= 0) << t;
            EXPECT_EQ(ma.wrapU, mb.wrapU) << t;
        }
        ASSERT_EQ(ours.textures.size(), theirs.textures.size());
        for (size_t i = 0; i < ours.textures.size(); ++i) EXPECT_EQ(ours.textures[i].file, theirs.textures[i].file);
    }
    // The object and group names are what excludes match, as with Assimp's reader.
    for (const char* name : {"first", "grp one", "second"}) {
        MeshLoadOptions options;
        options.excludeNames = {name};
        const size_t ours = LoadMeshFile(path, options).mesh.TriangleCount();
        setenv("LIGHTMESH_OBJ_READER", "assimp", 1);
        const size_t theirs = LoadMeshFile(path, options).mesh.TriangleCount();
        unsetenv("LIGHTMESH_OBJ_READER");
        EXPECT_EQ(ours, theirs) << name;
        EXPECT_LT(ours, 7u) << name;
    }
}

// A malformed number or index is an error naming its line (tinyobjloader's own parser
// reads a malformed number as 0; Assimp's said "vertex index out of range").
TEST(ObjReader, MalformedRecordsNameTheirLine) {
    const std::string folder = TempFolder();
    auto reason = [&](const std::string& text) {
        try {
            LoadMeshFile(WriteFile(folder, "bad.obj", text));
        } catch (const MeshFileError& e) {
            return e.Reason();
        }
        return std::string("<no error>");
    };
    EXPECT_EQ(reason("v 0 0 0\nv 1 0 x\nv 0 1 0\nf 1 2 3\n"),
              "OBJ: line 2: expected a number in a `v` record, got \"x\"");
    EXPECT_EQ(reason("v 0 0 0\nv 1 0\n"), "OBJ: line 2: a `v` record needs 3 numbers, got 2");
    EXPECT_EQ(reason("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n"),
              "OBJ: line 4: expected a vertex index (1, 2, ... or -1, -2, ...) in a face, got \"0\"");
    EXPECT_EQ(reason("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 -4 3\n"),
              "OBJ: line 4: face corner \"-4\" refers to vertex 0, but 3 vertices are defined before it");
    EXPECT_EQ(reason("v 0 0 0\nv 1 0 \\\n 0\nv 0 1 0\nf 1 2 3 \\\n\nf 1 2 9\n"),
              "OBJ: line 7: face corner \"9\" refers to vertex 9, but 3 vertices are defined before it");
}

// An image's data: URI without base64's padding is read (Assimp 5.2 refuses the whole
// file), without a warning.
TEST(MeshLoader, AnUnpaddedDataUriIsRead) {
    const std::string folder = TempFolder();
    std::ifstream in(std::string(LIGHTMESH_TEST_DATA) + "/textures/checker_mask.gltf");
    std::string g((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t at = g.find("ASUVORK5CYII=");
    ASSERT_NE(at, std::string::npos);
    g.erase(at + 12, 1);  // the one '='
    const LoadedMesh m = LoadMeshFile(WriteFile(folder, "unpadded.gltf", g));
    EXPECT_EQ(m.textures.size(), 1u);
    EXPECT_TRUE(m.warnings.empty()) << m.warnings[0];
}

// An AC3D object with several texture layers (TORCS's .acc: the base image, then
// placeholders and skid layers, a coordinate pair per layer on each refs line) takes its
// first layer, with the first pair: its image and its cut-out (Assimp 5.2 kept the last,
// an unquoted placeholder read as "ERROR", and the leaf cards became solid slabs).
TEST(MeshLoader, Ac3dTakesAnObjectsFirstTextureLayer) {
    const std::string folder = TempFolder();
    fs::copy_file(std::string(LIGHTMESH_TEST_DATA) + "/textures/texels.png", folder + "/leaf.png");
    const std::string ac =
        "AC3Db\n"
        "MATERIAL \"leaf\" rgb 1 1 1  amb 0.2 0.2 0.2  emis 0 0 0  spec 0 0 0  shi 0  trans 0\n"
        "OBJECT world\nkids 2\n"
        "OBJECT poly\nname \"tree\"\n"
        "texture \"leaf.png\" base\ntexture empty_texture_no_mapping tiled\n"
        "texture empty_texture_no_mapping skids\n"
        "numvert 4\n-1 0 0\n1 0 0\n1 2 0\n-1 2 0\n"
        "numsurf 1\nSURF 0x10\nmat 0\nrefs 4\n"
        "0 0 0 0.5 0.5 0.5 0.5\n1 1 0 0.5 0.5 0.5 0.5\n2 1 1 0.5 0.5 0.5 0.5\n3 0 1 0.5 0.5 0.5 0.5\n"
        "kids 0\n"
        "OBJECT poly\nname \"bare\"\nnumvert 3\n0 0 1\n1 0 1\n0 1 1\nnumsurf 1\nSURF 0x10\nmat 0\nrefs 3\n"
        "0 0 0\n1 0 0\n2 0 0\nkids 0\n";
    const std::string path = WriteFile(folder, "tree.acc", ac);
    size_t dropped = 0;
    const std::string repaired = mesh_import::RepairAc3dTextureLayers(path, &dropped);
    EXPECT_EQ(dropped, 2u);
    EXPECT_EQ(repaired.find("empty_texture_no_mapping"), std::string::npos);
    EXPECT_NE(repaired.find("texture \"leaf.png\" base"), std::string::npos);
    EXPECT_EQ(mesh_import::RepairAc3dTextureLayers(WriteFile(folder, "one.ac", "AC3Db\nOBJECT world\nkids 0\n")), "");
    const LoadedMesh m = LoadMeshFile(path);
    for (const std::string& w : m.warnings) EXPECT_EQ(w.find("ERROR"), std::string::npos) << w;
    ASSERT_EQ(m.textures.size(), 1u);
    EXPECT_EQ(fs::path(m.textures[0].file).filename(), "leaf.png");
    ASSERT_EQ(m.mesh.TriangleCount(), 3u);
    int textured = 0;
    for (size_t t = 0; t < m.mesh.TriangleCount(); ++t) {
        const Material& mat = m.materials[m.mesh.MaterialOf(static_cast<uint32_t>(t))];
        if (mat.texture < 0) continue;
        ++textured;
        EXPECT_EQ(mat.alphaTexture, mat.texture);  // its alpha is the cut-out
        EXPECT_EQ(mat.alphaSource, Material::AlphaSource::AlphaIfAny);
        // The first layer's coordinates: a corner of the card, not the other layers' 0.5.
        TexCoord uv[3];
        ASSERT_TRUE(m.mesh.UvsOf(static_cast<uint32_t>(t), uv));
        for (const TexCoord& c : uv) {
            EXPECT_TRUE(c.u == 0 || c.u == 1) << c.u;
            EXPECT_TRUE(c.v == 0 || c.v == 1) << c.v;
        }
    }
    EXPECT_EQ(textured, 2);
}

}  // namespace
}  // namespace mesh_loader_test
}  // namespace lm
