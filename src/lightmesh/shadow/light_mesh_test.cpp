// light_mesh_test.cpp -- the light mesh's variants, exactness claims, cell structures and
// determinism. Over 500 lines as one concept: each test is one claim about one light mesh.
#include "lightmesh/shadow/light_mesh.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <cmath>
#include <random>
#include <functional>
#include <unordered_map>

#include "support/floor_scenes.h"
#include "support/light_indices.h"
#include "support/light_mesh_probe.h"
#include "support/sanitized.h"
#include "lightmesh/render/whitted.h"
#include "lightmesh/scene/demo_scene.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace light_mesh_test {
namespace {

using testing::AddBox;
using Lmc = LightMeshCount;
using testing::FloorPoint;
using testing::FloorScene;
using testing::RenderedFloorPoint;

// The paper's variants at (CC, kI) over the nested grid.
struct Lmm : testing::LightMeshProbe {
    Lmm(const Scene& s, int cc, float ki, const std::string& variant = "grid")
        : LightMeshProbe(s, testing::LightMeshSettings(cc, ki, variant)) {}
};

TEST(LightMesh, LatticeDimensionsFollowCcAndKi) {
    // A box shaped like the paper's Gazebo: 86 x 64 x 100 cells at CC 100.
    const Bounds3 box(Vec3(0, 0, 0), Vec3(8.6f, 6.4f, 10.0f));
    const LightMeshLattice l = LightMeshLattice::Make(box, 100, 2.0f);
    EXPECT_EQ(l.nx, 92);
    EXPECT_EQ(l.ny, 70);
    EXPECT_EQ(l.nz, 106);  // CC + 2·ceil(kI) + 2: one node more at the far end
    EXPECT_FLOAT_EQ(l.h, 0.1f);
    EXPECT_FLOAT_EQ(l.r, 0.2f);
    EXPECT_EQ(LightMeshLattice::Make(box, 400, 3.0f).nz, 408);
    EXPECT_EQ(LightMeshLattice::Make(box, 100, 1.1f).nz, 105);  // ceil(1.1) = 2 cells of padding, enough
    // The lattice covers the box with ceil(kI) cells to spare on every side.
    EXPECT_LE(l.origin.x, box.lo.x - 2 * l.h + 1e-5f);
    EXPECT_GE(l.Node(l.nx - 1, l.ny - 1, l.nz - 1).z, box.hi.z + 2 * l.h - 1e-4f);
    EXPECT_THROW(LightMeshLattice::Make(box, 0, 2.0f), Error);
    EXPECT_THROW(LightMeshLattice::Make(box, 100, 0.0f), Error);
    EXPECT_THROW(LightMeshLattice::Make(Bounds3(), 100, 2.0f), Error);
}

TEST(LightMesh, OneBytePerNodeUpToSixLights) {
    EXPECT_EQ(LightMeshBytesPerNode(1), 1);
    EXPECT_EQ(LightMeshBytesPerNode(6), 1);
    EXPECT_EQ(LightMeshBytesPerNode(7), 2);
    EXPECT_EQ(LightMeshBytesPerNode(14), 2);
    EXPECT_EQ(LightMeshBytesPerNode(15), 4);
    EXPECT_EQ(LightMeshBytesPerNode(62), 8);
}

// Formula (2) averages each light's bits over a node set that does not depend on the
// lights (the nodes in front, and for ОТ and consensus those that see P), so a light's
// visibility in a scene of many lights is its visibility alone, to the bit. Lights repeated
// to 9, 20 and 40 make node words of 2, 4 and 8 bytes, whose bits are summed byte by byte
// (and, with AVX2, from gathered words): a light's count in the wrong lane, or a flag bit
// counted, changes some point's value.
TEST(LightMesh, EveryWordSizeGivesEachLightItsOwnAverage) {
    Scene base = FloorScene();
    AddBox(&base, {-1, 0, -1}, {0.6f, 0.5f, 0.3f});
    AddBox(&base, {0.9f, 0.7f, -0.4f}, {1.6f, 0.8f, 0.9f});
    const Vec3 positions[3] = {{0.5f, 4.0f, 0.25f}, {-2.5f, 3.0f, 1.5f}, {3.0f, 2.5f, -2.0f}};
    for (const char* variant : {"none", "consensus", "object"}) {
        std::vector<Scene> scenes(3, base);  // a light mesh keeps a reference to its scene
        std::vector<std::unique_ptr<Lmm>> alone;
        for (int l = 0; l < 3; ++l) {
            scenes[l].lights = {{positions[l], Color(1.0f), Falloff::None}};
            alone.push_back(std::make_unique<Lmm>(scenes[l], 60, 2.0f, variant));
        }
        for (int lights : {9, 20, 40}) {
            Scene s = base;
            s.lights.clear();
            for (int l = 0; l < lights; ++l) s.lights.push_back({positions[l % 3], Color(1.0f), Falloff::None});
            for (int width : {1, 0}) {  // the scalar byte lanes; the widest (AVX2's gathered sums)
                LightMeshOptions options = testing::LightMeshSettings(60, 2.0f, variant);
                options.simdWidth = width;
                testing::LightMeshProbe many(s, options);
                ASSERT_EQ(many.lmm->BytesPerNode(), lights < 15 ? 2 : lights < 31 ? 4 : 8);
                int partial = 0;
                const float step = testing::kSanitized ? 2.0f : 1.0f;  // a quarter of the points under the sanitizers
                for (float x = -2.2f; x <= 2.6f; x += 0.0731f * step)
                    for (float z = -2.1f; z <= 2.2f; z += 0.0917f * step) {
                        const ShadingPoint sp = testing::RenderedFloorPoint(x, z);
                        const std::vector<uint32_t> needed = testing::AllLights(s.lights.size());
                        float vis[64] = {};
                        RenderCounters c;
                        many.lmm->Visibility(sp, needed, vis, c);
                        for (int l = 0; l < lights; ++l) {
                            const float own = alone[l % 3]->Vis(sp);
                            ASSERT_EQ(vis[l], own) << variant << ", " << lights << " lights, light " << l << " at " << x << ", " << z;
                            partial += own > 0 && own < 1;
                        }
                    }
                EXPECT_GT(partial, 100) << variant << ", " << lights << " lights";  // penumbrae were summed
            }
        }
    }
}

// The faces of the scene's box lie on lattice planes where its side is a whole number of
// steps (always on the longest axis): a closed room's far walls. Their points must get
// the templates (and the cell summaries) like every other point, not the paper's cube
// loop, which traces a segment per candidate: the lattice's extra far node gives their
// templates room.
TEST(LightMesh, PointsOnTheBoxsFarFacesUseTheTemplates) {
    Scene s = FloorScene();  // 20 × 20: x and z both span CC steps
    const uint32_t v = static_cast<uint32_t>(s.mesh.positions.size());
    s.mesh.positions.insert(s.mesh.positions.end(), {{-10, 0, 10}, {10, 0, 10}, {10, 4, 10}, {-10, 4, 10},
                                                      {10, 0, -10}, {10, 4, -10}});
    s.mesh.triangles.insert(s.mesh.triangles.end(), {{v, v + 1, v + 2}, {v, v + 2, v + 3},               // z = 10
                                                     {v + 1, v + 4, v + 5}, {v + 1, v + 5, v + 2}});  // x = 10
    s.mesh.materialIds.insert(s.mesh.materialIds.end(), {0, 0, 0, 0});
    s.lights = {{{0.0f, 3.0f, 0.0f}, Color(1.0f), Falloff::None}};
    Lmm lmm(s, 100, 2.0f, "consensus");
    const float step = lmm.lmm->Lattice().h;
    RenderCounters c;
    int points = 0;
    for (float a = -8.0f; a <= 8.0f; a += 0.37f)
        for (float y = 0.5f; y <= 3.5f; y += 0.29f) {
            for (int wall = 0; wall < 2; ++wall) {
                ShadingPoint sp;
                sp.p = wall == 0 ? Vec3(a, y, 10.0f) : Vec3(10.0f, y, a);
                sp.n = wall == 0 ? Vec3(0, 0, -1) : Vec3(-1, 0, 0);
                sp.origin = sp.p + sp.n * (1e-3f * step);
                sp.prim = wall == 0 ? 2 : 4;
                EXPECT_EQ(lmm.Vis(sp, 0, &c), 1.0f) << a << ", " << y << ", wall " << wall;  // nothing between
                ++points;
            }
        }
    // Every point on the open walls is answered by its cell's summary: the templates'
    // path. The cube loop has no summaries and traces a segment per candidate (several
    // per point); here only points near the corner and the floor, not on a plane of
    // their own cell, look for one candidate that sees them.
    EXPECT_EQ(Count(c, Lmc::kUniformCellPoints), static_cast<uint64_t>(points));
    EXPECT_LT(Count(c, Lmc::kLocalSegments), static_cast<uint64_t>(points / 4));
}

// The converse on the near faces: a floor at the box's lowest point lies on lattice plane
// ceil(kI), but its points' coordinate may round a hair below it, into a cell whose
// template would reach below the lattice. The floor's height is chosen here so that it
// does (checked with the light mesh's own arithmetic); its points must still get the
// templates and summaries, and the same values as a floor a little higher up.
TEST(LightMesh, PointsOnTheBoxsNearFacesUseTheTemplates) {
    const int cc = 100, pad = 2;
    const float half = 10.0f, h = 2 * half / static_cast<float>(cc);
    float floorY = 0;
    for (int k = 1; k < 10000 && floorY == 0; ++k) {  // a height whose lattice coordinate rounds down
        const float y = 0.1f + 1.37e-4f * static_cast<float>(k);
        const float origin = y - static_cast<float>(pad) * h;
        if (FloorToInt((y - origin) * (1.0f / h)) < pad) floorY = y;
    }
    ASSERT_NE(floorY, 0.0f) << "no height rounds down: the test needs another search";
    Scene s = FloorScene(half);
    for (Vec3& p : s.mesh.positions) p.y = floorY;
    AddBox(&s, {-1, floorY + 2, -1}, {1, floorY + 2.1f, 1});  // a shadow on the floor
    s.lights = {{{0.3f, floorY + 5, 0.2f}, Color(1.0f), Falloff::None}};
    Lmm lmm(s, cc, 2.0f, "consensus");
    ASSERT_EQ(lmm.lmm->Lattice().origin.y, floorY - static_cast<float>(pad) * lmm.lmm->Lattice().h);
    RenderCounters c;
    int points = 0, shadowed = 0;
    for (float x = -3.0f; x <= 3.0f; x += 0.173f)
        for (float z = -3.0f; z <= 3.0f; z += 0.191f) {
            ShadingPoint sp = testing::RenderedFloorPoint(x, z, half);
            sp.p.y = floorY;
            sp.origin.y += floorY;
            const float v = lmm.Vis(sp, 0, &c);
            shadowed += v < 1;
            ++points;
        }
    EXPECT_GT(shadowed, 20);
    // Every point is on its cell's plane: the templates with their summaries, no segment.
    EXPECT_EQ(Count(c, Lmc::kPlanarCellPoints), static_cast<uint64_t>(points));
    EXPECT_EQ(Count(c, Lmc::kLocalSegments), 0u);
}

TEST(LightMesh, RefusesAMeshThatWouldNotFitBeforeAllocating) {
    Scene s = FloorScene();
    AddBox(&s, {-10, 0, -10}, {10, 20, 10});  // a cube-shaped scene: CC³ nodes
    auto accel = CreateAccelerator("brute", s.mesh);
    LightMeshOptions o;
    o.cc = 4096;
    try {
        CreateLightMeshShadows(s, *accel, o);
        FAIL() << "expected an error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("needs"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("GiB"), std::string::npos) << e.what();
    }
}

// A plane with no occluder: every node sees the light, so LMM is RT, pixel for pixel.
TEST(LightMesh, UnoccludedPlaneEqualsRtExactly) {
    Scene s = FloorScene();
    s.lights.push_back({{-2, 3, 1}, Color(5.0f), Falloff::InverseSquare});
    auto accel = CreateAccelerator("grid", s.mesh);
    s.render.shadows = "rt";
    auto rt = CreateShadowMethod("rt", s, *accel, s.render);
    auto lmm = CreateShadowMethod("lmm", s, *accel, s.render);
    const RenderResult a = WhittedRenderer(s, *accel, *rt, s.render).Render();
    const RenderResult b = WhittedRenderer(s, *accel, *lmm, s.render).Render();
    EXPECT_EQ(a.image.pixels, b.image.pixels);
    EXPECT_GT(Count(b.counters, Lmc::kInterpolations), 0u);
    EXPECT_EQ(Count(b.counters, Lmc::kFallbacks), 0u);
}

// A large occluder high above the floor: far inside its shadow, LMM gives 0 as RT does.
TEST(LightMesh, DeepUmbraIsDark) {
    Scene s = FloorScene();
    AddBox(&s, {-4, 2, -4}, {4, 2.2f, 4});
    Lmm lmm(s, 100, 2.0f);
    EXPECT_EQ(lmm.Vis(FloorPoint(0.3f, -0.2f)), 0.0f);
    EXPECT_EQ(lmm.Vis(FloorPoint(-1.0f, 1.0f)), 0.0f);
    EXPECT_EQ(lmm.Vis(FloorPoint(9.0f, 9.0f)), 1.0f);  // far outside the shadow
}

// A straight shadow edge: a half-plane occluder at x < e with the light right above its
// edge, so the shadow boundary is the vertical plane x = e. LMM's visibility across it
// rises from 0 to 1 over a band about 2r wide, monotonically up to the weight of about one
// node (the discrete sphere gains and loses nodes as P moves, which changes m).
TEST(LightMesh, ShadowEdgeBandIsAboutTwoR) {
    const float e = 0.37f;  // keeps nodes off the boundary plane
    for (float ki : {1.5f, 3.0f}) {
        Scene s = FloorScene(50.0f);
        AddBox(&s, {-50, 5, -50}, {e, 5.2f, 50});
        s.lights = {{{e, 10, 0}, Color(1.0f), Falloff::None}};
        Lmm lmm(s, 100, ki);
        const float r = lmm.lmm->Lattice().r, h = lmm.lmm->Lattice().h;
        float prev = -1, firstLit = NAN, lastShadowed = NAN;
        for (float x = e - 2 * r; x <= e + 2 * r; x += h / 16) {
            const float v = lmm.Vis(FloorPoint(x, 0.13f));
            EXPECT_GE(v, prev - 0.02f) << "not monotonic at x = " << x << ", kI " << ki;
            prev = v;
            if (v > 0 && std::isnan(firstLit)) firstLit = x;
            if (v < 1) lastShadowed = x;
        }
        const float band = lastShadowed - firstLit;
        EXPECT_LE(band, 2 * r) << "kI " << ki;
        EXPECT_GE(band, 2 * r - 2 * h) << "kI " << ki;
        EXPECT_EQ(lmm.Vis(FloorPoint(e - r - h / 8, 0)), 0.0f);
        EXPECT_EQ(lmm.Vis(FloorPoint(e + r + h / 8, 0)), 1.0f);
    }
}

// Light leaks (paper §1.4): a thin closed slab, much thinner than r, between the light and
// a receiver floor just below it. Nodes above the slab see the light; with no local
// visibility test they leak light under the slab, deep inside RT's shadow. The segment test
// (ОТ) drops them: no point that RT puts in shadow farther than r from its shadow edge
// gets any light.
TEST(LightMesh, SegmentTestStopsLeaksThatNoTestLetsThrough) {
    Scene s = FloorScene();
    const float h = 20.0f / 100.0f, r = 2.0f * h;  // CC 100, kI 2 over the 20-wide floor
    // Slab between lattice layers y = 0 and y = h, so the layer y = h lies above it, within r.
    const float y0 = 0.25f * r, thickness = 0.1f * h;
    const float half = 3.0f;
    AddBox(&s, {-half, y0, -half}, {half, y0 + thickness, half});
    s.lights = {{{0.1f, 8, 0.2f}, Color(1.0f), Falloff::None}};
    Lmm ot(s, 100, 2.0f, "grid"), none(s, 100, 2.0f, "grid-none"), reduced(s, 100, 2.0f, "reduced"),
        templates(s, 100, 2.0f, "templates"), inside(s, 100, 2.0f, "inside"),
        consensus(s, 100, 2.0f, "consensus");
    ASSERT_FLOAT_EQ(ot.lmm->Lattice().r, r);
    // The RT shadow of the slab on the floor is about the slab's footprint (the light is
    // high above); sample points deeper inside it than r.
    int leaksOt = 0, leaksNone = 0, leaksReduced = 0, leaksTemplates = 0, leaksInside = 0, leaksConsensus = 0,
        samples = 0;
    uint64_t patchSegments = 0;
    const float inner = half * (8.0f - y0) / 8.0f - r - h;
    for (float x = -inner; x <= inner; x += h / 3) {
        for (float z = -inner; z <= inner; z += h / 3) {
            const ShadingPoint sp = FloorPoint(x, z);
            ASSERT_FALSE(LightVisible(*ot.accel, sp.origin, s.lights[0].position));
            ++samples;
            leaksOt += ot.Vis(sp) > 0;
            leaksNone += none.Vis(sp) > 0;
            leaksReduced += reduced.Vis(sp) > 0;
            leaksTemplates += templates.Vis(sp) > 0;
            leaksInside += inside.Vis(sp) > 0;
            // The default also where its cell patches apply (points as the renderer makes them).
            RenderCounters counters;
            leaksConsensus += consensus.Vis(sp) > 0;
            leaksConsensus += consensus.Vis(RenderedFloorPoint(x, z), 0, &counters) > 0;
            patchSegments += Count(counters, Lmc::kPatchSegments);
        }
    }
    EXPECT_GT(samples, 100);
    EXPECT_EQ(leaksOt, 0);
    EXPECT_EQ(leaksTemplates, 0);
    EXPECT_EQ(leaksReduced, 0);
    EXPECT_EQ(leaksConsensus, 0);
    // Under the slab no node sees a whole cell patch (making them all "see" it fails the
    // count above); just outside it, where the slab is in reach but not in the way, nodes
    // do, and their points are lit exactly.
    for (float x = half + h; x <= half + r + h; x += h / 3)
        for (float z = -half; z <= half; z += h / 3) {
            RenderCounters counters;
            EXPECT_EQ(consensus.Vis(RenderedFloorPoint(x, z), 0, &counters), ot.Vis(RenderedFloorPoint(x, z)));
            patchSegments += Count(counters, Lmc::kPatchSegments);
        }
    EXPECT_GT(patchSegments, 0u);
    EXPECT_GT(leaksNone, samples / 2) << "the leak test must be able to fail";
    // СТ drops nodes inside solids; the slab is thinner than h and holds none, and the
    // leaking nodes lie outside it, so СТ cannot stop this leak (by design: paper §4
    // assumes leaks come from nodes inside objects). This pins that limit down.
    EXPECT_GT(leaksInside, samples / 2);
}

// Laziness: only nodes near visible surfaces are ever evaluated. With the cube loop "near"
// is within r of a shading point; the templates snap P to a sub-position first, which
// moves it by up to √3/2 · h/ns.
class LightMeshLaziness : public ::testing::TestWithParam<const char*> {};

TEST_P(LightMeshLaziness, EvaluatesOnlyNodesNearShadedPoints) {
    Scene s = MakeBuiltinScene("gazebo");
    s.render.lightMesh.variant = GetParam();
    for (Material& m : s.materials) m.mirror = Color(0.0f);  // shading points = camera hits
    s.render.width = 80;
    s.render.height = 60;
    auto accel = CreateAccelerator("grid", s.mesh);
    auto lmm = CreateLightMeshShadows(s, *accel, s.render.lightMesh);
    WhittedRenderer renderer(s, *accel, *lmm, s.render);
    renderer.Render();
    const LightMeshLattice& L = lmm->Lattice();
    const float reach = L.r + (lmm->Variant().enumeration == SphereEnumeration::Templates
                                   ? std::sqrt(3.0f) / 2 * L.h / kDefaultTemplateSubsteps
                                   : 0.0f);
    const uint64_t evaluated = lmm->NodesEvaluated();
    EXPECT_GT(evaluated, 0u);
    EXPECT_LT(static_cast<double>(evaluated), 0.05 * static_cast<double>(L.NodeCount()));

    // Hash the camera-ray hit points by cells of size r, then check every evaluated node
    // has one within r.
    const CameraRays cam(s.camera, s.render.width, s.render.height);
    std::unordered_map<uint64_t, std::vector<Vec3>> cells;
    auto key = [&](int i, int j, int k) {
        return (static_cast<uint64_t>(i + 4096) << 42) | (static_cast<uint64_t>(j + 4096) << 21) | (k + 4096);
    };
    auto cellOf = [&](const Vec3& p, int axis) { return static_cast<int>(std::floor(p[axis] / reach)); };
    for (int y = 0; y < s.render.height; ++y)
        for (int x = 0; x < s.render.width; ++x) {
            Hit hit;
            const Ray ray = cam.Generate(x + 0.5f, y + 0.5f);
            if (!accel->Intersect(ray, &hit)) continue;
            const Vec3 p = WhittedRenderer::MakeShadingPoint(s.mesh, ray, hit).p;
            cells[key(cellOf(p, 0), cellOf(p, 1), cellOf(p, 2))].push_back(p);
        }
    uint64_t checked = 0;
    for (uint64_t idx = 0; idx < L.NodeCount(); ++idx) {
        if (!lmm->IsEvaluated(idx)) continue;
        const Vec3 x = L.NodeAt(idx);
        bool near = false;
        for (int dk = -1; dk <= 1 && !near; ++dk)
            for (int dj = -1; dj <= 1 && !near; ++dj)
                for (int di = -1; di <= 1 && !near; ++di) {
                    auto it = cells.find(key(cellOf(x, 0) + di, cellOf(x, 1) + dj, cellOf(x, 2) + dk));
                    if (it == cells.end()) continue;
                    for (const Vec3& p : it->second)
                        if (Length(x - p) <= reach * 1.0001f) { near = true; break; }
                }
        EXPECT_TRUE(near) << "node " << idx << " evaluated far from every shading point";
        if (!near) break;
        ++checked;
    }
    EXPECT_EQ(checked, evaluated);
}

INSTANTIATE_TEST_SUITE_P(Variants, LightMeshLaziness, ::testing::Values("grid", "reduced", "inside"));

// Consensus traces a segment only where the candidates' bits disagree (or to find one node
// that sees P), and must give ОТ's image bit for bit, with far fewer segments.
TEST(LightMesh, ConsensusGivesTheObjectTestsImageExactly) {
    for (int sceneIndex = 0; sceneIndex < 2; ++sceneIndex) {
        Scene s = MakeBuiltinScene("gazebo");
        if (sceneIndex == 1) {  // the thin-slab leak scene
            s = FloorScene();
            AddBox(&s, {-3, 0.1f, -3}, {3, 0.12f, 3});
            s.lights = {{{0.1f, 8, 0.2f}, Color(1.0f), Falloff::None}};
        }
        s.render.width = 96;
        s.render.height = 72;
        auto accel = CreateAccelerator("grid", s.mesh);
        for (float ki : {2.0f, 3.0f}) {
            RenderResult results[2];
            for (int v = 0; v < 2; ++v) {
                s.render.lightMesh.ki = ki;
                s.render.lightMesh.variant = v == 0 ? "object" : "consensus";
                auto lmm = CreateShadowMethod("lmm", s, *accel, s.render);
                results[v] = WhittedRenderer(s, *accel, *lmm, s.render).Render();
            }
            EXPECT_EQ(results[0].image.pixels, results[1].image.pixels) << "scene " << sceneIndex << " kI " << ki;
            EXPECT_EQ(Count(results[0].counters, Lmc::kFallbacks), Count(results[1].counters, Lmc::kFallbacks));
            EXPECT_LT(Count(results[1].counters, Lmc::kLocalSegments),
                      Count(results[0].counters, Lmc::kLocalSegments) / 2)
                << "scene " << sceneIndex << " kI " << ki;
        }
    }
}

// Scenes for the exactness tests of the cell summaries: the builtin gazebo, the thin-slab
// leak scene, and seeded random scenes (boxes of all sizes on a floor, some floating, some
// touching each other, 1 to 7 lights) on which every case of the summaries happens.
Scene SummaryTestScene(int index) {
    if (index == 0) return MakeBuiltinScene("gazebo");
    Scene s = FloorScene(4.0f);
    if (index == 1) {
        AddBox(&s, {-3, 0.1f, -3}, {3, 0.12f, 3});
        s.lights = {{{0.1f, 8, 0.2f}, Color(1.0f), Falloff::None}};
        return s;
    }
    std::mt19937 rng(static_cast<uint32_t>(index) * 7919u);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const int boxes = 3 + static_cast<int>(u(rng) * 8);
    for (int b = 0; b < boxes; ++b) {
        const Vec3 c(-3 + 6 * u(rng), u(rng) < 0.7f ? 0.0f : 1.5f * u(rng), -3 + 6 * u(rng));
        const Vec3 half(0.05f + 0.8f * u(rng), 0.05f + 0.8f * u(rng), 0.05f + 0.8f * u(rng));
        AddBox(&s, c - Vec3(half.x, 0, half.z), c + Vec3(half.x, 2 * half.y, half.z));
    }
    s.lights.clear();
    const int lights = 1 + static_cast<int>(u(rng) * 7);
    for (int l = 0; l < lights; ++l)
        s.lights.push_back({{-5 + 10 * u(rng), 3 + 4 * u(rng), -5 + 10 * u(rng)}, Color(4.0f + 8 * u(rng)), Falloff::InverseSquare});
    s.camera = Camera{{5 * u(rng) - 2.5f, 3 + 3 * u(rng), 6}, {0, 0.3f, 0}, {0, 1, 0}, 55.0f};
    return s;
}

RenderResult RenderLmm(Scene s, const Accelerator& accel, const std::string& variant, const std::string& summaries,
                       float ki) {
    s.render.width = 72;
    s.render.height = 54;
    s.render.lightMesh.ki = ki;
    s.render.lightMesh.variant = variant;
    s.render.lightMesh.cellSummaries = summaries;
    auto lmm = CreateShadowMethod("lmm", s, accel, s.render);
    return WhittedRenderer(s, accel, *lmm, s.render).Render();
}

// The cell summaries are exact: consensus with them gives ОТ's image bit for bit on every
// back-end, and Нет and СТ with them ("on") their own images without them. The test
// also checks that the summaries did answer points and skip segments, so it can fail.
TEST(LightMesh, CellSummariesKeepEveryImageExactly) {
    uint64_t uniformPoints = 0, planarPoints = 0, culledSegments = 0, patchSegments = 0;
    for (int index = 0; index < 8; ++index) {
        const Scene s = SummaryTestScene(index);
        for (const char* accelName : {"grid", "embree", "brute"}) {
            if (std::string(accelName) == "brute" && index != 2) continue;  // slow: one scene
            // Under the sanitizers the grid and Embree take the scenes in turn (the summaries'
            // code is the same for both; Release runs every pair).
            if (testing::kSanitized && std::string(accelName) != "brute" &&
                (std::string(accelName) == "grid") != (index % 2 == 0))
                continue;
            std::unique_ptr<Accelerator> accel;
            try {
                accel = CreateAccelerator(accelName, s.mesh);
            } catch (const Error&) {
                continue;  // built without Embree
            }
            for (float ki : {2.0f, 1.2f, 3.0f}) {
                if (testing::kSanitized && ki != 2.0f) continue;  // the other kI in the Release build
                const std::string what = StringPrintf("scene %d, %s, kI %g", index, accelName, ki);
                // "on": summaries in every cell ("auto" skips them where cells hold few
                // points, which at this size is nearly everywhere).
                const RenderResult ot = RenderLmm(s, *accel, "object", "auto", ki);
                const RenderResult fast = RenderLmm(s, *accel, "consensus", "on", ki);
                const RenderResult slow = RenderLmm(s, *accel, "consensus", "off", ki);
                EXPECT_EQ(ot.image.pixels, fast.image.pixels) << what;
                EXPECT_EQ(ot.image.pixels, slow.image.pixels) << what;
                EXPECT_EQ(ot.image.pixels, RenderLmm(s, *accel, "consensus", "auto", ki).image.pixels) << what;
                EXPECT_EQ(Count(ot.counters, Lmc::kFallbacks), Count(fast.counters, Lmc::kFallbacks)) << what;
                EXPECT_LE(Count(fast.counters, Lmc::kLocalSegments), Count(slow.counters, Lmc::kLocalSegments)) << what;
                uniformPoints += Count(fast.counters, Lmc::kUniformCellPoints);
                planarPoints += Count(fast.counters, Lmc::kPlanarCellPoints);
                culledSegments += Count(fast.counters, Lmc::kCulledSegments);
                patchSegments += Count(fast.counters, Lmc::kPatchSegments);
                if (ki != 2.0f) continue;
                for (const char* variant : {"none", "inside"}) {
                    const RenderResult off = RenderLmm(s, *accel, variant, "off", ki);
                    const RenderResult on = RenderLmm(s, *accel, variant, "on", ki);
                    EXPECT_EQ(off.image.pixels, on.image.pixels) << what << " " << variant;
                    EXPECT_GT(Count(on.counters, Lmc::kUniformCellPoints), 0u) << what << " " << variant;
                    EXPECT_EQ(Count(off.counters, Lmc::kUniformCellPoints), 0u) << what << " " << variant;
                }
            }
        }
    }
    EXPECT_GT(uniformPoints, 0u);
    EXPECT_GT(planarPoints, 0u);
    EXPECT_GT(culledSegments, 0u);  // the blockers' culling decided segments too
    EXPECT_GT(patchSegments, 0u);   // and so did nodes that see a whole cell patch
}

// "auto" uses a cell's summary only where the image is fine enough for it to pay: for
// points nearer the camera than h / (rayAngle·√kMinRaysPerCell). A floor at CC 400 seen
// at 320×240 has points on both sides of that distance (about 4.5 here, the camera 3.6 to
// 10 away): auto answers some points by their summaries, fewer than "on", none at 48×36;
// the images are the same whatever the choice.
TEST(LightMesh, AutoSummariesOnlyWhereTheImageIsFineEnough) {
    Scene s = FloorScene();
    AddBox(&s, {-1, 0, -1}, {0.5f, 0.8f, 0.4f});
    s.render.lightMesh.cc = 400;
    auto accel = CreateAccelerator("grid", s.mesh);
    auto render = [&](int width, int height, const char* summaries) {
        s.render.width = width;
        s.render.height = height;
        s.render.lightMesh.variant = "consensus";
        s.render.lightMesh.cellSummaries = summaries;
        auto lmm = CreateShadowMethod("lmm", s, *accel, s.render);
        return WhittedRenderer(s, *accel, *lmm, s.render).Render();
    };
    const RenderResult on = render(320, 240, "on"), automatic = render(320, 240, "auto"), off = render(320, 240, "off");
    EXPECT_EQ(on.image.pixels, automatic.image.pixels);
    EXPECT_EQ(on.image.pixels, off.image.pixels);
    const uint64_t onPoints = Count(on.counters, Lmc::kUniformCellPoints);
    const uint64_t autoPoints = Count(automatic.counters, Lmc::kUniformCellPoints);
    EXPECT_GT(autoPoints, onPoints / 10);
    EXPECT_LT(autoPoints, onPoints - onPoints / 10);
    EXPECT_EQ(Count(render(48, 36, "auto").counters, Lmc::kUniformCellPoints), 0u);
    EXPECT_GT(Count(render(48, 36, "on").counters, Lmc::kUniformCellPoints), 0u);
}

// "auto" builds a cell patch only where the triangle's part of the cell meets at least as
// many camera rays as the cell has front triangles (LightMesh::PatchPays). A floor of two
// large triangles under six boxes: at 320×240 a cell (h 0.1) meets ~100 camera rays, more
// than any cell has front triangles, and "auto" keeps every patch "on" builds; at 120×90
// ~15, which the summaries still take (8 or more) but the cells among the boxes, with
// more front triangles, get no patch. The images are ОТ's whatever the choice.
TEST(LightMesh, AutoPatchesOnlyWhereTheyMeetEnoughRays) {
    Scene s = FloorScene(2.0f);
    AddBox(&s, {-0.5f, 0, -0.4f}, {0.3f, 0.7f, 0.3f});
    AddBox(&s, {0.1f, 0.9f, -0.2f}, {0.7f, 0.95f, 0.4f});  // floating: a penumbra on the floor
    for (int k = 0; k < 4; ++k) {  // small boxes around them: cells with 40-80 front triangles
        const float x = -0.8f + 0.45f * static_cast<float>(k);
        AddBox(&s, {x, 0, 0.45f}, {x + 0.12f, 0.15f, 0.57f});
    }
    s.lights = {{{-1.5f, 3, 1.5f}, Color(8.0f), Falloff::InverseSquare}, {{2.0f, 2.5f, -1.0f}, Color(6.0f), Falloff::InverseSquare}};
    s.camera = Camera{{0.5f, 2.5f, 3.0f}, {0, 0, 0}, {0, 1, 0}, 50.0f};
    s.render.lightMesh.cc = 40;
    auto accel = CreateAccelerator("grid", s.mesh);
    for (const int width : {320, 120}) {
        auto render = [&](const char* variant, const char* summaries) {
            Scene r = s;
            r.render.width = width;
            r.render.height = width * 3 / 4;
            r.render.lightMesh.variant = variant;
            r.render.lightMesh.cellSummaries = summaries;
            auto lmm = CreateShadowMethod("lmm", r, *accel, r.render);
            return WhittedRenderer(r, *accel, *lmm, r.render).Render();
        };
        const RenderResult ot = render("object", "auto"), on = render("consensus", "on"),
                           automatic = render("consensus", "auto");
        EXPECT_EQ(ot.image.pixels, on.image.pixels) << width;
        EXPECT_EQ(ot.image.pixels, automatic.image.pixels) << width;
        const uint64_t onPatch = Count(on.counters, Lmc::kPatchSegments);
        const uint64_t autoPatch = Count(automatic.counters, Lmc::kPatchSegments);
        const uint64_t notPaying = Count(automatic.counters, Lmc::kPatchesNotPaying);
        EXPECT_GT(onPatch, 0u) << width;
        EXPECT_EQ(Count(on.counters, Lmc::kPatchesNotPaying), 0u) << "\"on\" builds every patch";
        if (width == 320) {
            EXPECT_EQ(notPaying, 0u) << "every patch pays";
            EXPECT_EQ(autoPatch, onPatch);
        } else {
            EXPECT_GT(notPaying, 0u) << "the cells next to the boxes get none";
            EXPECT_LT(autoPatch, onPatch);
        }
        EXPECT_GT(Count(automatic.counters, Lmc::kUniformCellPoints), 0u) << width;  // the summaries still work
    }
}

// The summaries' tolerances follow the coordinates a cell computes with, not the scene's
// largest: small objects near the coordinates' origin of a scene that reaches 20 units
// away (a floor of small tiles) keep their blockers and cell patches, whose conditions
// (the origin clearly off the surface) a tolerance at the scene's scale refuses: the
// renderer's offset of a unit box's faces is 4e-6, four scene-wide tolerances 1.6e-5.
// The image stays ОТ's.
TEST(LightMesh, CellTolerancesFollowTheLocalCoordinates) {
    Scene s = FloorScene(1.0f);
    s.mesh = TriangleMesh{};
    for (int i = 0; i < 40; ++i)  // tiles of 0.5 over [-1, 19] x [-2, 2]
        for (int k = 0; k < 8; ++k) {
            const float x = -1 + 0.5f * static_cast<float>(i), z = -2 + 0.5f * static_cast<float>(k);
            const auto v = static_cast<uint32_t>(s.mesh.positions.size());
            s.mesh.positions.insert(s.mesh.positions.end(), {{x, 0, z}, {x + 0.5f, 0, z}, {x + 0.5f, 0, z + 0.5f}, {x, 0, z + 0.5f}});
            s.mesh.triangles.push_back({v, v + 2, v + 1});
            s.mesh.triangles.push_back({v, v + 3, v + 2});
            s.mesh.materialIds.insert(s.mesh.materialIds.end(), {0, 0});
        }
    AddBox(&s, {-0.4f, 0, -0.3f}, {0.3f, 0.6f, 0.2f});
    AddBox(&s, {0.5f, 0, 0.4f}, {0.8f, 1.1f, 0.7f});
    AddBox(&s, {0.1f, 0.75f, -0.2f}, {0.6f, 0.8f, 0.3f});  // floating: penumbrae on the boxes below
    s.lights = {{{-1.5f, 3, 1.5f}, Color(8.0f), Falloff::InverseSquare}, {{2.0f, 2.5f, -1.0f}, Color(6.0f), Falloff::InverseSquare}};
    s.camera = Camera{{1.2f, 1.6f, 2.2f}, {0.2f, 0.3f, 0}, {0, 1, 0}, 50.0f};
    s.render.lightMesh.cc = 400;  // h 0.05: the boxes span many cells
    for (const char* accelName : {"embree", "grid"}) {
        std::unique_ptr<Accelerator> accel;
        try {
            accel = CreateAccelerator(accelName, s.mesh);
        } catch (const Error&) {
            continue;  // built without Embree
        }
        EXPECT_EQ(RenderLmm(s, *accel, "object", "auto", 2.0f).image.pixels,
                  RenderLmm(s, *accel, "consensus", "on", 2.0f).image.pixels) << accelName;
    }
    auto accel = CreateAccelerator("grid", s.mesh);
    const RenderResult ot = RenderLmm(s, *accel, "object", "auto", 2.0f);
    const RenderResult fast = RenderLmm(s, *accel, "consensus", "on", 2.0f);
    // With the scene's tolerance no point here is planar and no segment is decided by
    // blockers or patches (measured: 0, 0, and 6,096 of ОТ's 21,056 segments traced);
    // with the cells' own, 2,007 points are planar and 329 segments are traced.
    EXPECT_GT(Count(fast.counters, Lmc::kPlanarCellPoints), Count(fast.counters, Lmc::kInterpolations) / 2);
    EXPECT_GT(Count(fast.counters, Lmc::kCulledSegments), 0u);
    EXPECT_GT(Count(fast.counters, Lmc::kPatchSegments), Count(fast.counters, Lmc::kLocalSegments));
    EXPECT_LT(Count(fast.counters, Lmc::kLocalSegments), Count(ot.counters, Lmc::kLocalSegments) / 20);
}

// The templates' front test runs eight entries at a time (AVX2) or four (SSE), the
// segment culling too: every variant's image and candidate count must equal the scalar
// front test's (simdWidth 1), on scenes where every case of the walks happens.
TEST(LightMesh, VectorisedFrontTestAndCullingMatchTheScalarOnes) {
    uint64_t candidates = 0;
    for (int index = 0; index < 5; ++index) {
        Scene s = SummaryTestScene(index);
        s.render.width = 64;
        s.render.height = 48;
        auto accel = CreateAccelerator("grid", s.mesh);
        for (float ki : {2.0f, 3.0f})
            for (const char* variant : {"none", "consensus", "reduced", "inside", "object", "templates"}) {
                if (testing::kSanitized && ki != 2.0f) continue;  // kI 3 in the Release build
                RenderResult results[3];
                const int widths[3] = {1, 4, 8};
                for (int w = 0; w < 3; ++w) {
                    s.render.lightMesh.ki = ki;
                    s.render.lightMesh.variant = variant;
                    s.render.lightMesh.simdWidth = widths[w];
                    auto lmm = CreateShadowMethod("lmm", s, *accel, s.render);
                    results[w] = WhittedRenderer(s, *accel, *lmm, s.render).Render();
                }
                const std::string what = StringPrintf("scene %d, kI %g, %s", index, ki, variant);
                for (int w = 1; w < 3; ++w) {
                    const RenderCounters &c0 = results[0].counters, &cw = results[w].counters;
                    EXPECT_EQ(results[0].image.pixels, results[w].image.pixels) << what << ", width " << widths[w];
                    EXPECT_EQ(Count(c0, Lmc::kCandidates), Count(cw, Lmc::kCandidates)) << what;
                    EXPECT_EQ(Count(c0, Lmc::kLocalSegments), Count(cw, Lmc::kLocalSegments)) << what;
                    // FindBlockers and the patch test: the AVX2 passes decide as the scalar ones.
                    EXPECT_EQ(Count(c0, Lmc::kCulledSegments), Count(cw, Lmc::kCulledSegments)) << what;
                    EXPECT_EQ(Count(c0, Lmc::kPatchSegments), Count(cw, Lmc::kPatchSegments)) << what;
                }
                candidates += Count(results[0].counters, Lmc::kCandidates);
            }
    }
    EXPECT_GT(candidates, 0u);
    Scene s = SummaryTestScene(0);
    s.render.lightMesh.simdWidth = 2;
    auto accel = CreateAccelerator("grid", s.mesh);
    EXPECT_THROW(CreateShadowMethod("lmm", s, *accel, s.render), Error);
}

// A file of huge overlapping triangles would make the brick lists enormous (every
// triangle's box covers every brick): the binning counts the pairs before storing any,
// turns the summaries off over its budget, and the image is still ОТ's.
TEST(LightMesh, CellSummariesTurnOffWhenTheBinningWouldBeHuge) {
    Scene s = FloorScene(1.0f);
    for (int t = 0; t < 40; ++t) {  // 40 thin diagonal triangles across the whole box
        const float o = 0.01f * static_cast<float>(t);
        const uint32_t v = static_cast<uint32_t>(s.mesh.positions.size());
        s.mesh.positions.push_back({-1, 0.02f + o, -1});
        s.mesh.positions.push_back({1, 2, 1 - o});
        s.mesh.positions.push_back({1 - o, 2, 1});
        s.mesh.triangles.push_back({v, v + 1, v + 2});
        s.mesh.materialIds.push_back(0);
    }
    auto accel = CreateAccelerator("grid", s.mesh);
    LightMeshOptions o;
    o.cc = 200;
    o.variant = "consensus";
    auto lmm = CreateLightMeshShadows(s, *accel, o);
    bool off = false;
    for (const auto& [name, value] : lmm->Figures())
        off |= name == "cell summaries" && value.rfind("off (", 0) == 0;
    EXPECT_TRUE(off);
    s.render.lightMesh.cc = 200;
    EXPECT_EQ(RenderLmm(s, *accel, "consensus", "auto", 2.0f).image.pixels,
              RenderLmm(s, *accel, "object", "auto", 2.0f).image.pixels);
}

// On an open floor far from any occluder every node sees every light: the summary answers
// the point (no walk, no segment) with RT's exact 1; in an umbra with 0.
TEST(LightMesh, CellSummaryAnswersOpenFloorWithoutSegments) {
    Scene s = FloorScene();
    AddBox(&s, {-1, 0, -1}, {1, 0.5f, 1});
    s.lights = {{{0, 6, 0}, Color(1.0f), Falloff::None}};
    auto accel = CreateAccelerator("grid", s.mesh);
    LightMeshOptions o;
    o.variant = "consensus";
    auto lmm = CreateLightMeshShadows(s, *accel, o);
    const uint32_t needed[1] = {0};
    for (const auto& [x, expected] : {std::pair{6.0f, 1.0f}, std::pair{8.5f, 1.0f}}) {
        float vis[64] = {};
        RenderCounters c;
        lmm->Visibility(FloorPoint(x, 0.3f), needed, vis, c);
        EXPECT_EQ(vis[0], expected) << x;
        EXPECT_EQ(Count(c, Lmc::kUniformCellPoints), 1u) << x;
        EXPECT_EQ(Count(c, Lmc::kPlanarCellPoints), 1u) << x;
        EXPECT_EQ(Count(c, Lmc::kLocalSegments), 0u) << x;
    }
    // On the box's top face, next to its edge: planar only if the reach stays on the face.
    float vis[64] = {};
    RenderCounters c;
    ShadingPoint top;
    top.p = Vec3(0.1f, 0.5f, 0.1f);
    top.n = Vec3(0, 1, 0);
    top.origin = Vec3(0.1f, 0.5f + 1e-5f, 0.1f);
    lmm->Visibility(top, needed, vis, c);
    EXPECT_EQ(vis[0], 1.0f);
}

// A cell's summary serves the points on its plane Π, whose spheres reach at most
// pointReach_ (r and half a sub-step) off Π: nodes of the cell's cube beyond that slab are
// neither evaluated nor compared, and a triangle wholly beyond it (a plate just above a
// floor's spheres) does not stop the planar argument. The image stays ОТ's.
TEST(LightMesh, CellSummariesLookOnlyAsFarAsTheirPlanesPointsReach) {
    Scene s = FloorScene();
    AddBox(&s, {5.0f, 0.46f, -1.0f}, {7.0f, 0.56f, 1.0f});      // the plate
    AddBox(&s, {-9.5f, -0.1f, -9.5f}, {-9.0f, -0.05f, -9.0f});  // puts the floor mid-cell
    s.lights = {{{0, 6, 0}, Color(1.0f), Falloff::None}};
    auto accel = CreateAccelerator("grid", s.mesh);
    LightMeshOptions o;
    o.variant = "consensus";
    auto lmm = CreateLightMeshShadows(s, *accel, o);
    const LightMeshLattice& L = lmm->Lattice();
    const float reach = L.r + L.h / 8 + 2e-3f * L.h;  // pointReach_ at ns 8, with room for its margin
    ASSERT_GT(0.46f, reach);
    const int ci = static_cast<int>(std::floor((6.0f - L.origin.x) / L.h));
    const int cj = static_cast<int>(std::floor((0.0f - L.origin.y) / L.h));
    const int ck = static_cast<int>(std::floor((0.3f - L.origin.z) / L.h));
    ASSERT_GT(L.Node(0, cj + 3, 0).y, reach);  // the cube's top layer is beyond every floor sphere
    ASSERT_LT(0.46f, L.Node(0, cj + 3, 0).y);  // and the plate within the cube's reach

    const uint32_t needed[1] = {0};
    float vis[64] = {};
    RenderCounters c;
    lmm->Visibility(FloorPoint(6.0f, 0.3f), needed, vis, c);
    EXPECT_EQ(Count(c, Lmc::kPlanarCellPoints), 1u);
    EXPECT_EQ(Count(c, Lmc::kLocalSegments), 0u);
    int beyond = 0;
    for (int k = ck - 2; k <= ck + 3; ++k)
        for (int j = cj - 2; j <= cj + 3; ++j)
            for (int i = ci - 2; i <= ci + 3; ++i)
                if (L.Node(i, j, k).y > reach) {
                    ++beyond;
                    EXPECT_FALSE(lmm->IsEvaluated(L.Index(i, j, k))) << i << " " << j << " " << k;
                }
    EXPECT_GT(beyond, 0);

    LightMeshOptions ot = o;
    ot.variant = "object";
    auto object = CreateLightMeshShadows(s, *accel, ot);
    float visObject[64] = {};
    RenderCounters co;
    object->Visibility(FloorPoint(6.0f, 0.3f), needed, visObject, co);
    EXPECT_EQ(vis[0], visObject[0]);
    EXPECT_LT(vis[0], 1.0f);  // the plate's shadow reaches the point's sphere

    s.camera = Camera{{6, 3, 4}, {6, 0, 0}, {0, 1, 0}, 50.0f};
    const RenderResult objectImage = RenderLmm(s, *accel, "object", "auto", 2.0f);
    const RenderResult consensusImage = RenderLmm(s, *accel, "consensus", "auto", 2.0f);
    EXPECT_EQ(objectImage.image.pixels, consensusImage.image.pixels);
    EXPECT_GT(Count(consensusImage.counters, Lmc::kPlanarCellPoints), 0u);
}

// У (§3.2) skips the inner nodes' segments only when every boundary node sees P; when no
// occluder lies inside any sphere that is always the case, so У gives Ш's image exactly.
TEST(LightMesh, ReducedEqualsTemplatesWithoutOccludersInSpheres) {
    Scene s = FloorScene();
    AddBox(&s, {-1, 2, -1}, {1, 2.3f, 1});  // a convex occluder far above the floor
    s.render.width = 64;
    s.render.height = 48;
    auto accel = CreateAccelerator("grid", s.mesh);
    RenderResult results[2];
    int n = 0;
    for (const char* variant : {"templates", "reduced"}) {
        s.render.lightMesh.variant = variant;
        auto lmm = CreateShadowMethod("lmm", s, *accel, s.render);
        results[n++] = WhittedRenderer(s, *accel, *lmm, s.render).Render();
    }
    EXPECT_EQ(results[0].image.pixels, results[1].image.pixels);
    EXPECT_LT(Count(results[1].counters, Lmc::kLocalSegments), Count(results[0].counters, Lmc::kLocalSegments));
    // And the occluder does cast a shadow: this is not a trivially lit image.
    EXPECT_GT(Count(results[0].counters, Lmc::kInterpolations), 0u);
}

// СТ (§4) marks exactly the nodes inside closed solids, also when the segments it counts
// crossings on pass exactly through mesh vertices and edges.
TEST(LightMesh, InsideFlagsMatchClosedSolids) {
    struct Solid {
        const char* name;
        std::function<void(Scene*)> add;
        std::function<bool(const Vec3&)> inside;
        std::function<float(const Vec3&)> distanceToSurface;
        Vec3 light;
    };
    const Vec3 c(0.05f, 1.3f, -0.15f);
    const Solid solids[] = {
        {"box",
         [](Scene* s) { AddBox(s, {-1.02f, 0.51f, -0.77f}, {1.13f, 2.47f, 0.88f}); },
         [](const Vec3& p) { return p.x > -1.02f && p.x < 1.13f && p.y > 0.51f && p.y < 2.47f && p.z > -0.77f && p.z < 0.88f; },
         [](const Vec3& p) {
             return std::min({std::abs(p.x + 1.02f), std::abs(p.x - 1.13f), std::abs(p.y - 0.51f),
                              std::abs(p.y - 2.47f), std::abs(p.z + 0.77f), std::abs(p.z - 0.88f)});
         },
         // On the line through the box's centre and its corner (1.13, 2.47, 0.88): the
         // segment from the centre to the light leaves through that vertex.
         Vec3(0.055f, 1.49f, 0.055f) + (Vec3(1.13f, 2.47f, 0.88f) - Vec3(0.055f, 1.49f, 0.055f)) * 4.0f},
        {"sphere",
         [c](Scene* s) {
             if (s->materials.size() < 2) s->materials.push_back({"ball", Color(0.7f), Color(0.0f), 1.0f, Color(0.0f)});
             ShapeBuilder(&s->mesh).Sphere(c, 1.1f, 12, 16, 1);
         },
         [c](const Vec3& p) { return Length(p - c) < 1.1f; },
         [c](const Vec3& p) { return std::abs(Length(p - c) - 1.1f); },
         c + Vec3(0, 6, 0)},  // straight above the pole: segments from below run through it
    };
    for (const Solid& solid : solids) {
        Scene s = FloorScene(3.0f);
        solid.add(&s);
        s.lights = {{solid.light, Color(1.0f), Falloff::None}};
        Lmm lmm(s, 24, 2.0f, "inside");
        const LightMeshLattice& L = lmm.lmm->Lattice();
        int checked = 0, insideCount = 0;
        for (uint64_t idx = 0; idx < L.NodeCount(); ++idx) {
            const Vec3 x = L.NodeAt(idx);
            // The tessellated sphere differs from the true one by up to ~4 % of its radius.
            if (solid.distanceToSurface(x) < 0.06f || std::abs(x.y) < 1e-3f || x.y < -0.03f) continue;
            const bool expected = solid.inside(x);
            EXPECT_EQ(lmm.lmm->NodeInside(idx), expected) << solid.name << " node " << x.x << "," << x.y << "," << x.z;
            ++checked;
            insideCount += expected;
        }
        EXPECT_GT(insideCount, 20) << solid.name;
        EXPECT_GT(checked, 1000) << solid.name;
        // The other variants do not compute the flag.
        Lmm reduced(s, 24, 2.0f, "reduced");
        EXPECT_FALSE(reduced.lmm->NodeInside(L.Index(L.nx / 2, L.ny / 2, L.nz / 2)));
    }
}

// What СТ is for (§4, Fig. 5): nodes inside a solid are dark (their shadow rays must leave
// the solid), so on a lit floor right next to a box, the nodes inside the box darken the
// floor with no local-visibility test ("Нет"). СТ drops them and gives full light, as RT.
TEST(LightMesh, InsideFlagsRemoveDarkeningAtJunctions) {
    Scene s = FloorScene();
    AddBox(&s, {-1, 0, -1}, {1, 1.5f, 1});
    s.lights = {{{0.3f, 9, 8}, Color(1.0f), Falloff::None}};  // lights the box's +z side and the floor there
    Lmm none(s, 100, 2.0f, "none"), inside(s, 100, 2.0f, "inside");
    const float r = inside.lmm->Lattice().r;
    const ShadingPoint sp = FloorPoint(0.1f, 1.0f + 0.3f * r);  // within r of the box's lit face
    ASSERT_TRUE(LightVisible(*inside.accel, sp.origin, s.lights[0].position));
    EXPECT_LT(none.Vis(sp), 1.0f);
    EXPECT_EQ(inside.Vis(sp), 1.0f);
}

TEST(LightMesh, ImagesAreIdenticalForAnyThreadCount) {
    Scene s = MakeBuiltinScene("gazebo");
    s.render.width = 96;
    s.render.height = 72;
    auto accel = CreateAccelerator("grid", s.mesh);
    std::vector<std::pair<std::string, std::string>> cases;
    for (const std::string& variant : LightMeshVariantNames()) cases.push_back({variant, "auto"});
    cases.push_back({"none", "on"});  // the cell summaries of Нет and СТ too
    cases.push_back({"inside", "on"});
    for (const auto& [variant, summaries] : cases) {
        s.render.lightMesh.variant = variant;
        s.render.lightMesh.cellSummaries = summaries;
        RenderResult one, many;
        uint64_t nodesOne = 0, nodesMany = 0;
        tbb::task_arena(1).execute([&] {
            auto lmm = CreateShadowMethod("lmm", s, *accel, s.render);
            one = WhittedRenderer(s, *accel, *lmm, s.render).Render();
            nodesOne = static_cast<LightMeshShadows&>(*lmm).NodesEvaluated();
        });
        tbb::task_arena(4).execute([&] {
            auto lmm = CreateShadowMethod("lmm", s, *accel, s.render);
            many = WhittedRenderer(s, *accel, *lmm, s.render).Render();
            nodesMany = static_cast<LightMeshShadows&>(*lmm).NodesEvaluated();
        });
        EXPECT_EQ(one.image.pixels, many.image.pixels) << variant;
        EXPECT_EQ(nodesOne, nodesMany) << variant;
        EXPECT_EQ(Count(one.counters, Lmc::kLocalSegments), Count(many.counters, Lmc::kLocalSegments)) << variant;
        EXPECT_EQ(Count(one.counters, Lmc::kUniformCellPoints), Count(many.counters, Lmc::kUniformCellPoints))
            << variant;
        EXPECT_EQ(Count(one.counters, Lmc::kCulledSegments), Count(many.counters, Lmc::kCulledSegments)) << variant;
        EXPECT_EQ(Count(one.counters, Lmc::kPatchSegments), Count(many.counters, Lmc::kPatchSegments)) << variant;
    }
}

TEST(LightMesh, UnknownVariantIsAnError) {
    EXPECT_THROW(ParseLightMeshVariant("fastest"), Error);
    EXPECT_EQ(ParseLightMeshVariant("").name, kDefaultLightMeshVariant);
    EXPECT_EQ(ParseLightMeshVariant("grid-none").local, LocalVisibility::None);
    // The paper's names and their transliterations name the same variants.
    EXPECT_EQ(ParseLightMeshVariant("СТ").name, "inside");
    EXPECT_EQ(ParseLightMeshVariant("st").name, "inside");
    EXPECT_EQ(ParseLightMeshVariant("Ш").name, "templates");
    EXPECT_EQ(ParseLightMeshVariant("У").local, LocalVisibility::Reduced);
    EXPECT_EQ(ParseLightMeshVariant("Нет").local, LocalVisibility::None);
    EXPECT_EQ(ParseLightMeshVariant("ОТ").enumeration, SphereEnumeration::Templates);
    EXPECT_EQ(ParseLightMeshVariant("Grid").enumeration, SphereEnumeration::Cube);
}

}  // namespace
}  // namespace light_mesh_test
}  // namespace lm
