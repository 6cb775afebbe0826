// scene_meshes.cpp -- a scene file's mesh files made one mesh: each imported once however
// many entries name it, transformed, cleaned, its materials merged with the scene's, and
// the references that save memory so placed as instances of one prototype.
#include "lightmesh/scene/scene_file_parts.h"
#include "lightmesh/scene/scene_load.h"

#include <algorithm>

#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm::scene_load {

using namespace json;  // Reader, Quoted

bool InstancesSaveMemory(int refs, size_t triangles) {
    return refs >= 2 && triangles >= kInstanceMinTriangles &&
           static_cast<double>(refs) * static_cast<double>(triangles) >= static_cast<double>(kInstanceMinTotal);
}

MeshAssembler::MeshAssembler(const Reader& r, const SceneLoadOptions& options, const std::vector<MeshEntry>& entries,
                             const std::vector<std::string>& materialNames, Scene* scene)
    : r_(r), options_(options), materialNames_(materialNames), scene_(scene) {
    for (const MeshEntry& e : entries) ++importsLeft_[ImportKey(e)];
    // References that become instances (docs/scene-format.md, "Instancing"): those of one
    // file with the same exclusions and material, imported once as a prototype.
    for (const MeshEntry& e : entries) ++groupRefs_[GroupKey(e)];
}

std::string MeshAssembler::ImportKey(const MeshEntry& e) {
    std::string key = e.resolved;
    for (const std::string& p : e.load.excludeMaterials) key += std::string(1, '\0') + "m" + p;
    for (const std::string& p : e.load.excludeNames) key += std::string(1, '\0') + "n" + p;
    if (e.load.smoothAngle > 0) key += std::string(1, '\0') + "s" + std::to_string(e.load.smoothAngle);
    return key;
}

std::string MeshAssembler::GroupKey(const MeshEntry& e) {
    return ImportKey(e) + std::string(1, '\0') + std::to_string(e.material);
}

LoadedMesh MeshAssembler::Import(const MeshEntry& e, const std::string& key) {
    LoadedMesh loaded;
    if (imported_.count(key) > 0) {
        if (--importsLeft_[key] == 0) {
            loaded = std::move(imported_[key]);
            imported_.erase(key);
        } else {
            loaded = imported_[key];
        }
        return loaded;
    }
    const std::string filePath = e.path + "/file";
    try {
        loaded = options_.loadMesh ? options_.loadMesh(e.resolved, e.load) : LoadMeshFile(e.resolved, e.load);
    } catch (const MeshFileError& err) {
        if (err.Unreadable()) r_.Fail(filePath, "cannot read " + Quoted(e.file) + ": " + err.Reason());
        r_.Fail(filePath, Quoted(e.file) + ": " + err.Reason());
    }
    for (const std::string& w : loaded.warnings) r_.Warn(w);
    if (--importsLeft_[key] > 0) imported_[key] = loaded;
    return loaded;
}

void MeshAssembler::WarnOnce(const std::string& key, const std::string& message) {
    const auto [at, added] = repeatedAt_.try_emplace(key, repeated_.size());
    if (added) repeated_.push_back({message, 0});
    ++repeated_[at->second].second;
}

// Patterns that excluded nothing are probably typos.
void MeshAssembler::WarnUnmatched(const MeshEntry& e, const char* key, const std::vector<std::string>& patterns,
                                  const std::vector<bool>& matched, bool list, const char* what) {
    for (size_t k = 0; k < patterns.size(); ++k) {
        if (matched[k]) continue;
        const std::string path = e.path + "/" + key + (list ? "/" + std::to_string(k) : std::string());
        WarnOnce(std::string(key) + '\0' + patterns[k] + '\0' + e.file,
                 r_.Where(path) + ": pattern " + Quoted(patterns[k]) + " matched no " + what + " of " +
                     Quoted(e.file));
    }
}

void MeshAssembler::CheckCopies(const MeshEntry& e, const std::string& group, size_t triangles) {
    const uint64_t refs = static_cast<uint64_t>(groupRefs_[group]);
    copiedTriangles_ += refs * triangles;
    const std::string over = CopiesOverBudget(copiedTriangles_);
    if (over.empty()) return;
    const bool sceneOff = !scene_->render.instancing;
    const std::string why = !options_.instancing ? " (" + options_.noInstancingBy + ")"
                            : sceneOff           ? " (\"instancing\": false at /render/instancing)"
                                                 : "";
    const std::string hint = !options_.instancing || sceneOff
                                 ? "; with instancing on, a file referenced many times is placed as "
                                   "instances of one import"
                                 : "";
    r_.Fail(e.path, Quoted(e.file) +
                        StringPrintf(" (%s triangles) is referenced %s times and copied each time%s: the "
                                     "scene's copies, %s triangles, ",
                                     FormatCount(triangles).c_str(), FormatCount(refs).c_str(), why.c_str(),
                                     FormatCount(copiedTriangles_).c_str()) +
                        over + hint);
}

void MeshAssembler::Place(const MeshEntry& e, uint32_t proto) {
    const Affine toWorld = e.hasTransform ? e.transform : Affine{};
    const size_t before = instances_->Instances().size();
    try {
        instances_->AddInstance(proto, toWorld);
    } catch (const Error& err) {
        r_.Fail(e.path, err.what());  // the reference past the ids' limit
    }
    const Bounds3& b = instances_->Instances()[before].bounds;
    if (!IsFinite(b.lo) || !IsFinite(b.hi)) r_.Fail(e.path, "the transform makes coordinates non-finite (too large)");
}

