// instances_test.cpp -- instancing end to end: a mesh with instances against the same mesh
// flattened (FlattenInstances keeps every id): the accessors bit for bit, the brute-force
// crossing count, the occluder hierarchy's lists, the back-ends' hits, soft shadows'
// visibility bit for bit, images of rt, soft and area, and the scene file's rule.
#include "lightmesh/geometry/instances.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/accel/occluder_bvh.h"
#include "lightmesh/geometry/cutouts.h"
#include "lightmesh/geometry/triangle.h"
#include "lightmesh/io/compare.h"
#include "lightmesh/io/image.h"
#include "lightmesh/render/render_job.h"
#include "lightmesh/render/whitted.h"
#include "lightmesh/scene/scene_file.h"
#include "lightmesh/scene/shapes.h"
#include "lightmesh/shadow/soft_shadows.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace instances_test {
namespace {

bool Same(const Vec3& a, const Vec3& b) { return std::memcmp(&a, &b, sizeof(Vec3)) == 0; }

/// A ground and a box (flat), and 40 placements of a sphere and a box: turned, scaled
/// unevenly, some mirrored.
Scene InstancedScene() {
    Scene s;
    s.name = "test:instances";
    s.materials = {{"ground", Color(0.6f), Color(0.0f), 1.0f, Color(0.0f)},
                   {"sphere", Color(0.8f, 0.5f, 0.3f), Color(0.0f), 1.0f, Color(0.0f)},
                   {"box", Color(0.3f, 0.6f, 0.8f), Color(0.0f), 1.0f, Color(0.0f)}};
    ShapeBuilder flat(&s.mesh);
    flat.Box({-12, -1, -12}, {12, 0, 12}, 0);
    flat.Box({-1, 0, -1}, {1, 3, 1}, 2);
    TriangleMesh sphere, box;
    ShapeBuilder(&sphere).Sphere({0, 0, 0}, 1.0f, 10, 16, 1);
    ShapeBuilder(&box).Box({-0.5f, 0, -0.5f}, {0.5f, 1.2f, 0.5f}, 2);
    auto inst = std::make_shared<InstancedMeshes>();
    const uint32_t ps = inst->AddPrototype(sphere), pb = inst->AddPrototype(box);
    for (int k = 0; k < 40; ++k) {
        const float x = -9.0f + 3.0f * static_cast<float>(k % 7), z = -9.0f + 3.0f * static_cast<float>(k / 7);
        const Vec3 scale(1.0f + 0.25f * static_cast<float>(k % 3), 0.7f + 0.2f * static_cast<float>(k % 4),
                         k % 5 == 2 ? -0.8f : 0.9f);  // every fifth mirrored
        const Affine t = Affine::Translate({x, 1.0f, z}) * Affine::Rotate({0.3f, 1, 0.2f}, 23.0f * static_cast<float>(k)) *
                         Affine::Scale(scale);
        inst->AddInstance(k % 3 == 1 ? pb : ps, t);
    }
    inst->HarmoniseAttributes(&s.mesh);
    s.mesh.instances = inst;
    s.lights = {{{-6, 12, 5}, Color(150.0f), Falloff::InverseSquare}, {{8, 9, -3}, Color(60.0f), Falloff::InverseSquare}};
    s.lights[0].radius = 0.8f;
    s.lights[1].radius = 0.4f;
    s.camera = Camera{{0, 13, 17}, {0, 0, 0}, {0, 1, 0}, 50.0f};
    s.render.width = 96;
    s.render.height = 72;
    return s;
}

Scene FlatCopy(const Scene& s) {
    Scene f = s;
    FlattenInstances(&f.mesh);
    return f;
}

std::vector<Ray> RandomRays(const Bounds3& box, int n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0, 1);
    auto inside = [&] {
        return Vec3(box.lo.x + u(rng) * (box.hi.x - box.lo.x), box.lo.y + u(rng) * (box.hi.y - box.lo.y),
                    box.lo.z + u(rng) * (box.hi.z - box.lo.z));
    };
    std::vector<Ray> rays;
    for (int i = 0; i < n; ++i) {
        const Vec3 o = inside() + Vec3(0, 8, 0), target = inside();
        rays.push_back(Ray{o, target - o, 0.0f, i % 2 ? 1.0f : Infinity});
    }
    return rays;
}

