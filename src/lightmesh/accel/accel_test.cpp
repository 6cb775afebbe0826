// accel_test.cpp -- the grid and Embree back-ends against brute force, ray by ray. Over
// 500 lines as one concept: the differential cases, scene by scene.
#include <gtest/gtest.h>

#include <random>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/accel/brute_force.h"
#include "support/accel_scenes.h"
#include "support/sanitized.h"
#include "lightmesh/geometry/triangle.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/parallel.h"

namespace lm {
namespace accel_test {
namespace {

namespace ts = testing_scenes;

bool HasEmbree() {
#ifdef LIGHTMESH_HAS_EMBREE
    return true;
#else
    return false;
#endif
}

struct NamedScene {
    std::string name;
    TriangleMesh mesh;
};

// The scenes, built once. Sizes keep brute force (the slow side) to a few seconds in all.
const NamedScene& GetScene(const std::string& name) {
    static std::mutex mutex;
    static std::map<std::string, std::unique_ptr<NamedScene>> cache;
    std::lock_guard<std::mutex> lock(mutex);
    auto& slot = cache[name];
    if (!slot) {
        slot = std::make_unique<NamedScene>();
        slot->name = name;
        if (name == "soup")
            slot->mesh = ts::Soup(1500, 1);
        else if (name == "heightfield")
            slot->mesh = ts::HeightField(28, 2);
        else if (name == "longthin")
            slot->mesh = ts::LongThin(600, 3);
        else if (name == "onecell")
            slot->mesh = ts::OneCell(1500, 4);
        else if (name == "sphere")
            slot->mesh = ts::Sphere(24, 32);
        else if (name == "box")
            slot->mesh = ts::TessellatedBox(8);
        else if (name == "stadium")
            slot->mesh = ts::TeapotInStadium(48, 64);
        else
            ADD_FAILURE() << "no scene " << name;
    }
    return *slot;
}

// "grid-sse" is the grid with its 4-wide triangle test (the 8-wide one is the default
// where the processor has AVX2): both must give brute force's answers bit for bit.
std::unique_ptr<Accelerator> MakeAccel(const std::string& name, const TriangleMesh& mesh) {
    if (name == "grid-sse") {
        AccelOptions options;
        options.gridSimdWidth = 4;
        return CreateAccelerator("grid", mesh, options);
    }
    return CreateAccelerator(name, mesh);
}

// ---------------------------------------------------------------------------------------
// Rays

using ts::MakeRays;
using ts::TestRay;

std::string RayString(const Ray& r) {
    return StringPrintf("Ray{o=(%a, %a, %a), d=(%a, %a, %a), tMin=%a, tMax=%a}", r.o.x, r.o.y,
                        r.o.z, r.d.x, r.d.y, r.d.z, r.tMin, r.tMax);
}

// What brute force says about one ray (and about the same ray stopped just before its hit).
struct Expected {
    bool hit = false;
    Hit h;
    bool occluded = false;
    int crossings = 0;
    Ray shortened;  // tMax = 0.99·t (only when hit)
    bool shortOccluded = false;
    int shortCrossings = 0;
};

struct Reference {
    std::vector<TestRay> rays;
    std::vector<Expected> expected;
};

constexpr int kRaysPerScene = 10000;
using lm::testing::SweepCases;

// Under the sanitizers each back-end's test process computes the brute-force reference
// again (every ray against every triangle: 10-15 s of CI's time per test at 10,000 rays), so
// it gets a third of the rays, and a twelfth on the stadium's 196k triangles. The rays cycle
// through their nine kinds, so each kind keeps its share. The Release run keeps them all.
int RaysFor(const std::string& sceneName) {
    return SweepCases(kRaysPerScene, sceneName == "stadium" ? 12 : 3);
}

const Reference& GetReference(const std::string& sceneName) {
    static std::mutex mutex;
    static std::map<std::string, std::unique_ptr<Reference>> cache;
    std::lock_guard<std::mutex> lock(mutex);
    auto& slot = cache[sceneName];
    if (!slot) {
        const TriangleMesh& mesh = GetScene(sceneName).mesh;
        slot = std::make_unique<Reference>();
        slot->rays = MakeRays(mesh, RaysFor(sceneName), 1234u + uint32_t(sceneName.size()));
        slot->expected.resize(slot->rays.size());
        BruteForceAccel brute(mesh);
        ParallelFor(size_t(0), slot->rays.size(), [&](size_t i) {
            const Ray& r = slot->rays[i].ray;
            Expected& e = slot->expected[i];
            e.hit = brute.Intersect(r, &e.h);
            e.occluded = brute.Occluded(r);
            e.crossings = brute.CountCrossings(r);
            if (e.hit) {
                e.shortened = r;
                e.shortened.tMax = 0.99f * e.h.t;
                e.shortOccluded = brute.Occluded(e.shortened);
                e.shortCrossings = brute.CountCrossings(e.shortened);
            }
        });
    }
    return *slot;
}

// The t of the ray with the plane of triangle `prim` (for judging Embree's ties).
float PlaneT(const TriangleMesh& mesh, uint32_t prim, const Ray& r) {
    const Vec3 p0 = mesh.Vertex(prim, 0), p1 = mesh.Vertex(prim, 1), p2 = mesh.Vertex(prim, 2);
    const Vec3 n = TriangleNormal(p0, p1, p2);
    return Dot(n, p0 - r.o) / Dot(n, r.d);
}

// Distance from the ray's line to the segment ab, in double.
double LineSegmentDistance(const Ray& r, const Vec3& a, const Vec3& b) {
    const double o[3] = {r.o.x, r.o.y, r.o.z}, d[3] = {r.d.x, r.d.y, r.d.z};
    const double pa[3] = {a.x, a.y, a.z},
                 u[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z};
    auto dot = [](const double* x, const double* y) {
        return x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
    };
    double w[3] = {pa[0] - o[0], pa[1] - o[1], pa[2] - o[2]};
    const double uu = dot(u, u), uv = dot(u, d), vv = dot(d, d), uw = dot(u, w), vw = dot(d, w);
    const double den = uu * vv - uv * uv;
    double s = den > 1e-30 * uu * vv ? (uv * vw - vv * uw) / den : 0.0;
    s = std::clamp(s, 0.0, 1.0);
    double q[3] = {w[0] + s * u[0], w[1] + s * u[1], w[2] + s * u[2]};  // segment point - o
    const double t = dot(q, d) / vv;
    for (int k = 0; k < 3; ++k) q[k] -= t * d[k];
    return std::sqrt(dot(q, q));
}

// Whether Embree's closest hit (he, e) and brute force's (hb, b) differ only because the
// ray grazes a triangle's boundary or starts on a surface: the first hit of one side is on a
// triangle whose boundary passes within 1e-5 of the scene's size from the ray's line (for
// Embree's, one IntersectTriangle does not hit at all), or is at the ray's start.
bool Grazes(const TriangleMesh& mesh, const Ray& r, bool hb, const Hit& b, bool he, const Hit& e,
            float tol) {
    const double near = 1e-5 * Length(mesh.Bounds().Diagonal());
    auto onBoundary = [&](const Hit& h) {
        const Vec3 p0 = mesh.Vertex(h.prim, 0), p1 = mesh.Vertex(h.prim, 1),
                   p2 = mesh.Vertex(h.prim, 2);
        return std::min({LineSegmentDistance(r, p0, p1), LineSegmentDistance(r, p1, p2),
                         LineSegmentDistance(r, p2, p0)}) <= near;
    };
    auto atStart = [&](const Hit& h) { return h.t - r.tMin <= tol; };
    if (he && (!hb || e.t < b.t)) {
        TriangleHit th;
        const bool ours = IntersectTriangle(r, mesh.Vertex(e.prim, 0), mesh.Vertex(e.prim, 1),
                                            mesh.Vertex(e.prim, 2), &th);
        return !ours && (onBoundary(e) || atStart(e));
    }
    if (hb && (!he || b.t < e.t)) return onBoundary(b) || atStart(b);
    return false;
}

// ---------------------------------------------------------------------------------------
// The differential test

struct AccelCase {
    std::string accel;
    std::string scene;
};

void PrintTo(const AccelCase& c, std::ostream* os) { *os << c.accel << " on " << c.scene; }

std::string CaseName(const ::testing::TestParamInfo<AccelCase>& info) {
    std::string name = info.param.accel + "_" + info.param.scene;
    std::replace(name.begin(), name.end(), '-', '_');
    return name;
}

class AccelDifferentialTest : public ::testing::TestWithParam<AccelCase> {};

TEST_P(AccelDifferentialTest, MatchesBruteForce) {
    const AccelCase& c = GetParam();
    if (c.accel == "embree" && !HasEmbree()) GTEST_SKIP() << "built without Embree";
    const TriangleMesh& mesh = GetScene(c.scene).mesh;
    const Reference& ref = GetReference(c.scene);
    const auto accel = MakeAccel(c.accel, mesh);
    // Our back-ends run the very same IntersectTriangle, so they must agree bit for bit.
    // Embree computes t its own way: a relative tolerance, and a different triangle is
    // accepted only as a tie (its plane is hit at the same t within tolerance).
    const bool exact = c.accel != "embree";
    const float radius = Length(mesh.Bounds().Diagonal());

    int failures = 0, grazes = 0;
    std::string first;
    auto fail = [&](size_t i, const std::string& what) {
        if (failures++ == 0)
            first = StringPrintf("ray %zu (%s): %s\n  %s", i, ref.rays[i].kind, what.c_str(),
                                 RayString(ref.rays[i].ray).c_str());
    };
    for (size_t i = 0; i < ref.rays.size(); ++i) {
        const Ray& r = ref.rays[i].ray;
        const Expected& e = ref.expected[i];
        const float tol = exact ? 0.0f : 1e-4f * (std::abs(e.h.t) + radius / Length(r.d));
        Hit h;
        const bool hit = accel->Intersect(r, &h);
        bool same = hit == e.hit;
        if (same && hit) {
            same = std::abs(h.t - e.h.t) <= tol;
            // A different triangle is fine for Embree at a tie: its plane is hit at that t.
            if (same && h.prim != e.h.prim)
                same = !exact && std::abs(PlaneT(mesh, h.prim, r) - e.h.t) <= tol;
            // Ours give brute force's barycentrics too, bit for bit (shading interpolates
            // normals with them; the grid's filter computes them for its nearest hit).
            if (same && exact) same = h.b1 == e.h.b1 && h.b2 == e.h.b2;
        }
        // Embree's edges are inclusive and its arithmetic is its own: a ray aimed exactly at
        // a vertex, or starting on a face, may hit a triangle there that IntersectTriangle
        // misses (or the reverse). Accepted for those two kinds of ray only, and only when
        // the hit in question lies on the triangle's boundary or at the ray's start.
        const bool grazeKind = std::string(ref.rays[i].kind) == "at a vertex" ||
                               std::string(ref.rays[i].kind) == "on box boundary";
        const bool graze = !same && !exact && grazeKind && Grazes(mesh, r, e.hit, e.h, hit, h, tol);
        if (graze) ++grazes;
        if (!same && !graze)
            fail(i, StringPrintf("Intersect %d t=%a prim %u b1=%a b2=%a, brute force %d t=%a prim %u b1=%a b2=%a", hit,
                                 h.t, h.prim, h.b1, h.b2, e.hit, e.h.t, e.h.prim, e.h.b1, e.h.b2));
        const bool occ = accel->Occluded(r);
        if (occ != e.occluded && !graze)
            fail(i, StringPrintf("Occluded %d, brute force %d", occ, e.occluded));
        // Crossing counts are exact for every back-end and every ray.
        const int n = accel->CountCrossings(r);
        if (n != e.crossings)
            fail(i, StringPrintf("CountCrossings %d, brute force %d", n, e.crossings));
        if (e.hit) {
            const bool so = accel->Occluded(e.shortened);
            const int sn = accel->CountCrossings(e.shortened);
            if ((so != e.shortOccluded && !graze) || sn != e.shortCrossings)
                fail(i, StringPrintf(
                            "with tMax=0.99t=%a: Occluded %d (brute %d), crossings %d (brute %d)",
                            e.shortened.tMax, so, e.shortOccluded, sn, e.shortCrossings));
        }
    }
    EXPECT_EQ(failures, 0) << c.accel << " on " << c.scene << ", " << mesh.TriangleCount()
                           << " triangles: " << failures << " of " << ref.rays.size()
                           << " rays differ; first: " << first;
    if (grazes)
        std::printf("  %s on %s: %d grazing rays hit in one test only\n", c.accel.c_str(),
                    c.scene.c_str(), grazes);
}

std::vector<AccelCase> DifferentialCases() {
    std::vector<AccelCase> cases;
    for (const char* a : {"grid", "grid-sse", "embree"})
        for (const char* s : {"soup", "heightfield", "longthin", "onecell", "sphere", "box", "stadium"})
            cases.push_back({a, s});
    return cases;
}

INSTANTIATE_TEST_SUITE_P(Accel, AccelDifferentialTest, ::testing::ValuesIn(DifferentialCases()),
                         CaseName);

// ---------------------------------------------------------------------------------------
// Parity through exact shared edges and vertices of closed meshes

class AccelParityTest : public ::testing::TestWithParam<std::string> {
  protected:
    void SetUp() override {
        if (GetParam() == "embree" && !HasEmbree()) GTEST_SKIP() << "built without Embree";
    }
};

// A segment from an outside point to an inside point crosses a closed surface an odd number
// of times, and one between two outside points an even number: even when it passes exactly
// through a shared vertex or edge, thanks to IntersectTriangle's tie-break. Directions are
// axis-parallel or dyadic, so "exactly" holds in float arithmetic too.
struct ParityCheck {
    explicit ParityCheck(const Accelerator& a) : accel(a) {}
    const Accelerator& accel;
    int checked = 0, failures = 0;
    std::string first;
    void Expect(const Vec3& a, const Vec3& b, bool odd, const char* what) {
        const Ray r = Segment(a, b);
        const int n = accel.CountCrossings(r);
        ++checked;
        if ((n % 2 == 1) != odd && failures++ == 0)
            first = StringPrintf("%s: %d crossings, expected %s\n  %s", what, n,
                                 odd ? "odd" : "even", RayString(r).c_str());
    }
};

TEST_P(AccelParityTest, SphereThroughVerticesAndPoles) {
    const TriangleMesh& mesh = GetScene("sphere").mesh;
    const auto accel = MakeAccel(GetParam(), mesh);
    ParityCheck check(*accel);
    // Along z through the poles: both pole fans are hit exactly at their common vertex.
    check.Expect({0, 0, -3}, {0, 0, 0}, true, "south pole to centre");
    check.Expect({0, 0, -3}, {0, 0, 3}, false, "through both poles");
    check.Expect({0, 0, 3}, {0, 0, 0.5f}, true, "north pole to inside");
    // Axis-parallel through every vertex: for a direction e_a the ray's 2D frame is exactly
    // the other two coordinates, so each vertex is hit exactly. The closest point of the line
    // to the centre is inside when it is well within the inscribed sphere (0.99 for 24x32).
    for (const Vec3& v : mesh.positions)
        for (int a = 0; a < 3; ++a) {
            Vec3 mid = v;
            mid[a] = 0;
            if (Length(mid) > 0.9f) continue;  // tangent-ish lines: no clear inside point
            Vec3 from = v, to = v;
            from[a] = -3;
            to[a] = 3;
            check.Expect(from, mid, true, "outside to inside through a vertex");
            check.Expect(from, to, false, "outside to outside through a vertex");
            check.Expect(to, mid, true, "outside to inside through a vertex (reversed)");
        }
    EXPECT_GT(check.checked, 1000);
    EXPECT_EQ(check.failures, 0) << check.failures << " of " << check.checked
                                 << "; first: " << check.first;
}

TEST_P(AccelParityTest, BoxThroughEdgesAndVertices) {
    const TriangleMesh& mesh = GetScene("box").mesh;  // [-1, 1]³, 8 × 8 quads a face
    const auto accel = MakeAccel(GetParam(), mesh);
    ParityCheck check(*accel);
    // Points on the x = -1 face at multiples of 1/16: vertices (multiples of 1/4), edge
    // midpoints of the axis-aligned edges and of the quad diagonals, and face interiors;
    // the box's own edges (|y| or |z| = 1) are left out, where the ray would graze a face.
    for (int j = -15; j <= 15; ++j)
        for (int k = -15; k <= 15; ++k) {
            const float y = float(j) / 16, z = float(k) / 16;
            for (int a = 0; a < 3; ++a) {
                // Permute so the crossing axis is a.
                auto place = [&](Vec3 v, float along) {
                    Vec3 q;
                    q[a] = along;
                    q[(a + 1) % 3] = v.y;
                    q[(a + 2) % 3] = v.z;
                    return q;
                };
                const Vec3 yz(0, y, z);
                check.Expect(place(yz, -3), place(yz, 0.125f), true, "axis-parallel, out to in");
                check.Expect(place(yz, -3), place(yz, 3), false, "axis-parallel, out to out");
                check.Expect(place(yz, 3), place(yz, -0.5f), true, "axis-parallel, in from +side");
                // Dyadic skew direction (1, 1/2, 1/4) through the face point: the shear
                // factors are exact, so vertices and edges are still hit exactly.
                const Vec3 d = place(Vec3(0, 0.5f, 0.25f), 1.0f);
                const Vec3 onFace = place(yz, -1);
                const Vec3 o = onFace - d * 0.5f, inPt = onFace + d * 0.25f;
                const Vec3 outPt = onFace + d * 4.0f;
                auto isInside = [](const Vec3& q) {
                    return std::abs(q.x) < 1 && std::abs(q.y) < 1 && std::abs(q.z) < 1;
                };
                auto isOutside = [](const Vec3& q) {
                    return std::abs(q.x) > 1 || std::abs(q.y) > 1 || std::abs(q.z) > 1;
                };
                if (isInside(inPt)) check.Expect(o, inPt, true, "skew, out to in");
                // The far end must leave through a face interior or a shared edge of the
                // tessellation, not graze the box's outer edge: keep it well outside.
                if (isOutside(outPt)) check.Expect(o, outPt, false, "skew, out to out");
            }
        }
    EXPECT_GT(check.checked, 5000);
    EXPECT_EQ(check.failures, 0) << check.failures << " of " << check.checked
                                 << "; first: " << check.first;
}

TEST_P(AccelParityTest, RandomSegmentsThroughClosedMeshes) {
    // Generic segments: from outside the bounding sphere to points well inside (odd), and
    // between two outside points (even).
    for (const char* name : {"sphere", "box"}) {
        const TriangleMesh& mesh = GetScene(name).mesh;
        const auto accel = MakeAccel(GetParam(), mesh);
        ParityCheck check(*accel);
        ts::Rng rng(77);
        for (int i = 0; i < 2000; ++i) {
            const Vec3 out = rng.Direction() * rng.Uniform(2.0f, 5.0f);
            const Vec3 in = rng.Direction() * rng.Uniform(0.0f, 0.95f);
            const Vec3 out2 = rng.Direction() * rng.Uniform(2.0f, 5.0f);
            check.Expect(out, in, true, "outside to inside");
            check.Expect(out, out2, false, "outside to outside");
        }
        EXPECT_EQ(check.failures, 0) << name << ": " << check.failures << " of " << check.checked
                                     << "; first: " << check.first;
    }
}

INSTANTIATE_TEST_SUITE_P(Accel, AccelParityTest, ::testing::Values("brute", "grid", "grid-sse", "embree"),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                             std::string name = info.param;
                             std::replace(name.begin(), name.end(), '-', '_');
                             return name;
                         });

// ---------------------------------------------------------------------------------------
// Scale: the same scene a million times larger and smaller, and far from the origin.

TEST(AccelScale, HugeAndTinyScenesMatchBruteForce) {
    for (const char* accelName : {"grid", "embree"}) {
        if (std::string(accelName) == "embree" && !HasEmbree()) continue;
        for (float scale : {1e6f, 1e-6f}) {
            for (const Vec3 offset :
                 {Vec3(0.0f), Vec3(3.0f * scale, -7.0f * scale, 11.0f * scale)}) {
                const TriangleMesh mesh = ts::Transformed(ts::Soup(300, 9), scale, offset);
                BruteForceAccel brute(mesh);
                const auto accel = CreateAccelerator(accelName, mesh);
                const auto rays = MakeRays(mesh, 2000, 99);
                int failures = 0;
                std::string first;
                const bool exact = std::string(accelName) == "grid";
                const float radius = Length(mesh.Bounds().Diagonal());
                for (const TestRay& tr : rays) {
                    const Ray& r = tr.ray;
                    bool ok = accel->CountCrossings(r) == brute.CountCrossings(r);
                    // Embree's own hits are compared on rays that graze nothing by design.
                    const std::string kind = tr.kind;
                    if (exact || (kind != "at a vertex" && kind != "on box boundary")) {
                        Hit a, b;
                        const bool ha = accel->Intersect(r, &a), hb = brute.Intersect(r, &b);
                        const float tol =
                            exact ? 0.0f : 1e-4f * (std::abs(b.t) + radius / Length(r.d));
                        ok = ok && ha == hb && accel->Occluded(r) == brute.Occluded(r);
                        if (ok && ha)
                            ok = std::abs(a.t - b.t) <= tol &&
                                 (a.prim == b.prim ||
                                  (!exact && std::abs(PlaneT(mesh, a.prim, r) - b.t) <= tol));
                    }
                    if (!ok && failures++ == 0) first = kind + " " + RayString(r);
                }
                EXPECT_EQ(failures, 0) << accelName << " at scale " << scale << ": first " << first;
            }
        }
    }
}

// Queries are const and thread-safe: the same answers from a TBB loop as from one thread,
// including Embree's crossing-count scene, built lazily by whichever thread comes first.
TEST(AccelThreads, ConcurrentQueriesMatchSerial) {
    const TriangleMesh& mesh = GetScene("sphere").mesh;
    const auto rays = MakeRays(mesh, 20000, 5);
    for (const char* name : {"grid", "embree"}) {
        if (std::string(name) == "embree" && !HasEmbree()) continue;
        const auto parallel = CreateAccelerator(name, mesh);
        std::vector<int> counts(rays.size());
        std::vector<Hit> hits(rays.size());
        ParallelFor(size_t(0), rays.size(), [&](size_t i) {
            counts[i] = parallel->CountCrossings(rays[i].ray);
            parallel->Intersect(rays[i].ray, &hits[i]);
        });
        const auto serial = CreateAccelerator(name, mesh);
        int differ = 0;
        for (size_t i = 0; i < rays.size(); ++i) {
            Hit h;
            serial->Intersect(rays[i].ray, &h);
            differ += serial->CountCrossings(rays[i].ray) != counts[i] || h.prim != hits[i].prim ||
                      h.t != hits[i].t;
        }
        EXPECT_EQ(differ, 0) << name;
    }
}

// OccludedMany (a few coherent rays at once, Embree's packets) against Occluded ray by ray:
// bundles of 1 to 13 rays from one point to a small disc, as the light's disc sends them,
// some with an empty range. Brute force and the grid keep the default (exactly Occluded);
// Embree's packet kernels may round a grazing ray otherwise, which random rays do not meet.
TEST(AccelBatch, OccludedManyMatchesOccludedRayByRay) {
    for (const char* sceneName : {"sphere", "soup"}) {
        const TriangleMesh& mesh = GetScene(sceneName).mesh;
        const Bounds3 box = mesh.Bounds();
        for (const char* name : {"brute", "grid", "embree"}) {
            if (std::string(name) == "embree" && !HasEmbree()) continue;
            const auto accel = CreateAccelerator(name, mesh);
            std::mt19937 rng(17);
            std::uniform_real_distribution<float> u(-0.25f, 1.25f), unit(-1.0f, 1.0f);
            auto inBox = [&] {
                const Vec3 d = box.Diagonal();
                return box.lo + Vec3(u(rng) * d.x, u(rng) * d.y, u(rng) * d.z);
            };
            int rays = 0, differ = 0, blocked = 0;
            for (int bundle = 0; bundle < 400; ++bundle) {
                const size_t n = 1 + static_cast<size_t>(bundle % 13);
                const Vec3 origin = inBox(), target = inBox();
                const float spread = 0.02f * Length(box.Diagonal());
                std::vector<Ray> batch(n);
                for (size_t k = 0; k < n; ++k) {
                    const Vec3 to = target + Vec3(unit(rng), unit(rng), unit(rng)) * spread - origin;
                    batch[k] = Ray{origin, to, 0.0f, 1.0f - 1e-5f};
                    if (bundle % 7 == 3 && k == n / 2) batch[k].tMin = 2.0f;  // an empty range
                }
                std::unique_ptr<bool[]> many(new bool[n]);
                accel->OccludedMany(batch.data(), n, many.get());
                for (size_t k = 0; k < n; ++k, ++rays) {
                    const bool one = accel->Occluded(batch[k]);
                    differ += one != many[k];
                    blocked += one;
                    if (batch[k].tMin > batch[k].tMax) {
                        EXPECT_FALSE(many[k]) << name;
                    }
                }
            }
            EXPECT_GT(blocked, rays / 10) << sceneName << " " << name;
            EXPECT_LT(blocked, rays - rays / 10) << sceneName << " " << name;
            EXPECT_EQ(differ, 0) << sceneName << " " << name << ": " << differ << " of " << rays;
        }
    }
}

// The light mesh hands local-visibility segments to OccludedMany in batches of up to 16
// (MinorityFirst) while ОТ and the first segments of a point go one by one, and consensus
// promises ОТ's image bit for bit: so a segment must get the same answer in a packet,
// whatever its companions, as alone. Embree's packet and single-ray kernels share the
// triangle test's operations (Plücker, the same expressions instantiated for the packet
// width); this holds them to it where rounding decides: segments ending exactly on
// vertices, on edges and on faces, grazing along faces, on closed and open meshes and
// on a heightfield, in packets of 1 to 16 with random companions.
TEST(AccelBatch, SegmentsInPacketsGetTheAnswersTheyGetAlone) {
    for (const char* sceneName : {"sphere", "soup", "heightfield", "box"}) {
        const TriangleMesh& mesh = GetScene(sceneName).mesh;
        const Bounds3 box = mesh.Bounds();
        for (const char* name : {"brute", "grid", "embree"}) {
            if (std::string(name) == "embree" && !HasEmbree()) continue;
            const auto accel = CreateAccelerator(name, mesh);
            std::mt19937 rng(29);
            std::uniform_real_distribution<float> u(-0.1f, 1.1f), unit(0.0f, 1.0f);
            std::uniform_int_distribution<uint32_t> pick(0, static_cast<uint32_t>(mesh.triangles.size() - 1));
            auto inBox = [&] {
                const Vec3 d = box.Diagonal();
                return box.lo + Vec3(u(rng) * d.x, u(rng) * d.y, u(rng) * d.z);
            };
            // An end where rounding decides: a vertex, an edge's point, a face's point.
            auto onMesh = [&](int kind) {
                const uint32_t t = pick(rng);
                const Vec3 &a = mesh.Vertex(t, 0), &b = mesh.Vertex(t, 1), &c = mesh.Vertex(t, 2);
                if (kind == 0) return a;
                const float f = unit(rng), g = unit(rng) * (1 - f);
                if (kind == 1) return a + (b - a) * f;
                return a + (b - a) * f + (c - a) * g;
            };
            int segments = 0, differ = 0, blocked = 0;
            for (int packet = 0; packet < SweepCases(2000, 4); ++packet) {
                const size_t n = 1 + static_cast<size_t>(packet % 16);
                std::vector<Ray> rays(n);
                for (size_t k = 0; k < n; ++k) {
                    const int kind = static_cast<int>((packet + k) % 5);
                    if (kind < 3) {  // from a random point to the mesh, ending on it
                        rays[k] = Segment(inBox(), onMesh(kind));
                    } else if (kind == 3) {  // through a vertex or an edge, ending beyond it
                        const Vec3 from = inBox(), through = onMesh(static_cast<int>(k % 2));
                        rays[k] = Ray{from, through - from, 0.0f, 1.0f + 1e-3f * unit(rng)};
                    } else {  // grazing: along a triangle's plane, from one of its points
                        const uint32_t t = pick(rng);
                        const Vec3 &a = mesh.Vertex(t, 0), &b = mesh.Vertex(t, 1), &c = mesh.Vertex(t, 2);
                        const Vec3 from = a + (b - a) * 0.5f, to = c + (c - from) * unit(rng);
                        rays[k] = Segment(from, to);
                    }
                }
                std::unique_ptr<bool[]> many(new bool[n]);
                accel->OccludedMany(rays.data(), n, many.get());
                for (size_t k = 0; k < n; ++k, ++segments) {
                    const bool alone = accel->Occluded(rays[k]);
                    differ += alone != many[k];
                    blocked += alone;
                }
            }
            EXPECT_GT(blocked, segments / 20) << sceneName << " " << name;
            EXPECT_LT(blocked, segments - segments / 20) << sceneName << " " << name;
            EXPECT_EQ(differ, 0) << sceneName << " " << name << ": " << differ << " of " << segments;
        }
    }
}

// IntersectMany and OccludedMany on coherent packets (a tile's camera rays, a tile's rays to
// one point), which the grid traverses together (coherent grid traversal), against
// Intersect and Occluded ray by ray on the same back-end (and so, by the differential tests
// above, brute force): hit triangle, t and barycentrics bit for bit. Packets of 1 to 100
// rays (more than one 64-ray chunk), from outside the box and from inside it, fanned from
// a point or parallel, some through a triangle's vertices and edges exactly, some with an
// empty or a short range, spread from a hair to the whole scene (the grid's divergent
// packets go on ray by ray).
TEST(AccelBatch, CoherentPacketsGetTheAnswersTheyGetAlone) {
    for (const char* sceneName : {"sphere", "soup", "heightfield", "box", "onecell", "longthin"}) {
        const TriangleMesh& mesh = GetScene(sceneName).mesh;
        const Bounds3 box = mesh.Bounds();
        const float diag = Length(box.Diagonal());
        for (const char* name : {"brute", "grid", "grid-sse", "embree"}) {
            if (std::string(name) == "embree" && !HasEmbree()) continue;
            const auto accel = MakeAccel(name, mesh);
            std::mt19937 rng(41);
            std::uniform_real_distribution<float> u(-0.1f, 1.1f), unit(0.0f, 1.0f), sym(-1.0f, 1.0f);
            std::uniform_int_distribution<uint32_t> pick(0, static_cast<uint32_t>(mesh.triangles.size() - 1));
            auto inBox = [&] {
                const Vec3 d = box.Diagonal();
                return box.lo + Vec3(u(rng) * d.x, u(rng) * d.y, u(rng) * d.z);
            };
            int rays = 0, hitCount = 0, differ = 0, blocked = 0, differOcc = 0;
            // Under the sanitizers 100 packets: every pattern (packet % 3, 4, 5, 7, 10) still comes.
            for (int packet = 0; packet < SweepCases(300, 3); ++packet) {
                const size_t n = packet % 10 == 9 ? 100 : 1 + static_cast<size_t>((packet * 7) % 64);
                const uint32_t t = pick(rng);
                const Vec3 &a = mesh.Vertex(t, 0), &b = mesh.Vertex(t, 1), &c = mesh.Vertex(t, 2);
                const Vec3 toward = a;
                // From outside the box (a camera), or from a point inside it.
                const Vec3 from = packet % 3 == 0 ? inBox()
                                                  : toward + Normalize(Vec3(sym(rng), sym(rng), sym(rng))) * (diag * (1.0f + unit(rng)));
                const float spread = diag * std::pow(10.0f, -4.0f + 4.0f * unit(rng));
                const bool parallel = packet % 5 == 4;
                const Vec3 dir = toward - from;
                std::vector<Ray> batch(n);
                for (size_t k = 0; k < n; ++k) {
                    Vec3 target = toward + Vec3(sym(rng), sym(rng), sym(rng)) * spread;
                    if (k % 6 == 1) target = k % 12 == 1 ? b : c;                 // a vertex
                    if (k % 6 == 2) target = a + (b - a) * unit(rng);              // an edge
                    if (k % 6 == 3) target = a + (b - a) * 0.5f + (c - a) * 0.25f;  // a face
                    Ray& r = batch[k];
                    if (parallel)
                        r = Ray{target - dir, dir, 0.0f, Infinity};
                    else
                        r = Ray{from, target - from, 0.0f, Infinity};
                    if (packet % 4 == 1) r.tMax = 1.0f - 1e-5f;                      // ends before the target
                    if (packet % 4 == 2) r.tMax = 1.0f + 1e-5f;                      // just beyond it
                    if (packet % 7 == 3 && k == n / 2) r.tMin = 2.0f, r.tMax = 1.0f;  // an empty range
                }
                std::vector<Hit> many(n);
                accel->IntersectMany(batch.data(), n, many.data());
                std::unique_ptr<bool[]> occ(new bool[n]);
                accel->OccludedMany(batch.data(), n, occ.get());
                for (size_t k = 0; k < n; ++k, ++rays) {
                    Hit one;
                    const bool found = accel->Intersect(batch[k], &one);
                    hitCount += found;
                    differ += found != (many[k].prim != UINT32_MAX) ||
                              (found && (one.prim != many[k].prim || one.t != many[k].t || one.b1 != many[k].b1 ||
                                         one.b2 != many[k].b2));
                    const bool alone = accel->Occluded(batch[k]);
                    blocked += alone;
                    differOcc += alone != occ[k];
                }
            }
            EXPECT_GT(hitCount, rays / 10) << sceneName << " " << name;
            EXPECT_LT(hitCount, rays - rays / 20) << sceneName << " " << name;
            // The occlusion answers compared are both kinds too.
            EXPECT_GT(blocked, rays / 10) << sceneName << " " << name;
            EXPECT_LT(blocked, rays - rays / 20) << sceneName << " " << name;
            EXPECT_EQ(differ, 0) << sceneName << " " << name << ": " << differ << " of " << rays;
            EXPECT_EQ(differOcc, 0) << sceneName << " " << name << ": " << differOcc << " of " << rays;
        }
    }
}

TEST(AccelFactory, NamesAndErrors) {
    EXPECT_EQ(AcceleratorNames(), (std::vector<std::string>{"brute", "grid", "embree"}));
    const TriangleMesh mesh = ts::Soup(10, 1);
    EXPECT_THROW(CreateAccelerator("octree", mesh), Error);
    EXPECT_EQ(CreateAccelerator("grid", mesh)->Name(), "grid");
    if (HasEmbree())
        EXPECT_EQ(CreateAccelerator("embree", mesh)->Name(), "embree");
    else
        EXPECT_THROW(CreateAccelerator("embree", mesh), Error);
}

TEST(AccelEmpty, EmptyMeshHasNoHits) {
    const TriangleMesh empty;
    for (const char* name : {"brute", "grid", "embree"}) {
        if (std::string(name) == "embree" && !HasEmbree()) continue;
        const auto accel = CreateAccelerator(name, empty);
        Hit h;
        const Ray r{{0, 0, 0}, {1, 0, 0}};
        EXPECT_FALSE(accel->Intersect(r, &h)) << name;
        EXPECT_FALSE(accel->Occluded(r)) << name;
        EXPECT_EQ(accel->CountCrossings(r), 0) << name;
        EXPECT_FALSE(accel->Figures().empty()) << name;
    }
}

}  // namespace
}  // namespace accel_test
}  // namespace lm
