// assimp_import.cpp -- the import itself, ImportMeshInProcess: Assimp's log collected per
// import, the importer's hardening (budgets, regular files only, assertions as errors, with
// Assimp's aiAssertViolation replaced), the walk of the node hierarchy that places the
// meshes. Its parts of their own: materials (assimp_material.cpp), the glTF node-graph checks
// (gltf_checks.cpp); the child process it runs in for LoadMeshFile (isolated_import.cpp).
#include "lightmesh/scene/mesh_import_internal.h"

#include <assimp/DefaultIOSystem.h>
#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/LogStream.hpp>
#include <assimp/MemoryIOWrapper.h>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "lightmesh/geometry/smooth_normals.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/log.h"
#include "lightmesh/util/system.h"

// Assimp's ai_assert() calls Assimp::aiAssertViolation, which Debian's build (5.2, without
// the later setAiAssertHandler) makes abort(). Every call in libassimp goes through the PLT,
// so this definition, exported from the executable (see src/CMakeLists.txt), takes its
// place: an assertion becomes an error naming the file instead of killing the renderer.
namespace Assimp {
void aiAssertViolation(const char* expression, const char* file, int line);
}

namespace lm {

using mesh_import::CheckGltfHierarchy;
using mesh_import::CheckReadable;
using mesh_import::gResultFd;
using mesh_import::ImportErrorReason;
using mesh_import::MaterialFromFile;
using mesh_import::Thousands;
using mesh_import::WriteErrorResult;

namespace {

// ---------------------------------------------------------------------------------------
// Assimp's log, collected per import so its warnings (a missing .mtl, ...) reach the user.

class CollectingStream : public Assimp::LogStream {
  public:
    explicit CollectingStream(std::vector<std::string>* out) : out_(out) {}
    void write(const char* message) override {
        std::string s(message);
        // Assimp prefixes "Warn,  T0: " / "Error, T0: " and appends a newline.
        if (size_t colon = s.find(": "); colon != std::string::npos && colon < 16)
            s.erase(0, colon + 2);
        while (!s.empty() && (s.back() == '\n' || s.back() == '\r')) s.pop_back();
        if (!s.empty()) out_->push_back(s);
    }

  private:
    std::vector<std::string>* out_;
};

// Assimp's logger is a process-wide singleton: one import at a time owns it.
std::mutex gAssimpLogMutex;

class ScopedAssimpLog {
  public:
    explicit ScopedAssimpLog(std::vector<std::string>* out) : lock_(gAssimpLogMutex) {
        Assimp::DefaultLogger::create("", Assimp::Logger::NORMAL, 0);
        Assimp::DefaultLogger::get()->attachStream(new CollectingStream(out),
                                                   Assimp::Logger::Warn | Assimp::Logger::Err);
    }
    ~ScopedAssimpLog() { Assimp::DefaultLogger::kill(); }

