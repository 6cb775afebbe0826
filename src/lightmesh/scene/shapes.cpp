#include "lightmesh/scene/shapes.h"

#include <cmath>
#include <vector>

namespace lm {

uint32_t ShapeBuilder::Vertex(const Vec3& p) {
    mesh_->positions.push_back(p);
    if (!mesh_->uvs.empty()) mesh_->uvs.resize(mesh_->positions.size());
    return static_cast<uint32_t>(mesh_->positions.size() - 1);
}

void ShapeBuilder::Tri(uint32_t a, uint32_t b, uint32_t c, uint32_t material) {
    mesh_->triangles.push_back({a, b, c});
    mesh_->materialIds.push_back(material);
}

void ShapeBuilder::OrientedBox(const Vec3& c, const Vec3& ex, const Vec3& ey, const Vec3& ez,
                               uint32_t material) {
    uint32_t v[8];
    for (int i = 0; i < 8; ++i)
        v[i] = Vertex(c + ex * ((i & 1) ? 1.0f : -1.0f) + ey * ((i & 2) ? 1.0f : -1.0f) +
                      ez * ((i & 4) ? 1.0f : -1.0f));
    // Faces as quads (counter-clockwise seen from outside for a right-handed frame).
    const int quads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                             {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
    for (const auto& q : quads) {
        Tri(v[q[0]], v[q[1]], v[q[2]], material);
        Tri(v[q[0]], v[q[2]], v[q[3]], material);
    }
}

void ShapeBuilder::Box(const Vec3& lo, const Vec3& hi, uint32_t material) {
    const Vec3 h = (hi - lo) * 0.5f;
    OrientedBox((lo + hi) * 0.5f, {h.x, 0, 0}, {0, h.y, 0}, {0, 0, h.z}, material);
}

void ShapeBuilder::Beam(const Vec3& a, const Vec3& b, float width, uint32_t material) {
    const Vec3 axis = (b - a) * 0.5f;
    Vec3 s, t;
    CoordinateSystem(Normalize(axis), &s, &t);
    OrientedBox((a + b) * 0.5f, s * (0.5f * width), t * (0.5f * width), axis, material);
}

namespace {
// A ring of `segments` points of the given radius around `centre` in the xz plane, in the
// order that makes the faces built below point outwards.
std::vector<Vec3> Ring(const Vec3& centre, float radius, int segments) {
    std::vector<Vec3> ring;
    for (int i = 0; i < segments; ++i) {
        const float a = 2.0f * Pi * static_cast<float>(i) / static_cast<float>(segments);
        ring.push_back(centre + Vec3(radius * std::cos(a), 0, radius * std::sin(a)));
    }
    return ring;
}
}  // namespace

void ShapeBuilder::Cylinder(const Vec3& base, float radius, float height, int segments,
                            uint32_t material) {
    const std::vector<Vec3> ring = Ring(base, radius, segments);
    std::vector<uint32_t> lo, hi;
    for (const Vec3& p : ring) lo.push_back(Vertex(p));
    for (const Vec3& p : ring) hi.push_back(Vertex(p + Vec3(0, height, 0)));
    const uint32_t cLo = Vertex(base), cHi = Vertex(base + Vec3(0, height, 0));
    for (int i = 0; i < segments; ++i) {
        const int j = (i + 1) % segments;
        Tri(lo[i], hi[i], hi[j], material);
        Tri(lo[i], hi[j], lo[j], material);
        Tri(cLo, lo[i], lo[j], material);
        Tri(cHi, hi[j], hi[i], material);
    }
}

void ShapeBuilder::Cone(const Vec3& base, float radius, float height, int segments,
                        uint32_t material) {
    const std::vector<Vec3> ring = Ring(base, radius, segments);
    std::vector<uint32_t> lo;
    for (const Vec3& p : ring) lo.push_back(Vertex(p));
    const uint32_t cLo = Vertex(base), apex = Vertex(base + Vec3(0, height, 0));
    for (int i = 0; i < segments; ++i) {
        const int j = (i + 1) % segments;
        Tri(lo[i], apex, lo[j], material);
        Tri(cLo, lo[i], lo[j], material);
    }
}

void ShapeBuilder::Sphere(const Vec3& centre, float radius, int rings, int segments,
                          uint32_t material) {
    const uint32_t top = Vertex(centre + Vec3(0, radius, 0));
    std::vector<std::vector<uint32_t>> rows;
    for (int r = 1; r < rings; ++r) {
        const float theta = Pi * static_cast<float>(r) / static_cast<float>(rings);
        const Vec3 c = centre + Vec3(0, radius * std::cos(theta), 0);
        std::vector<uint32_t> row;
        for (const Vec3& p : Ring(c, radius * std::sin(theta), segments)) row.push_back(Vertex(p));
        rows.push_back(std::move(row));
    }
    const uint32_t bottom = Vertex(centre - Vec3(0, radius, 0));
    for (int i = 0; i < segments; ++i) {
        const int j = (i + 1) % segments;
        Tri(top, rows.front()[j], rows.front()[i], material);
        for (size_t r = 0; r + 1 < rows.size(); ++r) {
            Tri(rows[r][i], rows[r][j], rows[r + 1][j], material);
            Tri(rows[r][i], rows[r + 1][j], rows[r + 1][i], material);
        }
        Tri(bottom, rows.back()[i], rows.back()[j], material);
    }
}

}  // namespace lm