TEST(Instances, AccessorsReadTheFlattenedTrianglesBitForBit) {
    const Scene s = InstancedScene();
    const Scene f = FlatCopy(s);
    ASSERT_EQ(s.mesh.PrimCount(), f.mesh.TriangleCount());
    EXPECT_EQ(s.mesh.PrimCount(), s.mesh.TriangleCount() + s.mesh.instances->TriangleCount());
    for (uint32_t id = 0; id < s.mesh.PrimCount(); ++id) {
        Vec3 p[3];
        s.mesh.Corners(id, p);
        for (int k = 0; k < 3; ++k) ASSERT_TRUE(Same(p[k], f.mesh.Vertex(id, k))) << id;
        EXPECT_EQ(s.mesh.MaterialOf(id), f.mesh.materialIds[id]);
        Vec3 n[3], fn[3];
        ASSERT_EQ(s.mesh.ShadingNormals(id, n), f.mesh.ShadingNormals(id, fn));
    }
    const Bounds3 a = s.mesh.Bounds(), b = f.mesh.Bounds();
    EXPECT_TRUE(Same(a.lo, b.lo) && Same(a.hi, b.hi));
    // A mirrored placement keeps its triangles facing out, as TransformMesh does.
    const MeshInstance& mirrored = s.mesh.instances->Instances()[2];
    ASSERT_LT(mirrored.toWorld.Determinant(), 0.0f);
}

TEST(Instances, CrossingCountIsTheFlattenedOnes) {
    const Scene s = InstancedScene();
    const Scene f = FlatCopy(s);
    for (const Ray& r : RandomRays(s.mesh.Bounds(), 300, 7)) EXPECT_EQ(CountCrossings(s.mesh, r), CountCrossings(f.mesh, r));
}

TEST(Instances, FlatteningPastTheMemoryBudgetIsRefusedFirst) {
    // The light mesh, brute force and the grid flatten the instances: past half the budget
    // at the pipeline's 128 B a triangle it is one error, before anything is allocated.
    const Scene s = InstancedScene();
    const uint64_t need = (s.mesh.TriangleCount() + s.mesh.instances->TriangleCount()) * kPipelineBytesPerTriangle;
    TriangleMesh m = s.mesh;
    setenv("LIGHTMESH_MEMORY_LIMIT", std::to_string(need).c_str(), 1);  // half of it is too little
    try {
        FlattenInstances(&m);
        ADD_FAILURE() << "flattened within half of " << need << " bytes";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("instances into"), std::string::npos) << e.what();
        EXPECT_TRUE(m.instances != nullptr);  // left as it was
    }
    setenv("LIGHTMESH_MEMORY_LIMIT", std::to_string(2 * need + 4096).c_str(), 1);
    EXPECT_NO_THROW(FlattenInstances(&m));
    EXPECT_TRUE(m.instances == nullptr);
    unsetenv("LIGHTMESH_MEMORY_LIMIT");
}

TEST(Instances, OccluderHierarchyListsTheFlattenedTriangles) {
    const Scene s = InstancedScene();
    const Scene f = FlatCopy(s);
    const OccluderBvh two(s.mesh), one(f.mesh);
    EXPECT_EQ(two.PrototypeCount(), 2u);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-10, 10), r(0.05f, 1.5f);
    size_t listed = 0;
    for (int q = 0; q < 300; ++q) {
        const BallHull hull{{u(rng), 0.5f + 0.1f * std::abs(u(rng)), u(rng)}, r(rng), {u(rng), 12, u(rng)}, r(rng)};
        std::vector<uint32_t> a, b;
        EXPECT_TRUE(two.Query(hull, &a));
        EXPECT_TRUE(one.Query(hull, &b));
        std::sort(a.begin(), a.end());
        std::sort(b.begin(), b.end());
        ASSERT_EQ(a, b) << q;
        listed += a.size();
        // The limit stops both alike.
        std::vector<uint32_t> c, d;
        EXPECT_EQ(two.Query(hull, &c, b.size() / 2), one.Query(hull, &d, b.size() / 2));
    }
    EXPECT_GT(listed, 1000u);
}