  private:
    std::lock_guard<std::mutex> lock_;
};

}  // namespace

// ---------------------------------------------------------------------------------------
// Hardening of the importer: budgets, regular files only, assertions as errors

namespace mesh_import {

std::string Thousands(uint64_t n) {
    // (FormatCount: inserting into a string here drew GCC 12's false -Wrestrict warning.)
    return FormatCount(n);
}

/// Whether an importer message is known noise of a file that reads well: Assimp's Blender
/// reader logs "<add reason>" and "BlendDNA: Did not find a field named `x` in structure
/// `Y`" for each field a newer Blender added, and
/// complaints about textures lightmesh does not use and the lights' attenuation
/// (scenes/real/garden.json: 845 messages in all).
bool KnownImporterNoise(const std::string& message) {
    for (const char* prefix : {"<add reason>", "BlendDNA: Did not find a field named",
                               "BLEND: Encountered a texture with an unsupported type",
                               "Validation warning: aiLight::mAttenuation",
                               "Validation warning: UV-mapped texture, but there are no UV coords"})
        if (message.rfind(prefix, 0) == 0) return true;
    return false;
}

/// The child's result file while it imports (-1 in the parent and in-process imports).
int gResultFd = -1;

}  // namespace mesh_import

namespace {

/// An Assimp assertion, thrown out of aiAssertViolation (in this process), or written as
/// the child's result (see ImportIsolated).
class AssimpAssertion : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

/// Assimp opens every file of an import through this: the mesh file itself, an OBJ's
/// mtllib, a glTF's buffers, COLLADA's external references. Anything but a regular file is
/// refused (a FIFO with no writer would block forever, /dev/zero never ends), and so is
/// writing.
class RegularFilesOnly : public Assimp::DefaultIOSystem {
  public:
    /// `replacement`, if not empty, is read in place of the file `replaced` (a glTF whose
    /// data: URIs were repaired, RepairGltfDataUris).
    explicit RegularFilesOnly(std::vector<std::string>* refused, std::string replaced = "", std::string replacement = "")
        : refused_(refused), replaced_(std::move(replaced)), replacement_(std::move(replacement)) {}
    bool Exists(const char* file) const override {
        return file && RegularFileProblem(file, "file").empty();
    }
    Assimp::IOStream* Open(const char* file, const char* mode = "rb") override {
        if (!file) return nullptr;
        if (mode && (std::strchr(mode, 'w') || std::strchr(mode, 'a') || std::strchr(mode, '+'))) {
            refused_->push_back(std::string(file) + ": refused to open for writing");
            return nullptr;
        }
        if (!replacement_.empty() && replaced_ == file)
            return new Assimp::MemoryIOStream(reinterpret_cast<const uint8_t*>(replacement_.data()), replacement_.size());
        const std::string problem = RegularFileProblem(file, "file");
        if (!problem.empty()) {
            if (problem != "no such file")
                refused_->push_back(std::string(file) + ": not opened: " + problem);
            return nullptr;
        }
        return DefaultIOSystem::Open(file, mode);
    }

  private:
    std::vector<std::string>* refused_;
    std::string replaced_, replacement_;
};

// ---------------------------------------------------------------------------------------
// The node walk

Affine ToAffine(const aiMatrix4x4& a) {
    Affine r;
    const float rows[3][4] = {
        {a.a1, a.a2, a.a3, a.a4}, {a.b1, a.b2, a.b3, a.b4}, {a.c1, a.c2, a.c3, a.c4}};
    std::memcpy(r.m, rows, sizeof(rows));
    return r;
}

bool MatchesAny(const std::vector<std::string>& patterns, std::string_view text,
                std::vector<bool>* matched) {
    bool any = false;
    for (size_t i = 0; i < patterns.size(); ++i) {
        if (GlobMatch(patterns[i], text)) {
            (*matched)[i] = true;
            any = true;
        }
    }
    return any;
}

std::string FormatVec(const Vec3& v) {
    return StringPrintf("(%g, %g, %g)", v.x, v.y, v.z);
}

class SceneWalker {
  public:
    SceneWalker(const std::string& path, const aiScene& scene, const MeshLoadOptions& options,
                const ImportBudget& budget, LoadedMesh* out)
        : path_(path), scene_(scene), options_(options), budget_(budget), out_(out) {
        out_->excludeMaterialsMatched.assign(options.excludeMaterials.size(), false);
        out_->excludeNamesMatched.assign(options.excludeNames.size(), false);
    }