void MeshAssembler::AssignMaterials(const MeshEntry& e, LoadedMesh* loaded) {
    if (e.material >= 0) {
        std::fill(loaded->mesh.materialIds.begin(), loaded->mesh.materialIds.end(), static_cast<uint32_t>(e.material));
        return;
    }
    // A file material named like one of the scene's "materials" takes the scene's
    // definition (how real models get their look without editing them); the
    // others are appended as the file defines them.
    std::vector<uint32_t> remap(loaded->materials.size());
    for (size_t m = 0; m < loaded->materials.size(); ++m) {
        const auto named = std::find(materialNames_.begin(), materialNames_.end(), loaded->materials[m].name);
        if (named != materialNames_.end()) {
            remap[m] = static_cast<uint32_t>(named - materialNames_.begin());
        } else {
            remap[m] = static_cast<uint32_t>(scene_->materials.size());
            scene_->materials.push_back(loaded->materials[m]);
        }
    }
    for (uint32_t& id : loaded->mesh.materialIds) id = remap[id];
}

void MeshAssembler::Add(const MeshEntry& e) {
    const std::string key = ImportKey(e);
    LoadedMesh loaded = Import(e, key);
    WarnUnmatched(e, "exclude_materials", e.load.excludeMaterials, loaded.excludeMaterialsMatched,
                  e.excludeMaterialsIsList, "material");
    WarnUnmatched(e, "exclude_names", e.load.excludeNames, loaded.excludeNamesMatched, e.excludeNamesIsList,
                  "node or mesh");
    const bool cameras = keepCameras_ && !loaded.cameras.empty();
    if (cameras || (keepLights_ && !loaded.lights.empty())) {
        kept_.push_back({&e, cameras ? loaded.cameras : std::vector<FileCamera>{},
                         keepLights_ ? loaded.lights : std::vector<FileLight>{}});
        if (cameras) keepCameras_ = false;  // the first file with cameras gives the camera
    }
    scene_->report.meshesExcluded += loaded.meshesExcluded;
    scene_->report.sources.push_back(e.resolved);
    if (loaded.mesh.TriangleCount() == 0) {
        WarnOnce(std::string("excluded") + '\0' + key,
                 r_.Where(e.path) + ": every mesh of " + Quoted(e.file) + " was excluded");
        return;
    }
    const std::string group = GroupKey(e);
    if (const auto p = prototypeOf_.find(group); p != prototypeOf_.end()) {
        Place(e, p->second);
        return;
    }
    const bool texturesOn = options_.textures && scene_->render.textures && e.material < 0;
    const bool instanced = options_.instancing && scene_->render.instancing &&
                           InstancesSaveMemory(groupRefs_[group], loaded.mesh.TriangleCount());
    if (!instanced && copiedGroups_.insert(group).second) CheckCopies(e, group, loaded.mesh.TriangleCount());
    if (e.hasTransform && !instanced) {
        TransformMesh(&loaded.mesh, e.transform);
        for (const Vec3& p : loaded.mesh.positions)
            if (!IsFinite(p)) r_.Fail(e.path, "the transform makes coordinates non-finite (too large)");
    }
    const CleanReport clean = CleanMesh(&loaded.mesh);
    scene_->report.degenerateRemoved += clean.degenerate;
    scene_->report.duplicatesRemoved += clean.duplicate;
    if (clean.degenerate || clean.duplicate)
        if (const std::string w = e.resolved + ": " + DroppedMessage(clean); said_.insert(w).second) r_.Warn(w);
    // A file material the scene replaces by name reads no image (its look is the scene's).
    for (Material& m : loaded.materials)
        if (std::find(materialNames_.begin(), materialNames_.end(), m.name) != materialNames_.end())
            m.texture = m.alphaTexture = -1;
    AttachTextures(r_, e.resolved, texturesOn, &textureCache_, &loaded, scene_);
    AssignMaterials(e, &loaded);
    if (instanced) {
        if (!instances_) instances_ = std::make_shared<InstancedMeshes>();
        // Its cut-outs in its own ids (the scene's mask answers for its instances).
        loaded.mesh.cutouts = MakeCutouts(loaded.mesh, *scene_, nullptr);
        const uint32_t proto = instances_->AddPrototype(std::move(loaded.mesh));
        prototypeOf_[group] = proto;
        Place(e, proto);
        return;
    }
    scene_->mesh.Append(loaded.mesh);
}

void MeshAssembler::Finish(const std::string& spec) {
    for (const auto& [message, count] : repeated_)
        r_.Warn(count == 1 ? message
                           : message + " (and in " + FormatCount(count - 1) +
                                 (count == 2 ? " other reference to it)" : " other references to it)"));
    // Triangles repeated across meshes (the same file placed twice at the same spot).
    const CleanReport across = CleanMesh(&scene_->mesh);
    scene_->report.degenerateRemoved += across.degenerate;
    scene_->report.duplicatesRemoved += across.duplicate;
    if (across.duplicate)
        r_.Warn(spec + ": dropped " + FormatCount(across.duplicate) +
                (across.duplicate == 1 ? " triangle that duplicates a triangle of another mesh"
                                       : " triangles that duplicate triangles of another mesh"));
    if (instances_) {
        instances_->HarmoniseAttributes(&scene_->mesh);
        scene_->mesh.instances = std::move(instances_);
    }
}

}  // namespace lm::scene_load