TEST(Instances, BackEndsAgreeWithEmbreesInstances) {
#ifndef LIGHTMESH_HAS_EMBREE
    GTEST_SKIP() << "no Embree";
#endif
    const Scene s = InstancedScene();
    const Scene f = FlatCopy(s);
    const auto embree = CreateAccelerator("embree", s.mesh), flatEmbree = CreateAccelerator("embree", f.mesh);
    const auto grid = CreateAccelerator("grid", s.mesh), brute = CreateAccelerator("brute", s.mesh);
    int hits = 0;
    for (const Ray& r : RandomRays(s.mesh.Bounds(), 3000, 11)) {
        Hit he, hf, hg, hb;
        const bool e = embree->Intersect(r, &he), ef = flatEmbree->Intersect(r, &hf), g = grid->Intersect(r, &hg),
                   b = brute->Intersect(r, &hb);
        ASSERT_EQ(e, ef);
        ASSERT_EQ(e, b);
        ASSERT_EQ(g, b);
        EXPECT_EQ(embree->Occluded(r), e);
        EXPECT_EQ(grid->Occluded(r), b);
        if (!e) continue;
        ++hits;
        EXPECT_EQ(he.prim, hf.prim);
        EXPECT_EQ(he.prim, hb.prim);
        EXPECT_EQ(hg.prim, hb.prim);
        EXPECT_NEAR(he.t, hb.t, 1e-4f * hb.t);
        EXPECT_NEAR(he.b1, hb.b1, 1e-3f);  // a mirrored placement's (u, v) swapped back
        EXPECT_NEAR(he.b2, hb.b2, 1e-3f);
        EXPECT_EQ(hg.t, hb.t);
    }
    EXPECT_GT(hits, 1500);
    // Packets answer as single rays.
    const std::vector<Ray> rays = RandomRays(s.mesh.Bounds(), 16, 12);
    std::vector<Hit> many(rays.size());
    embree->IntersectMany(rays.data(), rays.size(), many.data());
    for (size_t i = 0; i < rays.size(); ++i) {
        Hit one;
        embree->Intersect(rays[i], &one);
        EXPECT_EQ(many[i].prim, one.prim);
        EXPECT_EQ(many[i].t, one.t);
    }
    for (const Ray& r : RandomRays(s.mesh.Bounds(), 200, 13)) EXPECT_EQ(embree->CountCrossings(r), brute->CountCrossings(r));
    // The figures say what each holds.
    bool saysInstances = false, saysCopy = false;
    for (const auto& [k, v] : embree->Figures()) saysInstances |= k == "embree instances" && v.find("40 instance") == 0;
    for (const auto& [k, v] : grid->Figures()) saysCopy |= k == "flattened copy";
    EXPECT_TRUE(saysInstances);
    EXPECT_TRUE(saysCopy);
}

TEST(Instances, SoftShadowsSeeTheFlattenedTrianglesBitForBit) {
    const Scene s = InstancedScene();
    const Scene f = FlatCopy(s);
    const auto accel = CreateAccelerator("brute", s.mesh);  // answers both (same ids)
    SoftShadowOptions o;
    o.radii = {s.lights[0].radius, s.lights[1].radius};
    o.cc = 24;
    const auto two = CreateSoftShadows(s, *accel, o), one = CreateSoftShadows(f, *accel, o);
    int shaded = 0, partial = 0;
    for (const Ray& r : RandomRays(s.mesh.Bounds(), 1500, 17)) {
        Hit hit;
        if (!accel->Intersect(r, &hit)) continue;
        const ShadingPoint sp = WhittedRenderer::MakeShadingPoint(s.mesh, r, hit);
        const uint32_t needed[2] = {0, 1};  // both lights
        float a[2], b[2];
        RenderCounters ca, cb;
        two->Visibility(sp, LightIndices(needed), a, ca);
        one->Visibility(sp, LightIndices(needed), b, cb);
        for (int l = 0; l < 2; ++l) {
            ASSERT_EQ(a[l], b[l]);
            partial += a[l] > 0 && a[l] < 1;
        }
        ++shaded;
    }
    EXPECT_GT(shaded, 800);
    EXPECT_GT(partial, 20);
}