    /// Places every mesh of the hierarchy under `root`, depth first in file order. An
    /// explicit stack, not recursion: a hierarchy tens of thousands of levels deep must not
    /// overflow ours. Budgets (ImportBudget) are checked while instances are expanded.
    void Walk(const aiNode& root) {
        struct Frame {
            const aiNode* node;
            aiMatrix4x4 parent;
            bool excludedByAncestor;
            unsigned depth;
        };
        std::vector<Frame> stack{{&root, aiMatrix4x4(), false, 1}};
        size_t nodes = 0;
        while (!stack.empty()) {
            const Frame f = stack.back();
            stack.pop_back();
            const aiNode& node = *f.node;
            if (++nodes > budget_.nodes)
                Refuse(StringPrintf("the node hierarchy has more than %s node instances (the "
                                    "importer's budget)",
                                    Thousands(budget_.nodes).c_str()));
            if (f.depth > budget_.depth)
                Refuse(StringPrintf("the node hierarchy is more than %u levels deep (the limit)",
                                    budget_.depth));
            const aiMatrix4x4 transform = f.parent * node.mTransformation;
            if (wanted_ && !wanted_->empty()) {
                const auto it = wanted_->find(node.mName.C_Str());
                if (it != wanted_->end() && !it->second) {
                    mesh_import::NodeTransform t;
                    const aiMatrix4x4& a = transform;
                    const float rows[16] = {a.a1, a.a2, a.a3, a.a4, a.b1, a.b2, a.b3, a.b4,
                                            a.c1, a.c2, a.c3, a.c4, a.d1, a.d2, a.d3, a.d4};
                    std::memcpy(t.m, rows, sizeof rows);
                    t.lightRange = std::numeric_limits<float>::quiet_NaN();
                    if (float range = 0; node.mMetaData && node.mMetaData->Get("PBR_LightRange", range))
                        t.lightRange = range;
                    it->second = t;
                }
            }
            const bool excluded = MatchesAny(options_.excludeNames, node.mName.C_Str(),
                                             &out_->excludeNamesMatched) ||
                                  f.excludedByAncestor;
            for (unsigned i = 0; i < node.mNumMeshes; ++i) {
                if (node.mMeshes[i] >= scene_.mNumMeshes || !scene_.mMeshes[node.mMeshes[i]])
                    continue;
                PlaceMesh(*scene_.mMeshes[node.mMeshes[i]], transform, excluded);
            }
            if (!node.mChildren) continue;
            for (unsigned i = node.mNumChildren; i-- > 0;)
                if (node.mChildren[i])
                    stack.push_back({node.mChildren[i], transform, excluded, f.depth + 1});
        }
    }

    size_t nonTriangleMeshes = 0;  ///< meshes of points or lines seen (and dropped)
    /// Nodes whose global transform the walk records (cameras' and lights'), or null.
    mesh_import::NodeTransforms* wanted_ = nullptr;

  private:
    [[noreturn]] void Refuse(const std::string& reason) const {
        throw MeshFileError(path_, reason, false);
    }

