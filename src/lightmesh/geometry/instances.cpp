#include "lightmesh/geometry/instances.h"

#include <algorithm>
#include <utility>

#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {

namespace {

// Corner k of a world triangle is corner Order(k) of its prototype's (TransformMesh swaps
// corners 1 and 2 of a mirrored triangle).
int Order(const MeshInstance& in, int k) { return in.toWorld.Determinant() < 0 && k ? 3 - k : k; }

}  // namespace

uint32_t InstancedMeshes::AddPrototype(TriangleMesh mesh) {
    Bounds3 b;
    for (const auto& t : mesh.triangles)
        for (uint32_t v : t) b.Extend(mesh.positions[v]);
    protoBounds_.push_back(b);
    prototypes_.push_back(std::move(mesh));
    return static_cast<uint32_t>(prototypes_.size() - 1);
}

void InstancedMeshes::AddInstance(uint32_t p, const Affine& toWorld) {
    const TriangleMesh& proto = prototypes_[p];
    if (count_ + proto.TriangleCount() >= UINT32_MAX / 2) ThrowError("instances: more than 2^31 triangles");
    MeshInstance in;
    in.prototype = p;
    in.first = static_cast<uint32_t>(count_);
    in.toWorld = toWorld;
    // The exact box: each vertex a triangle uses, transformed (as FlattenInstances would).
    std::vector<bool> used(proto.positions.size(), false);
    for (const auto& t : proto.triangles)
        for (uint32_t v : t) used[v] = true;
    for (size_t v = 0; v < used.size(); ++v)
        if (used[v]) in.bounds.Extend(toWorld.ApplyPoint(proto.positions[v]));
    bounds_.Extend(in.bounds);
    count_ += proto.TriangleCount();
    instances_.push_back(in);
}

size_t InstancedMeshes::Locate(uint32_t id) const {
    const auto it = std::upper_bound(instances_.begin(), instances_.end(), id,
                                     [](uint32_t x, const MeshInstance& in) { return x < in.first; });
    return static_cast<size_t>(it - instances_.begin()) - 1;
}

void InstancedMeshes::Corners(uint32_t id, Vec3 p[3]) const {
    const MeshInstance& in = instances_[Locate(id)];
    const TriangleMesh& proto = prototypes_[in.prototype];
    const auto& t = proto.triangles[id - in.first];
    for (int k = 0; k < 3; ++k) p[k] = in.toWorld.ApplyPoint(proto.positions[t[Order(in, k)]]);
}

bool InstancedMeshes::Normals(uint32_t id, Vec3 n[3]) const {
    const MeshInstance& in = instances_[Locate(id)];
    const TriangleMesh& proto = prototypes_[in.prototype];
    if (proto.normals.empty()) return false;
    const auto& t = proto.triangles[id - in.first];
    for (int k = 0; k < 3; ++k) n[k] = in.toWorld.ApplyNormal(proto.normals[t[Order(in, k)]]);
    return true;
}

bool InstancedMeshes::TexCoords(uint32_t id, TexCoord uv[3]) const {
    const MeshInstance& in = instances_[Locate(id)];
    const TriangleMesh& proto = prototypes_[in.prototype];
    if (proto.uvs.empty()) return false;
    const auto& t = proto.triangles[id - in.first];
    for (int k = 0; k < 3; ++k) uv[k] = proto.uvs[t[Order(in, k)]];
    return true;
}

uint32_t InstancedMeshes::Material(uint32_t id) const {
    const MeshInstance& in = instances_[Locate(id)];
    return prototypes_[in.prototype].materialIds[id - in.first];
}

size_t InstancedMeshes::Bytes() const {
    size_t bytes = instances_.size() * sizeof(MeshInstance) + protoBounds_.size() * sizeof(Bounds3);
    for (const TriangleMesh& p : prototypes_)
        bytes += p.positions.size() * sizeof(Vec3) + p.normals.size() * sizeof(Vec3) + p.uvs.size() * sizeof(TexCoord) +
                 p.triangles.size() * (3 * sizeof(uint32_t) + sizeof(uint32_t));
    return bytes;
}

void InstancedMeshes::HarmoniseAttributes(TriangleMesh* flat) {
    bool normals = flat->positions.empty() || !flat->normals.empty();
    bool uvs = !flat->uvs.empty();
    for (const TriangleMesh& p : prototypes_) {
        normals &= !p.normals.empty();
        uvs |= !p.uvs.empty();
    }
    auto fix = [&](TriangleMesh& m) {
        if (!normals) m.normals.clear();
        if (uvs) m.uvs.resize(m.positions.size());
    };
    fix(*flat);
    for (TriangleMesh& p : prototypes_) fix(p);
}

uint64_t InstancedMeshes::FlattenedBytes() const {
    uint64_t bytes = 0;
    for (const MeshInstance& in : instances_) {
        const TriangleMesh& p = prototypes_[in.prototype];
        bytes += p.positions.size() * sizeof(Vec3) + p.normals.size() * sizeof(Vec3) + p.uvs.size() * sizeof(TexCoord) +
                 p.triangles.size() * 16;
    }
    return bytes;
}

std::string CopiesOverBudget(uint64_t triangles, uint64_t bytes) {
    const uint64_t perTriangle = kPipelineBytesPerTriangle;
    const uint64_t need = std::max(bytes, triangles > UINT64_MAX / perTriangle ? UINT64_MAX : triangles * perTriangle);
    const uint64_t budget = PhysicalMemoryBytes();
    if (!budget || need <= budget / 2) return {};
    return StringPrintf("would take about %s (%s a triangle through the pipeline), more than half of the %s this "
                        "process may use (LIGHTMESH_MEMORY_LIMIT)",
                        FormatBytes(need).c_str(), FormatBytes(perTriangle).c_str(), FormatBytes(budget).c_str());
}

void CheckFlatteningFits(const TriangleMesh& mesh, const std::string& who) {
    if (!mesh.instances) return;
    const uint64_t triangles = mesh.TriangleCount() + mesh.instances->TriangleCount();
    if (const std::string over = CopiesOverBudget(triangles, mesh.instances->FlattenedBytes()); !over.empty())
        ThrowError("%sflattening %s instances into %s triangles %s; the default soft shadows and rt, area and "
                   "denoised on embree trace instances as they are",
                   who.c_str(), FormatCount(mesh.instances->Instances().size()).c_str(),
                   FormatCount(triangles).c_str(), over.c_str());
}

void FlattenInstances(TriangleMesh* mesh, const std::string& who) {
    if (!mesh->instances) return;
    CheckFlatteningFits(*mesh, who);
    const std::shared_ptr<const InstancedMeshes> inst = std::move(mesh->instances);
    mesh->instances.reset();
    for (const MeshInstance& in : inst->Instances()) {
        TriangleMesh copy = inst->Prototypes()[in.prototype];
        TransformMesh(&copy, in.toWorld);
        copy.cutouts.reset();
        mesh->Append(copy);
    }
}

TriangleMesh Flattened(const TriangleMesh& mesh) {
    TriangleMesh copy = mesh;
    FlattenInstances(&copy);
    return copy;
}

}  // namespace lm