TEST(Instances, ImagesMatchTheFlattenedScenes) {
#ifndef LIGHTMESH_HAS_EMBREE
    GTEST_SKIP() << "no Embree";
#endif
    const Scene s = InstancedScene();
    const Scene f = FlatCopy(s);
    // Embree's instance traversal moves each ray into the prototype's space, so hits differ
    // from the flattened scene's in the last bits: near-equal images, not equal bytes.
    // (Measured: rt 147 dB, soft 74 dB, area 65 dB.)
    for (const auto& [method, least] : {std::pair{"rt", 100.0}, {"soft", 55.0}, {"exact", 55.0}, {"area", 55.0}}) {
        RenderOptions o = s.render;
        o.accel = "embree";
        o.shadows = method;
        const RenderResult a = RenderJob(s, o).Render(), b = RenderJob(f, o).Render();
        const ImageMetrics m = CompareImages(a.image, b.image);
        EXPECT_GT(m.psnr, least) << method;
    }
}

// --- the scene file's rule -------------------------------------------------------------

std::string TempFolder() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    const std::filesystem::path p =
        std::filesystem::path(::testing::TempDir()) / ("lightmesh_" + std::string(info->test_suite_name()) + "_" + info->name());
    std::filesystem::remove_all(p);
    std::filesystem::create_directories(p);
    return p.string();
}

/// An OBJ of two objects, "left" and "right", each a UV sphere of 2 × (rings − 1) × 64
/// triangles with vertex normals.
std::string TwoSpheresObj(int rings, const std::string& material = "") {
    std::string text = material.empty() ? "" : "mtllib balls.mtl\nusemtl " + material + "\n";
    int base = 1;
    for (int side = 0; side < 2; ++side) {
        text += side ? "o right\n" : "o left\n";
        const int segments = 64;
        for (int i = 0; i <= rings; ++i)
            for (int j = 0; j < segments; ++j) {
                const double th = M_PI * i / rings, ph = 2 * M_PI * j / segments;
                text += "v " + std::to_string(std::sin(th) * std::cos(ph) + 3 * side) + " " + std::to_string(std::cos(th)) +
                        " " + std::to_string(std::sin(th) * std::sin(ph)) + "\n";
                text += "vn " + std::to_string(std::sin(th) * std::cos(ph)) + " " + std::to_string(std::cos(th)) + " " +
                        std::to_string(std::sin(th) * std::sin(ph)) + "\n";
                text += "vt " + std::to_string(static_cast<double>(j) / segments) + " " +
                        std::to_string(static_cast<double>(i) / rings) + "\n";
            }
        auto v = [&](int i, int j) {
            const std::string k = std::to_string(base + i * segments + j % segments);
            return k + "/" + k + "/" + k;
        };
        for (int i = 0; i < rings; ++i)
            for (int j = 0; j < segments; ++j) {
                if (i > 0) text += "f " + v(i, j) + " " + v(i, j + 1) + " " + v(i + 1, j) + "\n";
                if (i < rings - 1) text += "f " + v(i, j + 1) + " " + v(i + 1, j + 1) + " " + v(i + 1, j) + "\n";
            }
        base += (rings + 1) * segments;
    }
    return text;
}