    void PlaceMesh(const aiMesh& am, const aiMatrix4x4& transform, bool excludedByNode) {
        if (!am.mFaces || (am.mNumVertices > 0 && !am.mVertices)) return;
        size_t triangles = 0;
        for (unsigned f = 0; f < am.mNumFaces; ++f) triangles += am.mFaces[f].mNumIndices == 3;
        if (triangles == 0) {
            ++nonTriangleMeshes;
            return;
        }
        // Evaluate every pattern (no short-circuit), so each one's "matched" flag is right.
        const bool byName =
            MatchesAny(options_.excludeNames, am.mName.C_Str(), &out_->excludeNamesMatched);
        std::string materialName;
        if (am.mMaterialIndex < scene_.mNumMaterials) {
            aiString s;
            if (scene_.mMaterials[am.mMaterialIndex]->Get(AI_MATKEY_NAME, s) == AI_SUCCESS)
                materialName = s.C_Str();
        }
        const bool byMaterial =
            MatchesAny(options_.excludeMaterials, materialName, &out_->excludeMaterialsMatched);
        if (excludedByNode || byName || byMaterial) {
            ++out_->meshesExcluded;
            return;
        }
        if (++instances_ > budget_.instances)
            Refuse(StringPrintf("expanding its instances places more than %s meshes (the "
                                "importer's budget)",
                                Thousands(budget_.instances).c_str()));
        const size_t total = out_->mesh.TriangleCount() + triangles;
        if (total > budget_.triangles)
            Refuse(StringPrintf(
                "expanding its instances gives more than %s triangles, the budget for %s of "
                "memory (%s per triangle; LIGHTMESH_MEMORY_LIMIT)",
                Thousands(budget_.triangles).c_str(), FormatBytes(budget_.memory).c_str(),
                FormatBytes(ImportBudget::kBytesPerTriangle).c_str()));
        if (out_->mesh.positions.size() + am.mNumVertices > UINT32_MAX)
            Refuse("more than 4,294,967,295 vertices");

        TriangleMesh mesh;
        mesh.positions.resize(am.mNumVertices);
        for (unsigned v = 0; v < am.mNumVertices; ++v) {
            const aiVector3D& p = am.mVertices[v];
            mesh.positions[v] = Vec3(p.x, p.y, p.z);
            if (!IsFinite(mesh.positions[v]))
                throw MeshFileError(
                    path_,
                    StringPrintf("vertex %u of mesh \"%s\" has a non-finite coordinate %s", v,
                                 am.mName.C_Str(), FormatVec(mesh.positions[v]).c_str()),
                    false);
        }
        if (am.HasNormals()) {
            mesh.normals.resize(am.mNumVertices);
            for (unsigned v = 0; v < am.mNumVertices; ++v)
                mesh.normals[v] = Vec3(am.mNormals[v].x, am.mNormals[v].y, am.mNormals[v].z);
        }
        const uint32_t material = MaterialIndex(am.mMaterialIndex);
        // Texture coordinates only where a texture reads them: untextured models carry none.
        if ((out_->materials[material].texture >= 0 || out_->materials[material].alphaTexture >= 0) &&
            am.HasTextureCoords(0)) {
            mesh.uvs.resize(am.mNumVertices);
            for (unsigned v = 0; v < am.mNumVertices; ++v) {
                const aiVector3D& t = am.mTextureCoords[0][v];
                mesh.uvs[v] = {std::isfinite(t.x) ? t.x : 0.0f, std::isfinite(t.y) ? t.y : 0.0f};
            }
        }
        mesh.triangles.reserve(triangles);
        for (unsigned f = 0; f < am.mNumFaces; ++f) {
            const aiFace& face = am.mFaces[f];
            if (face.mNumIndices != 3) continue;
            for (int k = 0; k < 3; ++k) {
                if (face.mIndices[k] >= am.mNumVertices)
                    throw MeshFileError(
                        path_,
                        StringPrintf(
                            "face %u of mesh \"%s\" refers to vertex %u, but it has %u vertices", f,
                            am.mName.C_Str(), face.mIndices[k], am.mNumVertices),
                        true);
            }
            mesh.triangles.push_back({face.mIndices[0], face.mIndices[1], face.mIndices[2]});
            mesh.materialIds.push_back(material);
        }

        if (mesh.normals.empty() && options_.smoothAngle > 0) SmoothNormals(&mesh, options_.smoothAngle);
        const Affine affine = ToAffine(transform);
        if (!(std::abs(affine.Determinant()) > 0))
            throw MeshFileError(
                path_,
                StringPrintf("the node transform of mesh \"%s\" is singular", am.mName.C_Str()),
                false);
        TransformMesh(&mesh, affine);
        for (const Vec3& p : mesh.positions) {
            if (!IsFinite(p))
                throw MeshFileError(path_,
                                    StringPrintf("the node transforms make mesh \"%s\" non-finite",
                                                 am.mName.C_Str()),
                                    false);
        }
        for (const Vec3& n : mesh.normals) {
            if (!IsFinite(n) || !(LengthSquared(n) > 0)) {
                out_->warnings.push_back(
                    path_ +
                    StringPrintf(
                        ": mesh \"%s\" has zero or non-finite normals; shading uses face normals",
                        am.mName.C_Str()));
                mesh.normals.clear();
                break;
            }
        }
        out_->mesh.Append(mesh);
        ++out_->meshesPlaced;
    }

    uint32_t MaterialIndex(unsigned fileIndex) {
        auto [it, inserted] =
            materialMap_.try_emplace(fileIndex, static_cast<uint32_t>(out_->materials.size()));
        if (inserted) {
            out_->materials.push_back(fileIndex < scene_.mNumMaterials &&
                                              scene_.mMaterials[fileIndex]
                                          ? MaterialFromFile(*scene_.mMaterials[fileIndex], scene_, path_,
                                                             &out_->textures, &out_->warnings)
                                          : Material{});
        }
        return it->second;
    }

