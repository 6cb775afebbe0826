#include "lightmesh/geometry/mesh.h"

#include <algorithm>
#include <cstring>
#include <unordered_map>

#include "lightmesh/geometry/triangle.h"

namespace lm {

Bounds3 TriangleMesh::Bounds() const {
    Bounds3 b;
    for (const auto& t : triangles)
        for (uint32_t v : t) b.Extend(positions[v]);
    return b;
}

void TriangleMesh::Append(const TriangleMesh& other, uint32_t materialOffset) {
    const uint32_t base = static_cast<uint32_t>(positions.size());
    const bool haveNormals = !normals.empty() || positions.empty();
    // Keep normals only when both sides have them; otherwise shading uses face normals.
    if (!other.normals.empty() && haveNormals) {
        normals.insert(normals.end(), other.normals.begin(), other.normals.end());
    } else {
        normals.clear();
    }
    positions.insert(positions.end(), other.positions.begin(), other.positions.end());
    for (const auto& t : other.triangles) triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
    for (uint32_t m : other.materialIds) materialIds.push_back(m + materialOffset);
}

namespace {

struct Vec3Hash {
    size_t operator()(const Vec3& v) const {
        auto h = [](float f) {
            if (f == 0.0f) f = 0.0f;  // +0 and -0 weld together
            uint32_t u;
            std::memcpy(&u, &f, 4);
            return static_cast<size_t>(u) * 0x9E3779B97F4A7C15ull;
        };
        return h(v.x) ^ (h(v.y) >> 1) ^ (h(v.z) << 1);
    }
};

// Welds vertices by exact position: returns a canonical id per position index.
std::vector<uint32_t> WeldIds(const std::vector<Vec3>& positions) {
    std::unordered_map<Vec3, uint32_t, Vec3Hash> ids;
    ids.reserve(positions.size());
    std::vector<uint32_t> out(positions.size());
    for (size_t i = 0; i < positions.size(); ++i) {
        auto [it, inserted] = ids.try_emplace(positions[i], static_cast<uint32_t>(ids.size()));
        out[i] = it->second;
    }
    return out;
}

}  // namespace

CleanReport CleanMesh(TriangleMesh* mesh) {
    CleanReport report;
    const std::vector<uint32_t> weld = WeldIds(mesh->positions);
    struct Key {
        uint32_t a, b, c;
        bool operator==(const Key&) const = default;
    };
    struct KeyHash {
        size_t operator()(const Key& k) const {
            return (static_cast<size_t>(k.a) * 0x9E3779B97F4A7C15ull) ^
                   (static_cast<size_t>(k.b) * 0xC2B2AE3D27D4EB4Full) ^ k.c;
        }
    };
    std::unordered_map<Key, uint32_t, KeyHash> seen;
    seen.reserve(mesh->triangles.size());
    size_t out = 0;
    for (size_t i = 0; i < mesh->triangles.size(); ++i) {
        const auto& t = mesh->triangles[i];
        const Vec3 &p0 = mesh->positions[t[0]], &p1 = mesh->positions[t[1]],
                   &p2 = mesh->positions[t[2]];
        const Vec3 n = TriangleNormal(p0, p1, p2);
        if (!IsFinite(p0) || !IsFinite(p1) || !IsFinite(p2) || !(LengthSquared(n) > 0) ||
            !IsFinite(n)) {
            ++report.degenerate;
            continue;
        }
        uint32_t ids[3] = {weld[t[0]], weld[t[1]], weld[t[2]]};
        std::sort(ids, ids + 3);
        if (!seen.emplace(Key{ids[0], ids[1], ids[2]}, 0).second) {
            ++report.duplicate;
            continue;
        }
        mesh->triangles[out] = t;
        if (!mesh->materialIds.empty()) mesh->materialIds[out] = mesh->materialIds[i];
        ++out;
    }
    mesh->triangles.resize(out);
    if (!mesh->materialIds.empty()) mesh->materialIds.resize(out);
    return report;
}

EdgeReport AnalyzeEdges(const TriangleMesh& mesh) {
    const std::vector<uint32_t> weld = WeldIds(mesh.positions);
    std::unordered_map<uint64_t, uint32_t> uses;
    uses.reserve(mesh.triangles.size() * 2);
    for (const auto& t : mesh.triangles) {
        for (int k = 0; k < 3; ++k) {
            uint32_t a = weld[t[k]], b = weld[t[(k + 1) % 3]];
            if (a == b) continue;
            if (a > b) std::swap(a, b);
            ++uses[(static_cast<uint64_t>(a) << 32) | b];
        }
    }
    EdgeReport r;
    r.edges = uses.size();
    for (const auto& [edge, n] : uses) {
        if (n == 1) ++r.open;
        else if (n > 2) ++r.nonManifold;
    }
    return r;
}

}  // namespace lm