/// `refs` references to balls.obj in a grid; `extra` added to every other one, which is
/// mirrored (x → −x) if `mirrorOdd`.
std::string SceneWith(int refs, const std::string& extra, const std::string& render = "", bool mirrorOdd = false) {
    std::string meshes;
    for (int k = 0; k < refs; ++k)
        meshes += std::string(k ? "," : "") + R"({"file": "balls.obj", "transform": {)" +
                  (mirrorOdd && k % 2 ? R"("scale": [-1, 1, 1], )" : "") + R"("translate": [)" +
                  std::to_string(8 * (k % 8)) + ", 0, " + std::to_string(8 * (k / 8)) + "]}" + (k % 2 ? extra : "") + "}";
    return R"({"camera": {"position": [30, 40, 80], "look_at": [30, 0, 30]}, "lights": [{"position": [0, 50, 0]}],
               "meshes": [)" + meshes + "]" + render + "}";
}

Scene LoadText(const std::string& folder, const std::string& text, int* imports = nullptr) {
    std::ofstream(folder + "/scene.json") << text;
    SceneLoadOptions options;
    options.loadMesh = [&](const std::string& file, const MeshLoadOptions& load) {
        if (imports) ++*imports;
        return LoadMeshFile(file, load);
    };
    std::vector<std::string> warnings;
    return LoadScene(folder + "/scene.json", options, &warnings);
}

TEST(Instances, SceneFileRuleAndExclusionsPerReference) {
    const std::string folder = TempFolder();
    std::ofstream(folder + "/balls.obj") << TwoSpheresObj(17);  // 2 × 2,048 triangles
    // 32 references: 131,072 triangles in copies: one prototype, 32 instances.
    int imports = 0;
    const Scene s = LoadText(folder, SceneWith(32, ""), &imports);
    EXPECT_EQ(imports, 1);
    ASSERT_TRUE(s.mesh.instances);
    EXPECT_EQ(s.mesh.instances->Prototypes().size(), 1u);
    EXPECT_EQ(s.mesh.instances->Instances().size(), 32u);
    EXPECT_EQ(s.mesh.PrimCount(), 32u * 4096u);
    EXPECT_EQ(s.mesh.TriangleCount(), 0u);
    // "instancing": false copies every reference, the same triangles in the same order.
    const Scene flat = LoadText(folder, SceneWith(32, "", R"(, "render": {"instancing": false})"));
    EXPECT_FALSE(flat.mesh.instances);
    ASSERT_EQ(flat.mesh.TriangleCount(), s.mesh.PrimCount());
    for (uint32_t id = 0; id < flat.mesh.TriangleCount(); id += 97) {
        Vec3 p[3];
        s.mesh.Corners(id, p);
        for (int k = 0; k < 3; ++k) EXPECT_TRUE(Same(p[k], flat.mesh.Vertex(id, k)));
    }
    // exclude_names per reference: half the references keep one sphere, so two groups of
    // 16 (65,536 and 32,768 triangles in copies): the first instanced, the second copied.
    const Scene mixed = LoadText(folder, SceneWith(32, R"(, "exclude_names": "right")"));
    ASSERT_TRUE(mixed.mesh.instances);
    EXPECT_EQ(mixed.mesh.instances->Instances().size(), 16u);
    EXPECT_EQ(mixed.mesh.TriangleCount(), 16u * 2048u);
    EXPECT_EQ(mixed.mesh.PrimCount(), 16u * 4096u + 16u * 2048u);
    // With a ground, shading normals as the copies would have them: the slab gets normals
    // like the instances', and every triangle reads the flattened mesh's normals.
    const Scene grounded = LoadText(folder, SceneWith(32, "", R"(, "ground": {"up": "y"})"));
    ASSERT_TRUE(grounded.mesh.instances);
    EXPECT_TRUE(grounded.mesh.HasShadingNormals());
    const TriangleMesh copies = Flattened(grounded.mesh);
    ASSERT_FALSE(copies.normals.empty());
    for (uint32_t id = 0; id < copies.TriangleCount(); id += 53) {
        Vec3 a[3], b[3];
        ASSERT_TRUE(grounded.mesh.ShadingNormals(id, a));
        ASSERT_TRUE(copies.ShadingNormals(id, b));
        for (int k = 0; k < 3; ++k) EXPECT_TRUE(Same(a[k], b[k])) << id;
    }
    // Few copies stay flat (byte-identical to before instancing).
    EXPECT_FALSE(LoadText(folder, SceneWith(8, "")).mesh.instances);
}

