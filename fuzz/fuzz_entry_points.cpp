// fuzz_entry_points.cpp -- see fuzz_entry_points.h.
#include "fuzz_entry_points.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/render/render_job.h"
#include "lightmesh/scene/mesh_loader.h"
#include "lightmesh/scene/scene_file.h"
#include "lightmesh/scene/shapes.h"
#include "lightmesh/shadow/shadow.h"
#include "lightmesh/shadow/sphere_templates.h"
#include "lightmesh/texture/texture.h"
#include "lightmesh/texture/texture_cache.h"
#include "lightmesh/util/error.h"

namespace lm::fuzz {
namespace {

namespace fs = std::filesystem;

/// A broken invariant: a bug the fuzzer must report, whatever the build flags.
#define FUZZ_CHECK(cond)                                                                  \
    do {                                                                                  \
        if (!(cond)) {                                                                    \
            std::fprintf(stderr, "%s:%d: fuzz invariant failed: %s\n", __FILE__, __LINE__, \
                         #cond);                                                          \
            std::abort();                                                                 \
        }                                                                                 \
    } while (0)

/// LIGHTMESH_FUZZ_VERBOSE=1 prints what became of each input (to triage a crash).
bool Verbose() {
    static const bool verbose = std::getenv("LIGHTMESH_FUZZ_VERBOSE") != nullptr;
    return verbose;
}

// ---------------------------------------------------------------------------------------
// The scene loader

/// One named part of a fake mesh file, for the exclude patterns.
struct Part {
    std::string name, material;
    TriangleMesh mesh;
};

/// The in-memory stand-ins for mesh files: the loader's own code is fuzzed, not Assimp's.
std::vector<Part> FakeParts(const std::string& file, const std::string& path) {
    std::vector<Part> parts;
    auto add = [&](std::string name, std::string material) -> TriangleMesh& {
        parts.push_back({std::move(name), std::move(material), {}});
        return parts.back().mesh;
    };
    if (file == "box.obj") {
        ShapeBuilder(&add("Box", "wood")).Box({0, 0, 0}, {1, 1, 1}, 0);
        ShapeBuilder(&add("Collision", "Hidden")).Box({2, 0, 0}, {3, 1, 1}, 0);
    } else if (file == "sphere.obj") {
        TriangleMesh& m = add("Sphere", "");
        ShapeBuilder(&m).Sphere({0, 1, 0}, 1, 6, 8, 0);
        m.normals.clear();
        for (const Vec3& p : m.positions) m.normals.push_back(Normalize(p - Vec3(0, 1, 0)));
    } else if (file == "quad.obj") {
        TriangleMesh& m = add("Quad", "floor");
        m.positions = {{-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1}};
        m.triangles = {{0, 2, 1}, {0, 3, 2}};
        m.materialIds = {0, 0};
    } else if (file == "dirty.obj") {
        TriangleMesh& m = add("Dirty", "wood");
        ShapeBuilder(&m).Box({0, 0, 0}, {1, 2, 1}, 0);
        m.positions.push_back({5, 5, 5});
        const uint32_t last = static_cast<uint32_t>(m.positions.size() - 1);
        m.triangles.push_back(m.triangles[0]);           // a duplicate
        m.triangles.push_back({last, last, 0});           // degenerate
        m.triangles.push_back({m.triangles[1][2], m.triangles[1][0], m.triangles[1][1]});
        m.materialIds.resize(m.triangles.size(), 0);
    } else if (file == "flat.obj") {
        TriangleMesh& m = add("Flat", "");
        m.positions = {{1, 1, 1}, {1, 1, 1}, {1, 1, 1}};
        m.triangles = {{0, 1, 2}};
        m.materialIds = {0};
    } else if (file == "empty.obj") {
        throw MeshFileError(path, "the file is empty", true);
    } else if (file == "nan.obj") {
        throw MeshFileError(path, "vertex 1 of mesh \"\" has a non-finite coordinate (nan, 0, 0)",
                            false);
    } else {
        throw MeshFileError(path, "no such file", true);
    }
    return parts;
}

/// LoadMeshFile's contract, on the fake files.
LoadedMesh FakeLoadMesh(const std::string& path, const MeshLoadOptions& options) {
    LoadedMesh out;
    out.excludeMaterialsMatched.assign(options.excludeMaterials.size(), false);
    out.excludeNamesMatched.assign(options.excludeNames.size(), false);
    auto matches = [](const std::vector<std::string>& patterns, const std::string& text,
                      std::vector<bool>* matched) {
        bool any = false;
        for (size_t i = 0; i < patterns.size(); ++i)
            if (GlobMatch(patterns[i], text)) any = (*matched)[i] = true;
        return any;
    };
    for (Part& part : FakeParts(fs::path(path).filename().string(), path)) {
        const bool byName = matches(options.excludeNames, part.name, &out.excludeNamesMatched);
        const bool byMaterial =
            matches(options.excludeMaterials, part.material, &out.excludeMaterialsMatched);
        if (byName || byMaterial) {
            ++out.meshesExcluded;
            continue;
        }
        Material m;
        if (!part.material.empty()) m.name = part.material;
        out.mesh.Append(part.mesh, static_cast<uint32_t>(out.materials.size()));
        out.materials.push_back(m);
        ++out.meshesPlaced;
    }
    if (out.mesh.TriangleCount() == 0 && out.meshesExcluded == 0)
        throw MeshFileError(path, "no triangles", false);
    return out;
}

/// A private folder for the template cache, removed at exit.
struct TemplateFolder {
    std::string path;
    TemplateFolder() {
        path = (fs::temp_directory_path() / ("lightmesh-fuzz-" + std::to_string(getpid()))).string();
        std::error_code ec;
        fs::create_directories(path, ec);
    }
    ~TemplateFolder() {
        std::error_code ec;
        fs::remove_all(path, ec);
    }
};

void CheckLoadedScene(const Scene& scene) {
    const TriangleMesh& mesh = scene.mesh;
    FUZZ_CHECK(mesh.TriangleCount() > 0);
    FUZZ_CHECK(mesh.materialIds.size() == mesh.triangles.size());
    FUZZ_CHECK(mesh.normals.empty() || mesh.normals.size() == mesh.positions.size());
    for (const auto& t : mesh.triangles)
        for (uint32_t v : t) FUZZ_CHECK(v < mesh.positions.size());
    for (uint32_t id : mesh.materialIds) FUZZ_CHECK(id < scene.materials.size());
    for (const Vec3& p : mesh.positions) FUZZ_CHECK(IsFinite(p));
    const Bounds3 b = mesh.Bounds();
    FUZZ_CHECK(IsFinite(b.Diagonal()) && b.MaxExtent() > 0);
    FUZZ_CHECK(!scene.lights.empty());
    for (const PointLight& l : scene.lights) FUZZ_CHECK(IsFinite(l.position));
    FUZZ_CHECK(scene.render.width >= 1 && scene.render.height >= 1);
}

// ---------------------------------------------------------------------------------------
// Template files

uint64_t Fnv1a(const unsigned char* data, size_t n) {
    uint64_t h = 0xcbf29ce484222325ull;
    for (size_t i = 0; i < n; ++i) h = (h ^ data[i]) * 0x100000001b3ull;
    return h;
}

}  // namespace

int FuzzSceneFile(const uint8_t* data, size_t size) {
    static const TemplateFolder templateFolder;
    SceneLoadOptions options;
    options.text = std::string(reinterpret_cast<const char*>(data), size);
    options.loadMesh = FakeLoadMesh;
    options.strict = size > 0 && data[size - 1] == '\n';  // both modes, cheaply
    std::vector<std::string> warnings;
    Scene scene;
    try {
        scene = LoadScene("fuzz/scene.json", options, &warnings);
    } catch (const Error& e) {
        if (Verbose()) std::fprintf(stderr, "fuzz_scene_file: %s\n", e.what());
        return 0;  // bad input, reported as such
    }
    CheckLoadedScene(scene);
    if (Verbose())
        std::fprintf(stderr, "fuzz_scene_file: loaded, %zu triangles, shadows %s\n",
                     scene.mesh.TriangleCount(), scene.render.shadows.c_str());

    // Render a few pixels with the scene's settings, bounded so one input stays fast.
    RenderOptions ro = scene.render;
    ro.width = std::min(ro.width, 6);
    ro.height = std::min(ro.height, 4);
    ro.aa = std::min(ro.aa, 2);
    ro.maxDepth = std::min(ro.maxDepth, 3);
    ro.accelOptions.gridResolution = std::min(ro.accelOptions.gridResolution, 16);
    ro.lightMesh.cc = std::min(ro.lightMesh.cc, 12);
    ro.lightMesh.ki = std::clamp(std::round(ro.lightMesh.ki * 4) / 4, 0.25f, 2.5f);
    ro.lightMesh.ns = std::min(ro.lightMesh.ns, 3);
    ro.lightMesh.templateDir = templateFolder.path;
    try {
        const RenderResult result = RenderJob(scene, ro).Render();
        FUZZ_CHECK(result.image.width == ro.width && result.image.height == ro.height);
        FUZZ_CHECK(result.image.pixels.size() == static_cast<size_t>(ro.width) * ro.height);
    } catch (const Error& e) {
        // e.g. an unknown light-mesh variant, or more lights than the renderer takes
        if (Verbose()) std::fprintf(stderr, "fuzz_scene_file: render: %s\n", e.what());
    }
    return 0;
}

int FuzzMeshImport(const uint8_t* data, size_t size, bool isolated) {
    static const TemplateFolder folder;  // a private folder, removed at exit
    static const char* const kExtensions[] = {".obj", ".ply", ".off", ".gltf", ".glb",
                                              ".dae", ".ac",  ".stl", ".nff",  ".3ds"};
    if (size < 1) return 0;
    const std::string path = folder.path + "/mesh" + kExtensions[data[0] % 10];
    {
        FILE* f = std::fopen(path.c_str(), "wb");
        if (!f) return 0;
        std::fwrite(data + 1, 1, size - 1, f);
        std::fclose(f);
    }
    // Small enough that one input stays fast and within the fuzzer's memory limit.
    ImportBudget budget;
    budget.memory = 256u << 20;
    budget.triangles = 200000;
    budget.instances = 10000;
    budget.nodes = 10000;
    budget.depth = 128;
    LoadedMesh m;
    try {
        m = isolated ? LoadMeshFile(path) : ImportMeshInProcess(path, {}, budget);
    } catch (const MeshFileError& e) {
        if (Verbose()) std::fprintf(stderr, "fuzz_mesh_import: %s\n", e.what());
        return 0;
    }
    const TriangleMesh& mesh = m.mesh;
    FUZZ_CHECK(mesh.materialIds.size() == mesh.triangles.size());
    FUZZ_CHECK(mesh.normals.empty() || mesh.normals.size() == mesh.positions.size());
    for (const auto& t : mesh.triangles)
        for (uint32_t v : t) FUZZ_CHECK(v < mesh.positions.size());
    for (uint32_t id : mesh.materialIds) FUZZ_CHECK(id < m.materials.size());
    for (const Vec3& p : mesh.positions) FUZZ_CHECK(IsFinite(p));
    FUZZ_CHECK(isolated || mesh.TriangleCount() <= budget.triangles);
    FUZZ_CHECK(mesh.TriangleCount() > 0 || m.meshesExcluded > 0);
    if (Verbose())
        std::fprintf(stderr, "fuzz_mesh_import: %zu triangles\n", mesh.TriangleCount());
    return 0;
}

int FuzzTemplateFile(const uint8_t* data, size_t size) {
    if (size < 1) return 0;
    const bool fixChecksum = data[0] & 1;
    std::string bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
    // The header: magic[8], version, ns, kI, sub-positions, entries, reserved (4 bytes each).
    int ns = 2;
    float ki = 1.5f;
    if (bytes.size() >= 20) {
        int32_t headerNs;
        float headerKi;
        std::memcpy(&headerNs, bytes.data() + 12, 4);
        std::memcpy(&headerKi, bytes.data() + 16, 4);
        if (headerNs >= 1 && headerNs <= 64) ns = headerNs;
        if (headerKi > 0 && headerKi <= 16) ki = headerKi;
    }
    if (fixChecksum && bytes.size() >= 8) {
        const uint64_t sum =
            Fnv1a(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size() - 8);
        std::memcpy(bytes.data() + bytes.size() - 8, &sum, 8);
    }
    SphereTemplates t;
    try {
        t = ParseSphereTemplates(bytes, "fuzz.lmt", ns, ki);
    } catch (const Error& e) {
        if (Verbose()) std::fprintf(stderr, "fuzz_template_file: %s\n", e.what());
        return 0;
    }
    // What the light mesh relies on when it walks a template.
    FUZZ_CHECK(t.ns == ns && t.ki == ki);
    const size_t subPositions = static_cast<size_t>(t.SubPositionCount());
    FUZZ_CHECK(t.begin.size() == subPositions + 1 && t.boundaryCount.size() == subPositions);
    FUZZ_CHECK(t.begin.front() == 0 && t.begin.back() == t.offsets.size());
    const int reach = static_cast<int>(std::ceil(ki)) + 1;
    int64_t sum = 0;
    for (size_t s = 0; s < subPositions; ++s) {
        FUZZ_CHECK(t.begin[s] <= t.begin[s + 1]);
        FUZZ_CHECK(t.boundaryCount[s] <= t.begin[s + 1] - t.begin[s]);
        for (uint32_t e = t.begin[s]; e < t.begin[s + 1]; ++e)
            for (int8_t v : t.offsets[e]) {
                FUZZ_CHECK(v >= -reach && v <= reach);
                sum += v;
            }
    }
    return sum == INT64_MIN;  // keeps the walk from being optimised away; always 0
}

int FuzzImageDecode(const uint8_t* data, size_t size, bool isolated) {
    static const TemplateFolder folder;  // a private folder, removed at exit
    if (size < 1) return 0;
    const std::string bytes(reinterpret_cast<const char*>(data + 1), size - 1);
    if (isolated) {
        TextureSource source;
        source.name = "fuzz";
        if (data[0] % 2 == 0) {
            source.bytes = bytes;
        } else {
            source.file = folder.path + "/image.exr";
            FILE* f = std::fopen(source.file.c_str(), "wb");
            if (!f) return 0;
            std::fwrite(bytes.data(), 1, bytes.size(), f);
            std::fclose(f);
        }
        std::vector<std::shared_ptr<const Texture>> textures;
        int warnings = 0;
        const int index = TextureCache().Get(source, "fuzz", &textures, [&](const std::string&) { ++warnings; });
        FUZZ_CHECK((index == 0 && textures.size() == 1 && warnings == 0) || (index == -1 && warnings == 1));
        return 0;
    }
    DecodedImage image;
    try {
        if (data[0] % 2 == 0) {
            image = DecodeImageBytes(bytes);
        } else {
            const std::string path = folder.path + "/image.exr";
            FILE* f = std::fopen(path.c_str(), "wb");
            if (!f) return 0;
            std::fwrite(bytes.data(), 1, bytes.size(), f);
            std::fclose(f);
            image = ReadImageFile(path);
        }
    } catch (const Error& e) {
        if (Verbose()) std::fprintf(stderr, "fuzz_image_decode: %s\n", e.what());
        return 0;
    }
    FUZZ_CHECK(image.Consistent());
    std::move(image).MakeTexture();
    return 0;
}

}  // namespace lm::fuzz
