// accel_scenes.h -- seeded scene and ray generators shared by the accelerator tests, the
// real-scene tests and bench_accel.
//
// Header-only and deterministic: the generators use their own integer-to-float mapping on
// std::mt19937 (whose sequence the standard fixes), so a seed gives the same triangles on
// every platform and standard library.
#pragma once

#include <cmath>
#include <cstdint>
#include <map>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "lightmesh/geometry/mesh.h"
#include "lightmesh/math/ray.h"

namespace lm::testing_scenes {

/// Uniform floats in [0, 1) from a fixed generator.
class Rng {
  public:
    explicit Rng(uint32_t seed) : gen_(seed) {}
    float Uniform() { return float(gen_() >> 8) * (1.0f / 16777216.0f); }
    float Uniform(float lo, float hi) { return lo + (hi - lo) * Uniform(); }
    uint32_t Index(uint32_t n) { return uint32_t(gen_() % n); }
    Vec3 InBox(const Vec3& lo, const Vec3& hi) {
        return {Uniform(lo.x, hi.x), Uniform(lo.y, hi.y), Uniform(lo.z, hi.z)};
    }
    /// A uniformly distributed unit vector.
    Vec3 Direction() {
        for (;;) {
            Vec3 v(Uniform(-1, 1), Uniform(-1, 1), Uniform(-1, 1));
            float l2 = LengthSquared(v);
            if (l2 > 1e-4f && l2 <= 1.0f) return v / std::sqrt(l2);
        }
    }

  private:
    std::mt19937 gen_;
};

inline void AddTriangle(TriangleMesh* m, const Vec3& a, const Vec3& b, const Vec3& c) {
    const uint32_t i = uint32_t(m->positions.size());
    m->positions.insert(m->positions.end(), {a, b, c});
    m->triangles.push_back({i, i + 1, i + 2});
    m->materialIds.push_back(0);
}

/// n triangles with edges up to `size` scattered in the unit cube.
inline TriangleMesh Soup(int n, uint32_t seed, float size = 0.08f) {
    TriangleMesh m;
    Rng rng(seed);
    for (int i = 0; i < n; ++i) {
        const Vec3 c = rng.InBox(Vec3(0), Vec3(1));
        AddTriangle(&m, c + rng.Direction() * (size * rng.Uniform(0.2f, 1)),
                    c + rng.Direction() * (size * rng.Uniform(0.2f, 1)),
                    c + rng.Direction() * (size * rng.Uniform(0.2f, 1)));
    }
    return m;
}

/// An indexed n × n height field over [0, 1]² (shared vertices, one open sheet).
inline TriangleMesh HeightField(int n, uint32_t seed, float amplitude = 0.15f) {
    TriangleMesh m;
    Rng rng(seed);
    const float p1 = rng.Uniform(0, 6.3f), p2 = rng.Uniform(0, 6.3f);
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) {
            const float x = float(i) / float(n), y = float(j) / float(n);
            const float z = amplitude * (std::sin(7 * x + p1) * std::cos(5 * y + p2) +
                                         0.3f * rng.Uniform(-1, 1));
            m.positions.emplace_back(x, y, z);
        }
    auto v = [&](int i, int j) { return uint32_t(j * (n + 1) + i); };
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            m.triangles.push_back({v(i, j), v(i + 1, j), v(i + 1, j + 1)});
            m.triangles.push_back({v(i, j), v(i + 1, j + 1), v(i, j + 1)});
        }
    m.materialIds.assign(m.triangles.size(), 0);
    return m;
}

/// n long, thin triangles (length ~1, width ~1e-3) in random directions across the unit cube:
/// the case where a triangle's bounding box covers many cells it does not touch.
inline TriangleMesh LongThin(int n, uint32_t seed) {
    TriangleMesh m;
    Rng rng(seed);
    for (int i = 0; i < n; ++i) {
        const Vec3 a = rng.InBox(Vec3(0), Vec3(1));
        const Vec3 b = rng.InBox(Vec3(0), Vec3(1));
        const Vec3 side = Normalize(Cross(b - a, rng.Direction())) * rng.Uniform(1e-4f, 2e-3f);
        AddTriangle(&m, a, b, a + (b - a) * rng.Uniform(0.1f, 0.9f) + side);
    }
    return m;
}