// A textured file is instanced and its texels read through the instances, as the copies'
// are; so is one whose material cuts holes (map_d), its holes where the copies' are.
TEST(Instances, TexturedAndCutOutFilesAreInstancedAsTheirCopies) {
#ifndef LIGHTMESH_HAS_EMBREE
    GTEST_SKIP() << "no Embree";
#endif
    const std::string folder = TempFolder();
    Image stripes(8, 8);
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x) stripes.At(x, y) = x % 2 ? Color(0.9f, 0.2f, 0.1f) : Color(0.1f, 0.3f, 0.9f);
    WriteImage(folder + "/stripes.png", stripes);
    std::ofstream(folder + "/balls.mtl") << "newmtl skin\nKd 1 1 1\nmap_Kd stripes.png\n"
                                            "newmtl holes\nKd 1 1 1\nmap_d stripes.png\n";
    std::ofstream(folder + "/balls.obj") << TwoSpheresObj(17, "skin");
    const Scene s = LoadText(folder, SceneWith(32, ""));
    ASSERT_TRUE(s.mesh.instances);
    ASSERT_GE(s.materials.size(), 1u);
    EXPECT_GE(s.materials.back().texture, 0);
    const Scene flat = LoadText(folder, SceneWith(32, "", R"(, "render": {"instancing": false})"));
    ASSERT_FALSE(flat.mesh.instances);
    RenderOptions o = s.render;
    o.width = 96, o.height = 72, o.accel = "embree", o.shadows = "rt";
    const RenderResult a = RenderJob(s, o).Render(), b = RenderJob(flat, o).Render();
    EXPECT_GT(CompareImages(a.image, b.image).psnr, 60.0);
    std::ofstream(folder + "/balls.obj") << TwoSpheresObj(17, "holes");
    const Scene cut = LoadText(folder, SceneWith(32, "", "", true));
    const Scene cutFlat = LoadText(folder, SceneWith(32, "", R"(, "render": {"instancing": false})", true));
    ASSERT_TRUE(cut.mesh.instances);
    ASSERT_TRUE(cut.mesh.cutouts);
    ASSERT_TRUE(cutFlat.mesh.cutouts);
    EXPECT_GT(cut.mesh.cutouts->Count(), 60000u);
    EXPECT_EQ(cut.mesh.cutouts->Count(), cutFlat.mesh.cutouts->Count());
    // The mask answers alike by id (half the references mirrored: barycentrics swapped).
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0, 1);
    for (uint32_t id = 0; id < cutFlat.mesh.TriangleCount(); id += 31) {
        float b1 = u(rng), b2 = u(rng);
        if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
        ASSERT_EQ(cut.mesh.cutouts->IsCutout(id), cutFlat.mesh.cutouts->IsCutout(id));
        ASSERT_EQ(cut.mesh.cutouts->Solid(cut.mesh, id, b1, b2), cutFlat.mesh.cutouts->Solid(cutFlat.mesh, id, b1, b2)) << id;
    }
    for (const char* method : {"rt", "soft", "exact", "area"}) {
        o.shadows = method;
        const RenderResult ci = RenderJob(cut, o).Render(), cf = RenderJob(cutFlat, o).Render();
        EXPECT_GT(CompareImages(ci.image, cf.image).psnr, 40.0) << method;
    }
}

TEST(Instances, ATransformTooLargeIsRefusedForAnInstance) {
    const std::string folder = TempFolder();
    std::ofstream(folder + "/balls.obj") << TwoSpheresObj(17);
    std::string text = SceneWith(32, "");
    const std::string first = R"({"file": "balls.obj", "transform": {"translate": [0, 0, 0]}})";
    ASSERT_NE(text.find(first), std::string::npos);
    text.replace(text.find(first), first.size(), R"({"file": "balls.obj", "transform": {"scale": 3e38, "translate": [3e38, 0, 0]}})");
    try {
        LoadText(folder, text);
        FAIL() << "loaded";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("/meshes/0: the transform makes coordinates non-finite"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace instances_test
}  // namespace lm