    const std::string& path_;
    const aiScene& scene_;
    const MeshLoadOptions& options_;
    const ImportBudget& budget_;
    LoadedMesh* out_;
    size_t instances_ = 0;
    std::unordered_map<unsigned, uint32_t> materialMap_;
};

}  // namespace

namespace mesh_import {

/// Checks what Assimp would report less clearly: a missing file, a directory, a FIFO, an
/// empty or unreadable file.
void CheckReadable(const std::string& path) {
    if (std::string problem = RegularFileProblem(path, "mesh file"); !problem.empty())
        throw MeshFileError(path, problem, true);
    struct stat st {};
    if (stat(path.c_str(), &st) == 0 && st.st_size == 0) {
        // /proc and /sys files report a size of 0 but have content.
        char c;
        const int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
        const bool hasContent = fd >= 0 && read(fd, &c, 1) == 1;
        if (fd >= 0) close(fd);
        if (hasContent)
            throw MeshFileError(path,
                                "reports a size of 0 but has content (a /proc or /sys file?): "
                                "not a mesh file",
                                true);
        throw MeshFileError(path, "the file is empty", true);
    }
    // No mesh format starts with a run of NUL bytes (a binary STL's 80-byte header may be
    // zeros, but its triangle count and data follow): a zeroed or sparse file is refused
    // here rather than read to its end under the import deadline (a 20 GB sparse file of
    // zeros would be read at 160 MB/s).
    constexpr size_t kProbe = 4096;
    const int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) return;
    char head[kProbe];
    size_t got = 0;
    while (got < kProbe) {
        const ssize_t n = read(fd, head + got, kProbe - got);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break;
        got += static_cast<size_t>(n);
    }
    close(fd);
    if (got > 0 && std::all_of(head, head + got, [](char c) { return c == 0; }))
        throw MeshFileError(path,
                            StringPrintf("its first %s bytes are all zero (NUL): not a mesh file (a zeroed or "
                                         "sparse file?)",
                                         Thousands(got).c_str()),
                            true);
}

/// Assimp's error string as a reason.
std::string ImportErrorReason(std::string err, const ImportBudget& budget) {
    if (err.rfind("No suitable reader found", 0) == 0)
        return "Assimp has no reader for this file format";
    if (err.find("mNumMeshes is 0") != std::string::npos)
        return "no meshes found in it (is the file really in this format?)";
    if (err.find("contains no faces") != std::string::npos)
        return "a mesh in it has no faces (is the file truncated?)";
    if (err.find("bad_alloc") != std::string::npos || err.find("bad alloc") != std::string::npos ||
        err.find("bad array new length") != std::string::npos)
        return StringPrintf("the importer ran out of memory (its budget is %s; "
                            "LIGHTMESH_MEMORY_LIMIT): the file's counts are too large or lie",
                            budget.memory ? FormatBytes(budget.memory).c_str() : "unlimited");
    if (size_t at = err.find("Assimp's internal check failed"); at != std::string::npos)
        return err.substr(at);
    if (err.rfind("Validation failed: ", 0) == 0)
        return "malformed or truncated (Assimp: " + err.substr(19) + ")";
    if (err.empty()) return "Assimp could not import it";
    return err;
}

}  // namespace mesh_import