/// n tiny triangles inside a 0.01-wide cube, in a box 1000 times larger defined by a few
/// big triangles: almost everything lands in one top-level cell, so only sub-grids help.
inline TriangleMesh OneCell(int n, uint32_t seed) {
    TriangleMesh m;
    Rng rng(seed);
    AddTriangle(&m, {-5, -5, -5}, {-4, -5, -5}, {-5, -4, -5});
    AddTriangle(&m, {5, 5, 5}, {4, 5, 5}, {5, 4, 5});
    AddTriangle(&m, {5, -5, 0}, {-5, 5, 0.5f}, {5, 5, -0.5f});  // a big one across the box
    for (int i = 0; i < n; ++i) {
        const Vec3 c = rng.InBox(Vec3(0), Vec3(0.01f));
        AddTriangle(&m, c + rng.Direction() * 1e-3f, c + rng.Direction() * 1e-3f,
                    c + rng.Direction() * 1e-3f);
    }
    return m;
}

/// A closed UV sphere of radius r around the origin: poles on the z axis, `rings` bands
/// (even), `segments` around. The southern half is the exact mirror (z negated) of the
/// northern one, and every edge is shared by exactly two triangles via shared indices.
inline TriangleMesh Sphere(int rings, int segments, float r = 1.0f) {
    TriangleMesh m;
    const double pi = 3.14159265358979323846;
    m.positions.emplace_back(0.0f, 0.0f, r);  // 0: north pole
    for (int i = 1; i < rings; ++i) {
        const int k = i <= rings / 2 ? i : rings - i;  // mirror ring
        const double theta = pi * k / rings;
        for (int j = 0; j < segments; ++j) {
            const double phi = 2 * pi * j / segments;
            float z = float(r * std::cos(theta));
            if (i > rings / 2) z = -z;
            if (2 * i == rings) z = 0.0f;
            m.positions.emplace_back(float(r * std::sin(theta) * std::cos(phi)),
                                     float(r * std::sin(theta) * std::sin(phi)), z);
        }
    }
    const uint32_t south = uint32_t(m.positions.size());
    m.positions.emplace_back(0.0f, 0.0f, -r);
    auto v = [&](int i, int j) { return uint32_t(1 + (i - 1) * segments + (j % segments)); };
    for (int j = 0; j < segments; ++j) {
        m.triangles.push_back({0, v(1, j), v(1, j + 1)});
        m.triangles.push_back({south, v(rings - 1, j + 1), v(rings - 1, j)});
    }
    for (int i = 1; i + 1 < rings; ++i)
        for (int j = 0; j < segments; ++j) {
            m.triangles.push_back({v(i, j), v(i + 1, j), v(i + 1, j + 1)});
            m.triangles.push_back({v(i, j), v(i + 1, j + 1), v(i, j + 1)});
        }
    m.materialIds.assign(m.triangles.size(), 0);
    return m;
}

/// The closed box [-h, h]³ with each face split into k × k quads (two triangles each), all
/// vertices shared. With h and k powers of two every vertex coordinate is a dyadic number,
/// so rays can pass exactly through vertices and edges.
inline TriangleMesh TessellatedBox(int k, float h = 1.0f) {
    TriangleMesh m;
    std::map<std::tuple<int, int, int>, uint32_t> index;
    auto vertex = [&](int i, int j, int l) {
        auto [it, inserted] = index.try_emplace({i, j, l}, uint32_t(m.positions.size()));
        if (inserted)
            m.positions.emplace_back(-h + 2 * h * float(i) / float(k),
                                     -h + 2 * h * float(j) / float(k),
                                     -h + 2 * h * float(l) / float(k));
        return it->second;
    };
    for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side <= 1; ++side)
            for (int a = 0; a < k; ++a)
                for (int b = 0; b < k; ++b) {
                    auto at = [&](int u, int w) {
                        int c[3];
                        c[axis] = side * k;
                        c[(axis + 1) % 3] = u;
                        c[(axis + 2) % 3] = w;
                        return vertex(c[0], c[1], c[2]);
                    };
                    const uint32_t p00 = at(a, b), p10 = at(a + 1, b), p11 = at(a + 1, b + 1),
                                   p01 = at(a, b + 1);
                    if (side) {
                        m.triangles.push_back({p00, p10, p11});
                        m.triangles.push_back({p00, p11, p01});
                    } else {
                        m.triangles.push_back({p00, p11, p10});
                        m.triangles.push_back({p00, p01, p11});
                    }
                }
    m.materialIds.assign(m.triangles.size(), 0);
    return m;
}

