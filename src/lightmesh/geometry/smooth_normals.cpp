// smooth_normals.cpp -- crease-angle smooth normals (smooth_normals.h).
#include "lightmesh/geometry/smooth_normals.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <unordered_map>

namespace lm {
namespace {

struct NormalKey {
    uint32_t vertex, x, y, z;
    bool operator==(const NormalKey& o) const { return vertex == o.vertex && x == o.x && y == o.y && z == o.z; }
};
struct NormalKeyHash {
    size_t operator()(const NormalKey& k) const {
        uint64_t h = k.vertex;
        for (uint32_t v : {k.x, k.y, k.z}) h = (h ^ v) * 0x100000001b3ull;
        return static_cast<size_t>(h ^ (h >> 29));
    }
};

uint32_t Bits(float f) {
    uint32_t u;
    std::memcpy(&u, &f, sizeof u);
    return u;
}

/// Vertices at the same position as one: group[v] for each vertex.
std::vector<uint32_t> PositionGroups(const std::vector<Vec3>& positions, uint32_t* count) {
    std::vector<uint32_t> order(positions.size());
    std::iota(order.begin(), order.end(), 0u);
    auto less = [&](uint32_t a, uint32_t b) {
        const Vec3 &p = positions[a], &q = positions[b];
        return p.x != q.x ? p.x < q.x : (p.y != q.y ? p.y < q.y : (p.z != q.z ? p.z < q.z : a < b));
    };
    std::sort(order.begin(), order.end(), less);
    std::vector<uint32_t> group(positions.size());
    uint32_t g = 0;
    for (size_t i = 0; i < order.size(); ++i) {
        if (i > 0) {
            const Vec3 &p = positions[order[i - 1]], &q = positions[order[i]];
            if (p.x != q.x || p.y != q.y || p.z != q.z) ++g;
        }
        group[order[i]] = g;
    }
    *count = order.empty() ? 0 : g + 1;
    return group;
}

}  // namespace

void SmoothNormals(TriangleMesh* mesh, float creaseDegrees) {
    const size_t nt = mesh->triangles.size();
    if (nt == 0 || !mesh->normals.empty()) return;
    const float cosCrease = creaseDegrees >= 180.0f ? -2.0f : std::cos(creaseDegrees * Pi / 180.0f);
    // Unit face normals, and each corner's angle: the faces around a position are weighted
    // by their angle there (Thürmer and Wüthrich), so how a face is split into triangles
    // does not tilt the normal.
    std::vector<Vec3> unit(nt);
    std::vector<float> angle(3 * nt);
    for (size_t t = 0; t < nt; ++t) {
        const auto& tri = mesh->triangles[t];
        const Vec3 c = Cross(mesh->positions[tri[1]] - mesh->positions[tri[0]], mesh->positions[tri[2]] - mesh->positions[tri[0]]);
        const float len = Length(c);
        const bool ok = len > 0 && std::isfinite(len);
        unit[t] = ok ? c / len : Vec3(0, 0, 0);
        for (int k = 0; k < 3; ++k) {
            const Vec3 a = mesh->positions[tri[(k + 1) % 3]] - mesh->positions[tri[k]];
            const Vec3 b = mesh->positions[tri[(k + 2) % 3]] - mesh->positions[tri[k]];
            const float cosine = Dot(a, b) / (Length(a) * Length(b));
            angle[3 * t + k] = ok && std::isfinite(cosine) ? std::acos(std::clamp(cosine, -1.0f, 1.0f)) : 0.0f;
        }
    }
    // The faces around each position (compressed rows).
    uint32_t groups = 0;
    const std::vector<uint32_t> group = PositionGroups(mesh->positions, &groups);
    // The corners at each position (compressed rows of 3·triangle + corner).
    std::vector<uint32_t> start(groups + 1, 0), corners(3 * nt);
    for (const auto& tri : mesh->triangles)
        for (int k = 0; k < 3; ++k) ++start[group[tri[k]] + 1];
    std::partial_sum(start.begin(), start.end(), start.begin());
    std::vector<uint32_t> fill(start.begin(), start.end() - 1);
    for (size_t t = 0; t < nt; ++t)
        for (int k = 0; k < 3; ++k) corners[fill[group[mesh->triangles[t][k]]]++] = static_cast<uint32_t>(3 * t + k);
    // Each corner's normal; a vertex per (old vertex, normal).
    TriangleMesh out;
    out.triangles.resize(nt);
    std::unordered_map<NormalKey, uint32_t, NormalKeyHash> made;
    made.reserve(mesh->positions.size());
    const bool uvs = !mesh->uvs.empty();
    for (size_t t = 0; t < nt; ++t) {
        for (int k = 0; k < 3; ++k) {
            const uint32_t v = mesh->triangles[t][k], g = group[v];
            const bool limited = cosCrease > -2.0f && start[g + 1] - start[g] <= kMaxSmoothedNormalsPerPosition &&
                                 LengthSquared(unit[t]) > 0;
            Vec3 sum(0, 0, 0);
            for (uint32_t i = start[g]; i < start[g + 1]; ++i) {
                const uint32_t u = corners[i] / 3;
                if (!limited || Dot(unit[u], unit[t]) >= cosCrease) sum += unit[u] * angle[corners[i]];
            }
            const float len = Length(sum);
            Vec3 n = len > 0 && std::isfinite(len) ? sum / len : unit[t];
            if (!(LengthSquared(n) > 0)) n = Vec3(0, 0, 1);
            const NormalKey key{v, Bits(n.x), Bits(n.y), Bits(n.z)};
            auto [it, inserted] = made.try_emplace(key, static_cast<uint32_t>(out.positions.size()));
            if (inserted) {
                out.positions.push_back(mesh->positions[v]);
                out.normals.push_back(n);
                if (uvs) out.uvs.push_back(mesh->uvs[v]);
            }
            out.triangles[t][k] = it->second;
        }
    }
    mesh->positions = std::move(out.positions);
    mesh->normals = std::move(out.normals);
    if (uvs) mesh->uvs = std::move(out.uvs);
    mesh->triangles = std::move(out.triangles);
}

}  // namespace lm