LoadedMesh ImportMeshInProcess(const std::string& path, const MeshLoadOptions& options,
                               const ImportBudget& budget) {
    CheckReadable(path);
    CheckGltfHierarchy(path, budget);
    LoadedMesh out;
    std::vector<std::string> log, refused;
    try {
        ScopedAssimpLog scopedLog(&log);
        Assimp::Importer importer;
        // A file read through a repaired copy: a glTF's data: URIs, an AC3D file's texture layers.
        std::string replacement = mesh_import::RepairGltfDataUris(path, &out.warnings);
        if (replacement.empty()) replacement = mesh_import::RepairAc3dTextureLayers(path);
        importer.SetIOHandler(new RegularFilesOnly(&refused, path, std::move(replacement)));
        // Triangulate polygons; split meshes by primitive type so points and lines sit in
        // meshes of their own, which the walk skips. Assimp generates no normals: shading
        // uses face normals where the file has none, or the walk's SmoothNormals when
        // asked (options.smoothAngle). Instances are expanded by the walk
        // (not aiProcess_PreTransformVertices) so node names stay available to excludes.
        // A material's texture-coordinate transform (glTF's KHR_texture_transform, 3DS and
        // ASE tiling and offsets) is applied to the coordinates themselves.
        // OBJ files come through tinyobjloader (UseTinyObjReader), their vertices welded.
        const bool tinyObj = mesh_import::UseTinyObjReader(&importer);
        importer.SetPropertyBool(mesh_import::kObjMergeObjects, options.excludeNames.empty());
        const unsigned flags = aiProcess_Triangulate | aiProcess_SortByPType | aiProcess_TransformUVCoords |
                               (tinyObj && mesh_import::HasObjExtension(path) ? 0u : aiProcess_JoinIdenticalVertices) |
                               aiProcess_ValidateDataStructure;
        const aiScene* scene = importer.ReadFile(path, flags);
        if (!scene) {
            std::string err = ImportErrorReason(importer.GetErrorString(), budget);
            if (!refused.empty()) err += " (" + refused.front() + ")";
            throw MeshFileError(path, err, true);
        }
        if (!scene->mRootNode)
            throw MeshFileError(path, "the file has no scene graph (no meshes)", true);
        SceneWalker walker(path, *scene, options, budget, &out);
        mesh_import::NodeTransforms placed;
        mesh_import::WantedNodeNames(*scene, &placed);
        walker.wanted_ = &placed;
        walker.Walk(*scene->mRootNode);
        mesh_import::ReadCamerasAndLights(*scene, path, placed, &out);
        if (out.mesh.TriangleCount() == 0 && out.meshesExcluded == 0) {
            throw MeshFileError(
                path,
                walker.nonTriangleMeshes > 0 ? "no triangles (only points/lines)" : "no triangles",
                false);
        }
    } catch (const Error&) {
        throw;
    } catch (const AssimpAssertion& e) {
        throw MeshFileError(path, e.what(), true);
    } catch (const std::bad_alloc&) {
        throw MeshFileError(path, ImportErrorReason("bad_alloc", budget), true);
    } catch (const std::exception& e) {
        // Assimp catches its own import errors, but allocation failures and the like can
        // still escape; they must not cross LoadMeshFile as anything but an Error.
        throw MeshFileError(path, StringPrintf("import failed: %s", e.what()), true);
    }
    for (const std::string& r : refused) out.warnings.push_back(path + ": " + r);
    // Keep a handful of the importer's complaints; a broken file can produce thousands.
    // Known noise of files read well (the Blender reader's "<add reason>" and a "BlendDNA:
    // Did not find a field named ..." per field of a newer Blender) is one line; -v shows
    // every message.
    const bool verbose = GetLogLevel() <= LogLevel::Debug;
    std::vector<std::string> shown;
    size_t noise = 0;
    for (const std::string& m : log) {
        if (!verbose && mesh_import::KnownImporterNoise(m))
            ++noise;
        else
            shown.push_back(m);
    }
    constexpr size_t MaxLogLines = 5;
    for (size_t i = 0; i < shown.size() && (verbose || i < MaxLogLines); ++i)
        out.warnings.push_back(path + ": " + shown[i]);
    if (!verbose && shown.size() > MaxLogLines)
        out.warnings.push_back(path + StringPrintf(": ... and %s more importer messages (-v shows them)",
                                                   mesh_import::Thousands(shown.size() - MaxLogLines).c_str()));
    if (noise)
        out.warnings.push_back(path + StringPrintf(": %s routine importer %s left out (Blender fields the reader "
                                                   "skips, textures lightmesh does not use, lights' attenuation; -v shows "
                                                   "them)",
                                                   mesh_import::Thousands(noise).c_str(),
                                                   noise == 1 ? "message" : "messages"));
    return out;
}

}  // namespace lm

namespace Assimp {
void aiAssertViolation(const char* expression, const char* file, int line) {
    const char* base = file ? std::strrchr(file, '/') : nullptr;
    const std::string reason = lm::StringPrintf(
        "Assimp's internal check failed (%s at %s:%d): the file is malformed or its counts lie",
        expression ? expression : "?", base ? base + 1 : (file ? file : "?"), line);
    if (lm::gResultFd >= 0) {
        // In the child: Assimp may assert where an exception cannot pass (a destructor);
        // report and end here.
        lm::WriteErrorResult(lm::gResultFd, reason, true);
        _exit(0);
    }
    throw lm::AssimpAssertion(reason);
}
}  // namespace Assimp