/// Scales and moves a mesh (for the huge/small scene-scale tests).
/// "A teapot in a stadium": a detailed closed model (a UV sphere of rings ×
/// segments around (0, 1, 0), radius 1) standing on a thin ground slab `width` times its
/// width, the case where a uniform grid's cells are either empty or crowded.
inline TriangleMesh TeapotInStadium(int rings, int segments, float width = 4.0f) {
    TriangleMesh m = Sphere(rings, segments);
    for (Vec3& p : m.positions) p = Vec3(p.x, p.z + 1.0f, p.y);
    const float w = width, y0 = -0.05f, y1 = 0.0f;
    const Vec3 c[8] = {{-w, y0, -w}, {w, y0, -w}, {w, y0, w}, {-w, y0, w},
                       {-w, y1, -w}, {w, y1, -w}, {w, y1, w}, {-w, y1, w}};
    const int quads[6][4] = {{4, 5, 6, 7}, {0, 3, 2, 1}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
    for (const auto& q : quads) {
        AddTriangle(&m, c[q[0]], c[q[1]], c[q[2]]);
        AddTriangle(&m, c[q[0]], c[q[2]], c[q[3]]);
    }
    return m;
}

inline TriangleMesh Transformed(TriangleMesh m, float scale, const Vec3& offset) {
    for (Vec3& p : m.positions) p = p * scale + offset;
    return m;
}

/// A ray and what kind it is, for messages.
struct TestRay {
    Ray ray;
    const char* kind;
};

// Every kind of ray the renderer makes, and the awkward ones: from outside and inside the
// box, axis-parallel, with a zero component, short segments, starting exactly on the box's
// boundary, aimed exactly at vertices, with tMin > 0.
inline std::vector<TestRay> MakeRays(const TriangleMesh& mesh, int count, uint32_t seed) {
    Rng rng(seed);
    const Bounds3 b = mesh.Bounds();
    const Vec3 c = b.Center();
    const float radius = 0.5f * Length(b.Diagonal());
    std::vector<TestRay> rays;
    rays.reserve(size_t(count));
    for (int i = 0; i < count; ++i) {
        const int kind = i % 9;
        const Vec3 inside = rng.InBox(b.lo, b.hi);
        const Vec3 outside = c + rng.Direction() * (radius * rng.Uniform(1.5f, 4.0f));
        const float scale = rng.Uniform(0.1f, 10.0f);  // |d| need not be 1
        Ray r;
        const char* name = "";
        switch (kind) {
            case 0:
                r = Ray{outside, (inside - outside) * scale};
                name = "outside->box";
                break;
            case 1:
                r = Ray{inside, rng.Direction() * scale};
                name = "inside";
                break;
            case 2: {
                const int a = int(rng.Index(3));
                Vec3 d(0.0f);
                d[a] = rng.Uniform() < 0.5f ? -scale : scale;
                Vec3 o = inside;
                if (rng.Uniform() < 0.5f) o[a] = c[a] - d[a] / scale * 2 * radius;  // from outside
                r = Ray{o, d};
                name = "axis-parallel";
                break;
            }
            case 3: {
                Vec3 d = rng.Direction() * scale;
                d[int(rng.Index(3))] = 0.0f;
                r = Ray{rng.Uniform() < 0.5f ? inside : outside, d};
                name = "zero component";
                break;
            }
            case 4: {
                const Vec3 end = inside + rng.Direction() * (radius * rng.Uniform(0.0f, 0.3f));
                r = Segment(inside, end);
                name = "short segment";
                break;
            }
            case 5: {
                Vec3 o = inside;
                const int a = int(rng.Index(3));
                const bool hi = rng.Uniform() < 0.5f;
                o[a] = hi ? b.hi[a] : b.lo[a];
                Vec3 d = rng.Direction();
                if ((d[a] > 0) == hi) d[a] = -d[a];  // into the box
                r = Ray{o, d * scale};
                name = "on box boundary";
                break;
            }
            case 6: {
                const Vec3& v = mesh.positions[rng.Index(uint32_t(mesh.positions.size()))];
                r = Ray{outside, v - outside};
                name = "at a vertex";
                break;
            }
            case 7: {
                r = Ray{outside, (inside - outside)};
                r.tMin = rng.Uniform(0.0f, 1.0f);
                r.tMax = r.tMin + rng.Uniform(0.05f, 2.0f);
                name = "tMin > 0";
                break;
            }
            default: {
                r = Segment(outside, inside);
                name = "outside segment";
                break;
            }
        }
        rays.push_back({r, name});
    }
    return rays;
}

}  // namespace lm::testing_scenes
