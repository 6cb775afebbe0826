// cutouts_test.cpp -- alpha cut-outs: the mask's test, and every back-end's queries on a
// cut-out checker against brute force's (the grid bit for bit, Embree by its own
// barycentrics through its filter functions).
#include "lightmesh/geometry/cutouts.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/geometry/mesh.h"
#include "lightmesh/io/image.h"
#include "lightmesh/scene/scene_file.h"
#include "support/cutout_scenes.h"

namespace lm {
namespace cutouts_test {
namespace {

namespace fs = std::filesystem;
const std::string DataDir = testing::TextureDataDir();
using testing::CheckerScene;

TEST(Cutouts, TheCheckerQuadIsACutOutAndItsHolesAreHoles) {
    const Scene s = CheckerScene();
    ASSERT_TRUE(s.mesh.cutouts);
    EXPECT_EQ(s.mesh.cutouts->Count(), 2u);  // the quad's two triangles, not the ground's
    const auto brute = CreateAccelerator("brute", s.mesh);
    // Texel (0, 0) of the image (its top left) is solid (alpha 255), its neighbours are
    // holes. The glTF's texture coordinates put the image's top-left corner at the quad's
    // corner (-2, 1, -2): texel column = (x + 2) / 0.5, row from the top = (z + 2) / 0.5.
    auto solidAt = [&](float x, float z) {
        Hit hit;
        EXPECT_TRUE(brute->Intersect(Ray{Vec3(x, 5, z), Vec3(0, -1, 0), 0, Infinity}, &hit));
        return hit.t < 4.5f;  // the quad (t = 4), not the ground (t = 5)
    };
    for (int row = 0; row < 8; ++row)
        for (int col = 0; col < 8; ++col) {
            const float x = -2 + 0.5f * (col + 0.5f), z = -2 + 0.5f * (row + 0.5f);
            EXPECT_EQ(solidAt(x, z), (row + col) % 2 == 0) << "texel " << col << ", " << row;
        }
    // Without textures the quad is solid everywhere, as before cut-outs.
    const Scene flat = CheckerScene(false);
    EXPECT_FALSE(flat.mesh.cutouts);
}

TEST(Cutouts, EveryBackEndAgreesWithBruteForce) {
    const Scene s = CheckerScene();
    const auto brute = CreateAccelerator("brute", s.mesh);
    std::mt19937 rng(46);
    std::uniform_real_distribution<float> u(-2.5f, 2.5f), tilt(-0.4f, 0.4f);
    std::vector<Ray> rays;
    for (int i = 0; i < 4000; ++i) {
        const Vec3 o(u(rng), 3.0f, u(rng));
        rays.push_back(Ray{o, Normalize(Vec3(tilt(rng), -1, tilt(rng))), 0, i % 3 == 0 ? 2.5f : Infinity});
    }
    size_t holes = 0;
    for (const std::string& name : AcceleratorNames()) {
        if (name == "brute") continue;
        SCOPED_TRACE(name);
        const auto accel = CreateAccelerator(name, s.mesh);
        std::vector<Hit> many(rays.size());
        accel->IntersectMany(rays.data(), rays.size(), many.data());
        std::unique_ptr<bool[]> occludedMany(new bool[rays.size()]);
        accel->OccludedMany(rays.data(), rays.size(), occludedMany.get());
        size_t differ = 0;
        for (size_t i = 0; i < rays.size(); ++i) {
            Hit want, got;
            const bool w = brute->Intersect(rays[i], &want), g = accel->Intersect(rays[i], &got);
            const bool wo = brute->Occluded(rays[i]);
            holes += w && s.mesh.materialIds[want.prim] != s.mesh.materialIds[0] && rays[i].tMax == Infinity;
            if (name == "grid") {
                // The same triangle test and the same alpha test: the same answers, bit for bit.
                ASSERT_EQ(w, g) << i;
                EXPECT_EQ(want.prim, got.prim) << i;
                EXPECT_EQ(want.t, got.t) << i;
                EXPECT_EQ(want.b1, got.b1) << i;
                EXPECT_EQ(want.b2, got.b2) << i;
                EXPECT_EQ(wo, accel->Occluded(rays[i])) << i;
                EXPECT_EQ(brute->CountCrossings(rays[i]), accel->CountCrossings(rays[i])) << i;
            } else {
                // Embree's own triangle test and barycentrics: the same answers but for rays
                // within rounding of a texel's edge or a triangle's.
                differ += w != g || (w && want.prim != got.prim) || wo != accel->Occluded(rays[i]) ||
                          brute->CountCrossings(rays[i]) != accel->CountCrossings(rays[i]);
                if (w && g && want.prim == got.prim) {
                    EXPECT_NEAR(want.t, got.t, 1e-4f) << i;
                }
            }
            // The batched queries give each ray its own answer.
            EXPECT_EQ(many[i].prim, g ? got.prim : UINT32_MAX) << i;
            EXPECT_EQ(occludedMany[i], accel->Occluded(rays[i])) << i;
        }
        EXPECT_LE(differ, rays.size() / 500) << name;
    }
    // The test saw holes: rays through the quad that reached the ground.
    EXPECT_GT(holes, 100u);
}

// Coherent rays (a camera's, as the renderer batches them): the grid's packet leaf test
// hands cut-out hits to the scalar test and the alpha test; each ray gets Intersect's and
// Occluded's answer, whatever its companions.
TEST(Cutouts, BatchesOfCoherentRaysGetEachRaysAnswer) {
    const Scene s = CheckerScene();
    const auto brute = CreateAccelerator("brute", s.mesh);
    for (const std::string& name : AcceleratorNames()) {
        SCOPED_TRACE(name);
        const auto accel = CreateAccelerator(name, s.mesh);
        size_t holes = 0;
        for (int tile = 0; tile < 16; ++tile) {
            std::vector<Ray> rays;
            for (int k = 0; k < 64; ++k) {
                const float x = -2.2f + 4.4f * ((tile % 4) * 8 + k % 8 + 0.5f) / 32,
                            z = -2.2f + 4.4f * ((tile / 4) * 8 + k / 8 + 0.5f) / 32;
                rays.push_back(Ray{Vec3(0.3f, 6, 0.2f), Vec3(x, 1, z) - Vec3(0.3f, 6, 0.2f), 0, Infinity});
            }
            std::vector<Hit> hits(rays.size());
            accel->IntersectMany(rays.data(), rays.size(), hits.data());
            std::unique_ptr<bool[]> occluded(new bool[rays.size()]);
            std::vector<Ray> shadow;
            for (const Ray& r : rays) shadow.push_back(Ray{r.o, r.d, 0, 1.1f});  // to between the quad (t = 1) and the ground (t = 1.2)
            accel->OccludedMany(shadow.data(), shadow.size(), occluded.get());
            for (size_t i = 0; i < rays.size(); ++i) {
                Hit want;
                const bool w = brute->Intersect(rays[i], &want);
                ASSERT_EQ(w, hits[i].prim != UINT32_MAX) << tile << " " << i;
                if (name == "grid") {
                    EXPECT_EQ(want.prim, hits[i].prim);
                    EXPECT_EQ(want.t, hits[i].t);
                    EXPECT_EQ(brute->Occluded(shadow[i]), occluded[i]);
                }
                EXPECT_EQ(accel->Occluded(shadow[i]), occluded[i]);
                holes += w && want.t > 1.1f;
            }
        }
        EXPECT_GT(holes, 100u);
    }
}

TEST(Cutouts, CrossingCountsSkipTheHoles) {
    const Scene s = CheckerScene();
    // Down through a solid texel and through a hole: the quad counts only where solid; the
    // ground slab (closed) twice either way.
    const auto brute = CreateAccelerator("brute", s.mesh);
    const float solidX = -2 + 0.25f, solidZ = -2 + 0.25f;  // texel (0, 0)
    const float holeX = -2 + 0.75f;                               // texel (1, 0)
    const Ray solid{Vec3(solidX, 5, solidZ), Vec3(0, -1, 0), 0, 20};
    const Ray hole{Vec3(holeX, 5, solidZ), Vec3(0, -1, 0), 0, 20};
    for (const std::string& name : AcceleratorNames()) {
        const auto accel = CreateAccelerator(name, s.mesh);
        EXPECT_EQ(accel->CountCrossings(solid), 3) << name;
        EXPECT_EQ(accel->CountCrossings(hole), 2) << name;
    }
    EXPECT_EQ(CountCrossings(s.mesh, hole), 2);
}

// MTL: map_d, a grey opacity map without alpha (its grey level is the opacity), times d;
// a map_Kd image without alpha cuts nothing.
TEST(Cutouts, AnMtlOpacityMapCutsByItsGreyLevel) {
    const fs::path dir = fs::temp_directory_path() / "lightmesh_cutouts_map_d";
    fs::create_directories(dir);
    Image mask(2, 1);
    mask.At(0, 0) = Color(0.0f);  // the left half a hole
    mask.At(1, 0) = Color(1.0f);
    WriteImage((dir / "mask.png").string(), mask);
    std::ofstream(dir / "m.mtl") << "newmtl cut\nKd 0.3 0.6 0.2\nd 1\nmap_d mask.png\n";
    std::ofstream(dir / "m.obj") << "mtllib m.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n"
                                    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl cut\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
    std::vector<std::string> warnings;
    const Scene s = LoadScene((dir / "m.obj").string(), SceneLoadOptions{}, &warnings);
    ASSERT_TRUE(s.mesh.cutouts);
    const auto accel = CreateAccelerator("brute", s.mesh);
    Hit hit;
    ASSERT_TRUE(accel->Intersect(Ray{Vec3(0.6f, 0, 5), Vec3(0, 0, -1), 0, Infinity}, &hit));
    EXPECT_NEAR(hit.t, 5.0f, 1e-5f);  // the solid half
    const bool behind = accel->Intersect(Ray{Vec3(-0.6f, 0, 5), Vec3(0, 0, -1), 0, Infinity}, &hit);
    EXPECT_TRUE(!behind || hit.t > 5.0f) << "the left half is a hole";  // (the ground slab lies below)
    // The same quad with map_Kd of an image without alpha: solid.
    const Scene plain = LoadScene(DataDir + "/quad.obj", SceneLoadOptions{}, &warnings);
    EXPECT_FALSE(plain.mesh.cutouts);
    fs::remove_all(dir);
}

// A binary glTF (.glb) whose image lies in a buffer view: the same cut-out.
TEST(Cutouts, AGlbsImageInABufferViewIsRead) {
    std::vector<std::string> warnings;
    const Scene s = LoadScene(DataDir + "/checker_mask.glb", SceneLoadOptions{}, &warnings);
    ASSERT_EQ(s.textures.size(), 1u);
    ASSERT_TRUE(s.mesh.cutouts);
    EXPECT_EQ(s.mesh.cutouts->Count(), 2u);
    const auto brute = CreateAccelerator("brute", s.mesh);
    Hit hit;
    ASSERT_TRUE(brute->Intersect(Ray{Vec3(-1.75f, 5, -1.75f), Vec3(0, -1, 0), 0, Infinity}, &hit));
    EXPECT_EQ(hit.t, 4.0f);  // texel (0, 0): solid
    const bool below = brute->Intersect(Ray{Vec3(-1.25f, 5, -1.75f), Vec3(0, -1, 0), 0, Infinity}, &hit);
    EXPECT_TRUE(!below || hit.t > 4.0f);  // texel (1, 0): a hole
}

// A MASK material whose image is solid under a triangle leaves it opaque (no alpha test,
// no second Embree geometry); an image without alpha (all solid) leaves no cut-outs at all.
TEST(Cutouts, TrianglesWhollySolidUnderTheirImageAreOpaque) {
    const fs::path dir = fs::temp_directory_path() / "lightmesh_cutouts_opaque";
    fs::create_directories(dir);
    Image grey(8, 8);
    for (Color& c : grey.pixels) c = Color(0.5f);
    WriteImage((dir / "opaque.png").string(), grey);
    std::ifstream in(DataDir + "/checker_mask.gltf");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t uri = text.find("data:image/png;base64,");
    ASSERT_NE(uri, std::string::npos);
    text.replace(uri, text.find('"', uri) - uri, "opaque.png");
    std::ofstream(dir / "opaque.gltf") << text;
    std::vector<std::string> warnings;
    const Scene s = LoadScene((dir / "opaque.gltf").string(), SceneLoadOptions{}, &warnings);
    ASSERT_EQ(s.textures.size(), 1u);
    EXPECT_FALSE(s.mesh.cutouts);
    fs::remove_all(dir);
}

TEST(Cutouts, GltfBlendIsAMaskAtOneHalfWithAWarning) {
    const fs::path dir = fs::temp_directory_path() / "lightmesh_cutouts_blend";
    fs::create_directories(dir);
    std::ifstream in(DataDir + "/checker_mask.gltf");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    text.replace(text.find("\"MASK\""), 6, "\"BLEND\"");
    std::ofstream(dir / "blend.gltf") << text;
    std::vector<std::string> warnings;
    const Scene s = LoadScene((dir / "blend.gltf").string(), SceneLoadOptions{}, &warnings);
    EXPECT_TRUE(s.mesh.cutouts);
    size_t said = 0;
    for (const std::string& w : warnings) said += w.find("alphaMode BLEND is rendered as a cut-out at alpha 0.5") != std::string::npos;
    EXPECT_EQ(said, 1u);
    fs::remove_all(dir);
}

TEST(Cutouts, TheCellTableGivesTheComputedAnswer) {
    // SolidAt answers from the cell table where a texel cell's corners agree; everywhere it
    // must give what the bilinear lookup gives, for 8-bit and float images, every wrap
    // mode, sides of 2^k texels and not, cut-offs on the texels' own levels, and scales.
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> byte(0, 255);
    std::uniform_real_distribution<float> uv(-2.5f, 3.5f), unit(0.0f, 1.0f);
    size_t fast = 0, total = 0;
    for (int trial = 0; trial < 12; ++trial) {
        const int w = trial % 3 == 0 ? 8 : 5 + trial, h = trial % 2 ? 4 : 7;
        std::shared_ptr<const Texture> image;
        if (trial % 4 == 3) {
            std::vector<float> texels(static_cast<size_t>(w) * h * 4);
            for (float& t : texels) t = unit(rng) < 0.5f ? 0.0f : unit(rng);
            image = std::make_shared<Texture>(w, h, std::move(texels));
        } else {
            std::vector<uint8_t> texels(static_cast<size_t>(w) * h * 4);
            // Blocks of equal alpha, so that many cells agree, and levels at the cut-off.
            for (size_t i = 0; i < texels.size(); ++i) texels[i] = static_cast<uint8_t>((i / 8) % 3 == 0 ? 0 : (i / 8) % 3 == 1 ? 255 : 128);
            for (int k = 0; k < 6; ++k) texels[static_cast<size_t>(byte(rng) % (w * h)) * 4 + 3] = static_cast<uint8_t>(byte(rng));
            image = std::make_shared<Texture>(w, h, std::move(texels));
        }
        CutoutMaterial m;
        m.image = image;
        m.cutoff = trial % 5 == 0 ? 128.0f / 255.0f : 0.25f + 0.5f * unit(rng);
        m.scale = trial % 6 == 1 ? 0.8f : 1.0f;
        m.wrapU = static_cast<TextureWrap>(trial % 3);
        m.wrapV = static_cast<TextureWrap>((trial / 3) % 3);
        m.fromRed = trial % 7 == 2;
        CutoutMaterial plain = m;  // no table: always computed
        m.ClassifyCells();
        ASSERT_EQ(m.cells.size(), static_cast<size_t>(w) * h);
        for (uint8_t k : m.cells) fast += k != 0;
        const TexCoord t0{uv(rng), uv(rng)}, t1{uv(rng), uv(rng)}, t2{uv(rng), uv(rng)};
        for (int s = 0; s < 20000; ++s) {
            const float b1 = unit(rng), b2 = unit(rng) * (1 - b1);
            ASSERT_EQ(CutoutMask::SolidAt(m, t0, t1, t2, b1, b2), CutoutMask::SolidAt(plain, t0, t1, t2, b1, b2))
                << "trial " << trial << " b1 " << b1 << " b2 " << b2;
            ++total;
        }
    }
    EXPECT_GT(fast, 100u);  // the table answers for many cells
    EXPECT_EQ(total, 240000u);
}

}  // namespace
}  // namespace cutouts_test
}  // namespace lm
