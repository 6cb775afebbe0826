#include "lightmesh/geometry/mesh.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>
#include <unordered_map>

#include "lightmesh/geometry/cutouts.h"
#include "lightmesh/geometry/instances.h"
#include "lightmesh/geometry/triangle.h"
#include "lightmesh/util/hash.h"

namespace lm {

Bounds3 TriangleMesh::Bounds() const {
    Bounds3 b;
    for (const auto& t : triangles)
        for (uint32_t v : t) b.Extend(positions[v]);
    if (instances) b.Extend(instances->Bounds());
    return b;
}

size_t TriangleMesh::PrimCount() const { return triangles.size() + (instances ? instances->TriangleCount() : 0); }

void TriangleMesh::InstancedCorners(uint32_t prim, Vec3 p[3]) const {
    instances->Corners(prim - static_cast<uint32_t>(triangles.size()), p);
}

uint32_t TriangleMesh::InstancedMaterial(uint32_t prim) const {
    return instances->Material(prim - static_cast<uint32_t>(triangles.size()));
}

bool TriangleMesh::HasShadingNormals() const {
    if (!normals.empty() || !positions.empty() || !instances) return !normals.empty();
    const auto& protos = instances->Prototypes();
    return std::all_of(protos.begin(), protos.end(), [](const TriangleMesh& p) { return !p.normals.empty(); });
}

bool TriangleMesh::InstancedNormals(uint32_t prim, Vec3 n[3]) const {
    return instances->Normals(prim - static_cast<uint32_t>(triangles.size()), n);
}

bool TriangleMesh::InstancedUvs(uint32_t prim, TexCoord t[3]) const {
    return instances->TexCoords(prim - static_cast<uint32_t>(triangles.size()), t);
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
    // Texture coordinates: kept if either side has them, (0, 0) for the other's vertices.
    if (!uvs.empty() || !other.uvs.empty()) {
        uvs.resize(positions.size());
        if (other.uvs.empty())
            uvs.resize(positions.size() + other.positions.size());
        else
            uvs.insert(uvs.end(), other.uvs.begin(), other.uvs.end());
    }
    positions.insert(positions.end(), other.positions.begin(), other.positions.end());
    for (const auto& t : other.triangles) triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
    for (uint32_t m : other.materialIds) materialIds.push_back(m + materialOffset);
}

namespace {

// Open addressing over one array (a table of indices, linear probing): a mesh of a
// million vertices would otherwise cost a million node allocations of a std::unordered_map
// and their page faults — most of the time of loading a large model.
size_t TableSize(size_t entries) { return std::bit_ceil(std::max<size_t>(2 * entries, 16)); }
constexpr uint32_t kEmpty = UINT32_MAX;


// Welds vertices by exact position (+0 and -0 together, a NaN coordinate with nothing):
// a canonical id per position index, numbered in order of first appearance.
std::vector<uint32_t> WeldIds(const std::vector<Vec3>& positions) {
    auto bits = [](float f) {
        if (f == 0.0f) f = 0.0f;  // +0 and -0 weld together
        uint32_t u;
        std::memcpy(&u, &f, 4);
        return u;
    };
    std::vector<uint32_t> table(TableSize(positions.size()), kEmpty);
    const size_t mask = table.size() - 1;
    std::vector<uint32_t> out(positions.size());
    uint32_t next = 0;
    for (size_t i = 0; i < positions.size(); ++i) {
        const Vec3& p = positions[i];
        if (!(p == p)) {  // NaN equals nothing, itself included
            out[i] = next++;
            continue;
        }
        size_t slot = Mix64((uint64_t(bits(p.x)) << 32 | bits(p.y)) ^ Mix64(bits(p.z))) & mask;
        for (;; slot = (slot + 1) & mask) {
            const uint32_t j = table[slot];
            if (j == kEmpty) {
                table[slot] = static_cast<uint32_t>(i);
                out[i] = next++;
                break;
            }
            if (positions[j] == p) {
                out[i] = out[j];
                break;
            }
        }
    }
    return out;
}

}  // namespace

CleanReport CleanMesh(TriangleMesh* mesh) {
    CleanReport report;
    const std::vector<uint32_t> weld = WeldIds(mesh->positions);
    // The kept triangles' welded ids, sorted, by a table of indices into `keys`.
    std::vector<std::array<uint32_t, 3>> keys;
    keys.reserve(mesh->triangles.size());
    std::vector<uint32_t> table(TableSize(mesh->triangles.size()), kEmpty);
    const size_t mask = table.size() - 1;
    auto insert = [&](const std::array<uint32_t, 3>& k) {  // false if already there
        size_t slot = Mix64((uint64_t(k[0]) << 32 | k[1]) ^ Mix64(k[2])) & mask;
        for (;; slot = (slot + 1) & mask) {
            if (table[slot] == kEmpty) {
                table[slot] = static_cast<uint32_t>(keys.size());
                keys.push_back(k);
                return true;
            }
            const std::array<uint32_t, 3>& e = keys[table[slot]];
            if (e[0] == k[0] && e[1] == k[1] && e[2] == k[2]) return false;  // (not a memcmp call)
        }
    };
    size_t out = 0;
    for (size_t i = 0; i < mesh->triangles.size(); ++i) {
        const auto& t = mesh->triangles[i];
        const Vec3 &p0 = mesh->positions[t[0]], &p1 = mesh->positions[t[1]],
                   &p2 = mesh->positions[t[2]];
        // Relative to the triangle's own size: the edges scaled to its largest component
        // first, so a valid model at 1e-17 scale is kept (its squared cross product
        // underflowed to 0 in float) and only a flat triangle is dropped.
        const Vec3 n = ScaledTriangleNormal(p0, p1, p2);
        if (!IsFinite(p0) || !IsFinite(p1) || !IsFinite(p2) || !(LengthSquared(n) > 0) ||
            !IsFinite(n)) {
            ++report.degenerate;
            continue;
        }
        std::array<uint32_t, 3> ids = {weld[t[0]], weld[t[1]], weld[t[2]]};
        std::sort(ids.begin(), ids.end());
        if (!insert(ids)) {
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

namespace {

/// ClosedParts' flags for one triangle list: a union of the triangles that share an edge,
/// and the parts with an edge not shared by exactly two of them marked open.
std::vector<uint8_t> ClosedTriangles(const std::vector<Vec3>& positions,
                                     const std::vector<std::array<uint32_t, 3>>& triangles) {
    const std::vector<uint32_t> weld = WeldIds(positions);
    std::vector<uint32_t> parent(triangles.size());
    for (uint32_t t = 0; t < parent.size(); ++t) parent[t] = t;
    auto find = [&](uint32_t t) {
        while (parent[t] != t) t = parent[t] = parent[parent[t]];
        return t;
    };
    std::vector<std::pair<uint64_t, uint32_t>> edges;  // (welded edge, triangle), sorted
    edges.reserve(3 * triangles.size());
    for (uint32_t t = 0; t < triangles.size(); ++t)
        for (int k = 0; k < 3; ++k) {
            uint32_t a = weld[triangles[t][k]], b = weld[triangles[t][(k + 1) % 3]];
            if (a == b) continue;
            if (a > b) std::swap(a, b);
            edges.push_back({uint64_t(a) << 32 | b, t});
        }
    std::sort(edges.begin(), edges.end());
    std::vector<uint32_t> openAt;  // a triangle of each part with an open or non-manifold edge
    for (size_t i = 0; i < edges.size();) {
        size_t j = i + 1;
        for (; j < edges.size() && edges[j].first == edges[i].first; ++j) parent[find(edges[j].second)] = find(edges[i].second);
        if (j - i != 2) openAt.push_back(edges[i].second);
        i = j;
    }
    std::vector<uint8_t> open(triangles.size(), 0), closed(triangles.size(), 0);
    for (const uint32_t t : openAt) open[find(t)] = 1;
    for (uint32_t t = 0; t < triangles.size(); ++t) closed[t] = !open[find(t)];
    return closed;
}

/// CountCrossings, counting the triangles `counts` (id, prototype's triangle or -1) takes.
template <typename Counts>
int Crossings(const TriangleMesh& mesh, const Ray& ray, Counts&& counts) {
    TriangleHit th;
    int n = 0;
    const CutoutMask* cut = mesh.cutouts.get();
    for (uint32_t i = 0; i < mesh.triangles.size(); ++i)
        n += counts(i, -1) && IntersectTriangle(ray, mesh.Vertex(i, 0), mesh.Vertex(i, 1), mesh.Vertex(i, 2), &th) &&
             (!cut || cut->Solid(mesh, i, th.b1, th.b2));
    if (!mesh.instances) return n;
    // Instanced triangles: those of instances whose box the ray meets.
    const uint32_t flat = static_cast<uint32_t>(mesh.triangles.size());
    const InstancedMeshes& inst = *mesh.instances;
    for (const MeshInstance& in : inst.Instances()) {
        float t0 = ray.tMin, t1 = ray.tMax;
        bool meets = true;
        for (int k = 0; k < 3 && meets; ++k) {
            // The box grown a little: a ray along a face must still reach the test.
            const float pad = 1e-5f * (std::abs(in.bounds.lo[k]) + std::abs(in.bounds.hi[k])) + 1e-30f;
            const float inv = 1.0f / ray.d[k];
            float a = (in.bounds.lo[k] - pad - ray.o[k]) * inv, b = (in.bounds.hi[k] + pad - ray.o[k]) * inv;
            if (a > b) std::swap(a, b);
            if (ray.d[k] == 0) {
                if (ray.o[k] < in.bounds.lo[k] - pad || ray.o[k] > in.bounds.hi[k] + pad) meets = false;
                continue;
            }
            t0 = std::max(t0, a), t1 = std::min(t1, b);
            meets = t0 <= t1 + 1e-5f * (std::abs(t0) + std::abs(t1));
        }
        if (!meets) continue;
        const size_t count = inst.Prototypes()[in.prototype].TriangleCount();
        for (size_t k = 0; k < count; ++k) {
            const uint32_t id = flat + in.first + static_cast<uint32_t>(k);
            if (!counts(in.prototype, static_cast<int64_t>(k))) continue;
            Vec3 p[3];
            mesh.Corners(id, p);
            n += IntersectTriangle(ray, p[0], p[1], p[2], &th) && (!cut || cut->Solid(mesh, id, th.b1, th.b2));
        }
    }
    return n;
}

}  // namespace

ClosedParts FindClosedParts(const TriangleMesh& mesh) {
    ClosedParts parts;
    parts.flat = ClosedTriangles(mesh.positions, mesh.triangles);
    if (mesh.instances)
        for (const TriangleMesh& p : mesh.instances->Prototypes())
            parts.prototypes.push_back(ClosedTriangles(p.positions, p.triangles));
    return parts;
}

int CountCrossings(const TriangleMesh& mesh, const Ray& ray) {
    return Crossings(mesh, ray, [](uint32_t, int64_t) { return true; });
}

int CountCrossings(const TriangleMesh& mesh, const Ray& ray, const ClosedParts& only) {
    return Crossings(mesh, ray, [&](uint32_t i, int64_t k) {
        return k < 0 ? only.flat[i] != 0 : only.prototypes[i][static_cast<size_t>(k)] != 0;
    });
}

}  // namespace lm
