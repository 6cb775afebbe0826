#include "lightmesh/scene/mesh_loader.h"

#include <assimp/DefaultIOSystem.h>
#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/LogStream.hpp>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/syscall.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string_view>
#include <unordered_map>

#include "lightmesh/util/log.h"
#include "lightmesh/util/system.h"

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define LIGHTMESH_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
#define LIGHTMESH_SANITIZED 1
#endif
#endif

// Assimp's ai_assert() calls Assimp::aiAssertViolation, which Debian's build (5.2, without
// the later setAiAssertHandler) makes abort(). Every call in libassimp goes through the PLT,
// so this definition, exported from the executable (see src/CMakeLists.txt), takes its
// place: an assertion becomes an error naming the file instead of killing the renderer.
namespace Assimp {
void aiAssertViolation(const char* expression, const char* file, int line);
}

namespace lm {

// ---------------------------------------------------------------------------------------
// Globs

bool GlobMatch(std::string_view pattern, std::string_view text) {
    // Greedy matching with backtracking to the last '*' (linear in practice).
    size_t p = 0, s = 0, star = std::string_view::npos, mark = 0;
    while (s < text.size()) {
        if (p < pattern.size() && (pattern[p] == '?' || pattern[p] == text[s])) {
            ++p;
            ++s;
        } else if (p < pattern.size() && pattern[p] == '*') {
            star = p++;
            mark = s;
        } else if (star != std::string_view::npos) {
            p = star + 1;
            s = ++mark;
        } else {
            return false;
        }
    }
    while (p < pattern.size() && pattern[p] == '*') ++p;
    return p == pattern.size();
}

namespace {

// ---------------------------------------------------------------------------------------
// Materials

Color ToColor(const aiColor3D& c) {
    auto clean = [](float v) { return std::isfinite(v) && v > 0 ? v : 0.0f; };
    return {clean(c.r), clean(c.g), clean(c.b)};
}

Color Lerp(const Color& a, const Color& b, float t) {
    return a * (1 - t) + b * t;
}

// How an Assimp material becomes a Phong material of formula (1):
//  - kd: AI_MATKEY_BASE_COLOR (glTF's baseColorFactor) if present, else
//    AI_MATKEY_COLOR_DIFFUSE (OBJ's Kd, Collada's diffuse, ...).
//  - Metallic-roughness materials (AI_MATKEY_METALLIC_FACTOR present: glTF 2):
//      kd     = base·(1 − metallic)               (metals have no diffuse reflection)
//      ks     = lerp(0.04, base, metallic)·(1 − roughness)
//               (dielectrics reflect ~4 %, metals their colour; a rough surface has no
//               visible highlight)
//      phong  = 2/α² − 2 with α = roughness², clamped to [1, 1000] (the Blinn-Phong
//               exponent of a GGX lobe of the same width)
//      mirror = base only if metallic ≥ 0.9 and roughness ≤ 0.1 (obviously polished metal).
//  - Other materials (OBJ/MTL, PLY, Collada, FBX, ...):
//      ks     = AI_MATKEY_COLOR_SPECULAR × AI_MATKEY_SHININESS_STRENGTH (default 1)
//      phong  = AI_MATKEY_SHININESS (OBJ's Ns) if > 0, else 32; clamped to ≤ 10000
//      mirror = AI_MATKEY_COLOR_REFLECTIVE × AI_MATKEY_REFLECTIVITY, only if the
//               reflectivity is ≥ 0.5: exporters write small values by default, which
//               would make every surface a faint mirror. MTL has no reflectivity.
//  - Assimp's stand-in for files without materials (PLY, STL, an OBJ without .mtl; glTF's
//    default material) becomes our default grey (kd 0.8, no specular) rather than
//    Assimp's 0.6 grey, white, or glTF's black-diffuse "white metal".
//  Transparency, emission, textures and vertex colours are ignored; negative or
//  non-finite values become 0.
Material MaterialFromFile(const aiMaterial& am) {
    Material m;
    aiString aname;
    const std::string name =
        am.Get(AI_MATKEY_NAME, aname) == AI_SUCCESS ? std::string(aname.C_Str()) : std::string();

    aiColor3D base(0.8f, 0.8f, 0.8f);
    const bool hasBase = am.Get(AI_MATKEY_BASE_COLOR, base) == AI_SUCCESS;
    if (!hasBase) am.Get(AI_MATKEY_COLOR_DIFFUSE, base);
    float metallic = 0, roughness = 1;
    const bool pbr = am.Get(AI_MATKEY_METALLIC_FACTOR, metallic) == AI_SUCCESS;
    am.Get(AI_MATKEY_ROUGHNESS_FACTOR, roughness);

    const bool standIn =
        (name.empty() || name == AI_DEFAULT_MATERIAL_NAME) &&
        (!pbr || (base.r == 1 && base.g == 1 && base.b == 1 && metallic == 1 && roughness == 1));
    if (standIn) return m;  // the default grey
    m.name = name.empty() ? "unnamed" : name;

    const Color kd = ToColor(base);
    if (pbr) {
        metallic = std::isfinite(metallic) ? std::clamp(metallic, 0.0f, 1.0f) : 0.0f;
        roughness = std::isfinite(roughness) ? std::clamp(roughness, 0.0f, 1.0f) : 1.0f;
        m.kd = kd * (1 - metallic);
        m.ks = Lerp(Color(0.04f), kd, metallic) * (1 - roughness);
        const float alpha2 = std::max(roughness * roughness * roughness * roughness, 1e-6f);
        m.phong = std::clamp(2.0f / alpha2 - 2.0f, 1.0f, 1000.0f);
        if (metallic >= 0.9f && roughness <= 0.1f) m.mirror = kd;
    } else {
        m.kd = kd;
        aiColor3D spec(0, 0, 0);
        float strength = 1, shininess = 0, reflectivity = 0;
        am.Get(AI_MATKEY_COLOR_SPECULAR, spec);
        am.Get(AI_MATKEY_SHININESS_STRENGTH, strength);
        am.Get(AI_MATKEY_SHININESS, shininess);
        if (!std::isfinite(strength) || strength < 0) strength = 0;
        m.ks = ToColor(spec) * strength;
        if (std::isfinite(shininess) && shininess > 0) m.phong = std::min(shininess, 10000.0f);
        if (am.Get(AI_MATKEY_REFLECTIVITY, reflectivity) == AI_SUCCESS &&
            std::isfinite(reflectivity) && reflectivity >= 0.5f) {
            aiColor3D reflective(1, 1, 1);
            am.Get(AI_MATKEY_COLOR_REFLECTIVE, reflective);
            m.mirror = ToColor(reflective) * std::min(reflectivity, 1.0f);
        }
    }
    return m;
}

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

// ---------------------------------------------------------------------------------------
// Hardening of the importer: budgets, regular files only, assertions as errors

std::string Thousands(uint64_t n) {
    std::string s = std::to_string(n);
    for (int i = static_cast<int>(s.size()) - 3; i > 0; i -= 3) s.insert(static_cast<size_t>(i), ",");
    return s;
}

/// An Assimp assertion, thrown out of aiAssertViolation (in this process), or written as
/// the child's result (see ImportIsolated).
class AssimpAssertion : public std::runtime_error {
  public:
    using std::runtime_error::runtime_error;
};

/// The child's result file while it imports (-1 in the parent and in-process imports).
int gResultFd = -1;
void WriteErrorResult(int fd, const std::string& reason, bool unreadable);

/// Assimp opens every file of an import through this: the mesh file itself, an OBJ's
/// mtllib, a glTF's buffers, COLLADA's external references. Anything but a regular file is
/// refused (a FIFO with no writer would block forever, /dev/zero never ends), and so is
/// writing.
class RegularFilesOnly : public Assimp::DefaultIOSystem {
  public:
    explicit RegularFilesOnly(std::vector<std::string>* refused) : refused_(refused) {}
    bool Exists(const char* file) const override {
        return file && RegularFileProblem(file, "file").empty();
    }
    Assimp::IOStream* Open(const char* file, const char* mode = "rb") override {
        if (!file) return nullptr;
        if (mode && (std::strchr(mode, 'w') || std::strchr(mode, 'a') || std::strchr(mode, '+'))) {
            refused_->push_back(std::string(file) + ": refused to open for writing");
            return nullptr;
        }
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
                                          ? MaterialFromFile(*scene_.mMaterials[fileIndex])
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
}

// ---------------------------------------------------------------------------------------
// glTF node graphs, checked before Assimp expands them: its importer makes one aiNode per
// path through the graph, recursively, so a cycle or a deep chain overflows its stack and
// 24 levels of nodes sharing two children make 2^24 nodes.

std::string LowerExtension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

/// The JSON of a .gltf, or the JSON chunk of a .glb; "" if it is neither.
std::string GltfJson(const std::string& path, const std::string& ext) {
    std::string bytes;
    try {
        bytes = ReadRegularFile(path, "mesh file");
    } catch (const Error&) {
        return "";
    }
    if (ext == ".gltf") return bytes;
    // .glb: magic "glTF", version, length; chunk 0: length, type "JSON", data.
    if (bytes.size() < 20 || bytes.compare(0, 4, "glTF") != 0) return "";
    uint32_t chunkLength = 0;
    std::memcpy(&chunkLength, bytes.data() + 12, 4);
    if (bytes.compare(16, 4, "JSON") != 0 || chunkLength > bytes.size() - 20) return "";
    return bytes.substr(20, chunkLength);
}

void CheckGltfHierarchy(const std::string& path, const ImportBudget& budget) {
    const std::string ext = LowerExtension(path);
    if (ext != ".gltf" && ext != ".glb") return;
    const std::string text = GltfJson(path, ext);
    if (text.empty()) return;
    const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded() || !j.is_object()) return;  // Assimp reports it
    const auto nodesIt = j.find("nodes");
    if (nodesIt == j.end() || !nodesIt->is_array()) return;
    const nlohmann::json& nodes = *nodesIt;
    const size_t n = nodes.size();
    std::vector<std::vector<size_t>> children(n);
    std::vector<bool> isChild(n, false);
    for (size_t i = 0; i < n; ++i) {
        if (!nodes[i].is_object()) continue;
        const auto c = nodes[i].find("children");
        if (c == nodes[i].end() || !c->is_array()) continue;
        for (const auto& k : *c) {
            if (!k.is_number_unsigned() || k.get<uint64_t>() >= n) continue;  // Assimp reports it
            children[i].push_back(static_cast<size_t>(k.get<uint64_t>()));
            isChild[static_cast<size_t>(k.get<uint64_t>())] = true;
        }
    }
    // Depth-first, without recursion: expanded size and depth of each node's subtree.
    constexpr uint64_t kSaturated = uint64_t(1) << 62;
    std::vector<uint8_t> state(n, 0);  // 0 new, 1 on the stack, 2 done
    std::vector<uint64_t> size(n, 1), depth(n, 1);
    for (size_t start = 0; start < n; ++start) {
        if (state[start]) continue;
        std::vector<std::pair<size_t, size_t>> stack{{start, 0}};
        state[start] = 1;
        while (!stack.empty()) {
            auto& [node, next] = stack.back();
            if (next < children[node].size()) {
                const size_t c = children[node][next++];
                if (state[c] == 1)
                    throw MeshFileError(
                        path,
                        StringPrintf("glTF node %zu is its own descendant: the node hierarchy "
                                     "has a cycle",
                                     c),
                        true);
                if (state[c] == 0) {
                    state[c] = 1;
                    stack.push_back({c, 0});
                }
                continue;
            }
            uint64_t total = 1, deepest = 0;
            for (size_t c : children[node]) {
                total = std::min(kSaturated, total + size[c]);
                deepest = std::max(deepest, depth[c]);
            }
            size[node] = total;
            depth[node] = deepest + 1;
            state[node] = 2;
            stack.pop_back();
        }
    }
    uint64_t instances = 0, deepest = 0;
    for (size_t i = 0; i < n; ++i) {
        if (isChild[i]) continue;
        instances = std::min(kSaturated, instances + size[i]);
        deepest = std::max(deepest, depth[i]);
    }
    if (deepest > budget.depth)
        throw MeshFileError(path,
                            StringPrintf("the glTF node hierarchy is %s levels deep, more than "
                                         "the limit of %u",
                                         Thousands(deepest).c_str(), budget.depth),
                            true);
    if (instances > budget.nodes)
        throw MeshFileError(
            path,
            StringPrintf("the glTF nodes share children so that they expand to %s node "
                         "instances, more than the importer's budget of %s",
                         instances >= kSaturated ? "more than 4.6e18"
                                                 : Thousands(instances).c_str(),
                         Thousands(budget.nodes).c_str()),
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

}  // namespace

ImportBudget ImportBudget::ForThisMachine() {
    ImportBudget b;
    b.memory = PhysicalMemoryBytes() / 2;
    b.triangles = b.memory ? static_cast<size_t>(b.memory / kBytesPerTriangle) : SIZE_MAX;
    b.triangles = std::min<size_t>(b.triangles, size_t(1) << 31);
    b.instances = size_t(1) << 22;
    b.nodes = size_t(1) << 22;
    b.depth = 1024;
    return b;
}

LoadedMesh ImportMeshInProcess(const std::string& path, const MeshLoadOptions& options,
                               const ImportBudget& budget) {
    CheckReadable(path);
    CheckGltfHierarchy(path, budget);
    LoadedMesh out;
    std::vector<std::string> log, refused;
    try {
        ScopedAssimpLog scopedLog(&log);
        Assimp::Importer importer;
        importer.SetIOHandler(new RegularFilesOnly(&refused));
        // Triangulate polygons; split meshes by primitive type so points and lines sit in
        // meshes of their own, which the walk skips. No normals are generated: shading
        // uses face normals where the file has none. Instances are expanded by the walk
        // (not aiProcess_PreTransformVertices) so node names stay available to excludes.
        const unsigned flags = aiProcess_Triangulate | aiProcess_SortByPType |
                               aiProcess_JoinIdenticalVertices | aiProcess_ValidateDataStructure;
        const aiScene* scene = importer.ReadFile(path, flags);
        if (!scene) {
            std::string err = ImportErrorReason(importer.GetErrorString(), budget);
            if (!refused.empty()) err += " (" + refused.front() + ")";
            throw MeshFileError(path, err, true);
        }
        if (!scene->mRootNode)
            throw MeshFileError(path, "the file has no scene graph (no meshes)", true);
        SceneWalker walker(path, *scene, options, budget, &out);
        walker.Walk(*scene->mRootNode);
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
    constexpr size_t MaxLogLines = 5;
    for (size_t i = 0; i < log.size() && i < MaxLogLines; ++i)
        out.warnings.push_back(path + ": " + log[i]);
    if (log.size() > MaxLogLines)
        out.warnings.push_back(
            path + StringPrintf(": ... and %zu more importer messages", log.size() - MaxLogLines));
    return out;
}

namespace {

// ---------------------------------------------------------------------------------------
// The child process: its result, serialised into a memfd

/// The child's result: small fields are copied, large arrays are written in place
/// (writev), so the triangles are copied once on the way to the parent.
class ResultWriter {
  public:
    template <typename T>
    void Pod(const T& v) {
        Bytes(&v, sizeof(T), true);
    }
    void Str(const std::string& s) {
        Pod<uint64_t>(s.size());
        Bytes(s.data(), s.size(), true);
    }
    /// `v` must outlive WriteTo.
    template <typename T>
    void Vec(const std::vector<T>& v) {
        Pod<uint64_t>(v.size());
        Bytes(v.data(), v.size() * sizeof(T), false);
    }
    void Bools(const std::vector<bool>& v) {
        Pod<uint64_t>(v.size());
        std::string b;
        for (bool x : v) b.push_back(x ? 1 : 0);
        Bytes(b.data(), b.size(), true);
    }
    /// Writes everything at offset 0 of `fd`; false on failure.
    bool WriteTo(int fd) const {
        if (ftruncate(fd, 0) != 0 || lseek(fd, 0, SEEK_SET) != 0) return false;
        for (const Piece& p : pieces_) {
            const char* data = p.copied ? copies_[p.index].data() : p.data;
            size_t done = 0;
            while (done < p.size) {
                const ssize_t n = write(fd, data + done, p.size - done);
                if (n < 0 && errno == EINTR) continue;
                if (n <= 0) return false;
                done += static_cast<size_t>(n);
            }
        }
        return true;
    }

  private:
    struct Piece {
        const char* data;
        size_t size;
        bool copied;
        size_t index;
    };
    void Bytes(const void* data, size_t size, bool copy) {
        if (size == 0) return;
        if (copy) {
            // Small fields go into one buffer, extended while no large array comes between.
            if (!pieces_.empty() && pieces_.back().copied) {
                copies_.back().append(static_cast<const char*>(data), size);
                pieces_.back().size += size;
                return;
            }
            copies_.emplace_back(static_cast<const char*>(data), size);
            pieces_.push_back({nullptr, size, true, copies_.size() - 1});
        } else {
            pieces_.push_back({static_cast<const char*>(data), size, false, 0});
        }
    }
    std::vector<Piece> pieces_;
    std::deque<std::string> copies_;
};

class ResultReader {
  public:
    explicit ResultReader(std::string_view bytes) : bytes_(bytes) {}
    template <typename T>
    T Pod() {
        T v{};
        Need(sizeof(T));
        std::memcpy(&v, bytes_.data() + at_, sizeof(T));
        at_ += sizeof(T);
        return v;
    }
    std::string Str() {
        const uint64_t n = Pod<uint64_t>();
        Need(n);
        std::string s(bytes_.substr(at_, n));
        at_ += n;
        return s;
    }
    template <typename T>
    std::vector<T> Vec() {
        const uint64_t n = Pod<uint64_t>();
        if (n > (bytes_.size() - at_) / sizeof(T)) Need(SIZE_MAX);
        std::vector<T> v(n);
        if (n) std::memcpy(v.data(), bytes_.data() + at_, n * sizeof(T));
        at_ += n * sizeof(T);
        return v;
    }
    std::vector<bool> Bools() {
        const uint64_t n = Pod<uint64_t>();
        Need(n);
        std::vector<bool> v(n);
        for (uint64_t i = 0; i < n; ++i) v[i] = bytes_[at_ + i] != 0;
        at_ += n;
        return v;
    }

  private:
    void Need(uint64_t n) const {
        if (n > bytes_.size() - at_) throw std::runtime_error("truncated result");
    }
    std::string_view bytes_;
    size_t at_ = 0;
};

enum : uint8_t { kResultMesh = 1, kResultMeshError = 2 };

void WriteErrorResult(int fd, const std::string& reason, bool unreadable) {
    ResultWriter w;
    w.Pod<uint8_t>(kResultMeshError);
    w.Str(reason);
    w.Pod<uint8_t>(unreadable ? 1 : 0);
    w.WriteTo(fd);
}

void WriteMeshResult(int fd, const LoadedMesh& m) {
    ResultWriter w;
    w.Pod<uint8_t>(kResultMesh);
    w.Vec(m.mesh.positions);
    w.Vec(m.mesh.normals);
    w.Vec(m.mesh.triangles);
    w.Vec(m.mesh.materialIds);
    w.Pod<uint64_t>(m.materials.size());
    for (const Material& mat : m.materials) {
        w.Str(mat.name);
        w.Pod(mat.kd);
        w.Pod(mat.ks);
        w.Pod(mat.phong);
        w.Pod(mat.mirror);
    }
    w.Pod<uint64_t>(m.meshesPlaced);
    w.Pod<uint64_t>(m.meshesExcluded);
    w.Bools(m.excludeMaterialsMatched);
    w.Bools(m.excludeNamesMatched);
    w.Pod<uint64_t>(m.warnings.size());
    for (const std::string& s : m.warnings) w.Str(s);
    if (!w.WriteTo(fd)) _exit(3);
}

LoadedMesh ReadResult(const std::string& path, std::string_view bytes) {
    ResultReader r(bytes);
    const uint8_t kind = r.Pod<uint8_t>();
    if (kind == kResultMeshError) {
        std::string reason = r.Str();
        const bool unreadable = r.Pod<uint8_t>() != 0;
        throw MeshFileError(path, reason, unreadable);
    }
    if (kind != kResultMesh) throw std::runtime_error("bad result");
    LoadedMesh m;
    m.mesh.positions = r.Vec<Vec3>();
    m.mesh.normals = r.Vec<Vec3>();
    m.mesh.triangles = r.Vec<std::array<uint32_t, 3>>();
    m.mesh.materialIds = r.Vec<uint32_t>();
    const uint64_t materials = r.Pod<uint64_t>();
    for (uint64_t i = 0; i < materials; ++i) {
        Material mat;
        mat.name = r.Str();
        mat.kd = r.Pod<Color>();
        mat.ks = r.Pod<Color>();
        mat.phong = r.Pod<float>();
        mat.mirror = r.Pod<Color>();
        m.materials.push_back(std::move(mat));
    }
    m.meshesPlaced = r.Pod<uint64_t>();
    m.meshesExcluded = r.Pod<uint64_t>();
    m.excludeMaterialsMatched = r.Bools();
    m.excludeNamesMatched = r.Bools();
    const uint64_t warnings = r.Pod<uint64_t>();
    for (uint64_t i = 0; i < warnings; ++i) m.warnings.push_back(r.Str());
    return m;
}

/// The address space this process maps now, in bytes (0 if unknown).
uint64_t MappedBytes() {
    FILE* f = std::fopen("/proc/self/statm", "r");
    if (!f) return 0;
    unsigned long long pages = 0;
    const int got = std::fscanf(f, "%llu", &pages);
    std::fclose(f);
    return got == 1 ? pages * static_cast<uint64_t>(sysconf(_SC_PAGE_SIZE)) : 0;
}

const char* SignalName(int sig) {
    switch (sig) {
        case SIGSEGV: return "SIGSEGV: a stack overflow on a deep or cyclic node hierarchy, or a bad memory access";
        case SIGABRT: return "SIGABRT: an internal check failed";
        case SIGBUS: return "SIGBUS";
        case SIGFPE: return "SIGFPE";
        case SIGILL: return "SIGILL";
        case SIGKILL: return "SIGKILL: killed, perhaps by the out-of-memory killer";
        default: return "";
    }
}

/// LIGHTMESH_IMPORT_TIMEOUT (seconds) if set, else 60 s + 2 s per MB of the file (Assimp
/// parses tens of MB per second).
double ImportTimeoutSeconds(const std::string& path) {
    if (const char* env = std::getenv("LIGHTMESH_IMPORT_TIMEOUT"); env && *env) {
        char* end = nullptr;
        const double v = std::strtod(env, &end);
        if (end != env && *end == 0 && v > 0 && v < 1e7) return v;
    }
    struct stat st {};
    const double mb = stat(path.c_str(), &st) == 0 ? static_cast<double>(st.st_size) / 1e6 : 0;
    return 60.0 + 2.0 * mb;
}

LoadedMesh ImportIsolated(const std::string& path, const MeshLoadOptions& options,
                          const ImportBudget& budget) {
    const int fd = memfd_create("lightmesh-import", MFD_CLOEXEC);
    if (fd < 0) return ImportMeshInProcess(path, options, budget);
    // One import at a time forks (another thread must not be inside Assimp's singleton
    // logger when the child copies the process).
    static std::mutex forkMutex;
    std::unique_lock<std::mutex> lock(forkMutex);
    std::fflush(nullptr);
    const uint64_t mappedNow = MappedBytes();
    const pid_t pid = fork();
    if (pid < 0) {
        lock.unlock();
        close(fd);
        return ImportMeshInProcess(path, options, budget);
    }
    if (pid == 0) {
        // The child: import, write the result, _exit (no atexit handlers, no destructors
        // of the parent's objects).
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        for (int sig : {SIGINT, SIGTERM, SIGHUP}) std::signal(sig, SIG_DFL);
#ifndef LIGHTMESH_SANITIZED
        // The sanitizers reserve terabytes of shadow address space: no limit under them.
        if (budget.memory && mappedNow) {
            // At least 64 MiB, for the importer's own working set under a tiny budget.
            const rlim_t limit = static_cast<rlim_t>(
                mappedNow + std::max<uint64_t>(budget.memory, uint64_t(64) << 20));
            struct rlimit rl {limit, limit};
            setrlimit(RLIMIT_AS, &rl);
        }
#endif
        gResultFd = fd;
        try {
            WriteMeshResult(fd, ImportMeshInProcess(path, options, budget));
        } catch (const MeshFileError& e) {
            WriteErrorResult(fd, e.Reason(), e.Unreadable());
        } catch (const std::bad_alloc&) {
            WriteErrorResult(fd, ImportErrorReason("bad_alloc", budget), true);
        } catch (const std::exception& e) {
            WriteErrorResult(fd, StringPrintf("import failed: %s", e.what()), true);
        }
        _exit(0);
    }
    // Some malformed files make Assimp loop forever (a PLY header without end_header, found
    // by fuzz_mesh_import): the child gets a deadline, generous next to any real parse.
    const double timeout = ImportTimeoutSeconds(path);
    int status = 0;
    bool timedOut = false;
    {
        const auto deadline = std::chrono::steady_clock::now() +
                              std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                  std::chrono::duration<double>(timeout));
        const int pidfd = static_cast<int>(syscall(SYS_pidfd_open, pid, 0));
        for (;;) {
            const pid_t done = waitpid(pid, &status, WNOHANG);
            if (done == pid || (done < 0 && errno != EINTR)) break;
            const auto now = std::chrono::steady_clock::now();
            if (now >= deadline) {
                kill(pid, SIGKILL);
                while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
                }
                timedOut = true;
                break;
            }
            const double left = std::chrono::duration<double>(deadline - now).count();
            if (pidfd >= 0) {
                // Readable when the child exits: no polling latency.
                struct pollfd p {pidfd, POLLIN, 0};
                poll(&p, 1, static_cast<int>(std::min(left * 1000.0 + 1, 1e9)));
            } else {
                usleep(static_cast<useconds_t>(std::min(left, 0.002) * 1e6));
            }
        }
        if (pidfd >= 0) close(pidfd);
    }
    lock.unlock();
    if (timedOut) {
        close(fd);
        throw MeshFileError(path,
                            StringPrintf("the importer did not finish within %.0f s and was "
                                         "stopped (Assimp loops forever on some malformed files; "
                                         "LIGHTMESH_IMPORT_TIMEOUT sets the limit in seconds)",
                                         timeout),
                            true);
    }
    // The result, mapped rather than read: one copy, into the vectors.
    void* mapped = MAP_FAILED;
    size_t mappedSize = 0;
    struct stat st {};
    if (fstat(fd, &st) == 0 && st.st_size > 0) {
        mappedSize = static_cast<size_t>(st.st_size);
        mapped = mmap(nullptr, mappedSize, PROT_READ, MAP_PRIVATE, fd, 0);
    }
    close(fd);
    struct Unmap {
        void* p;
        size_t n;
        ~Unmap() {
            if (p != MAP_FAILED) munmap(p, n);
        }
    } unmap{mapped, mappedSize};
    const std::string_view bytes =
        mapped == MAP_FAILED ? std::string_view()
                             : std::string_view(static_cast<const char*>(mapped), mappedSize);
    if (WIFSIGNALED(status)) {
        const int sig = WTERMSIG(status);
        const char* name = SignalName(sig);
        throw MeshFileError(path,
                            StringPrintf("the importer crashed (signal %d%s%s)", sig,
                                         *name ? ", " : "", name),
                            true);
    }
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || bytes.empty())
        throw MeshFileError(path,
                            StringPrintf("the importer crashed (exit status %d)",
                                         WIFEXITED(status) ? WEXITSTATUS(status) : -1),
                            true);
    try {
        return ReadResult(path, bytes);
    } catch (const MeshFileError&) {
        throw;
    } catch (const std::exception&) {
        throw MeshFileError(path, "the importer's result is incomplete (it crashed?)", true);
    }
}

bool InProcessRequested() {
    const char* v = std::getenv("LIGHTMESH_IMPORT_IN_PROCESS");
    return v && *v && std::strcmp(v, "0") != 0;
}

}  // namespace

LoadedMesh LoadMeshFile(const std::string& path, const MeshLoadOptions& options) {
    CheckReadable(path);  // cheap and clear; the child would say the same
    const ImportBudget budget = ImportBudget::ForThisMachine();
    const auto t0 = std::chrono::steady_clock::now();
    LoadedMesh out = InProcessRequested() ? ImportMeshInProcess(path, options, budget)
                                          : ImportIsolated(path, options, budget);
    LogDebug(StringPrintf("%s: imported in %.3f ms (%s)", path.c_str(),
                          std::chrono::duration<double, std::milli>(
                              std::chrono::steady_clock::now() - t0)
                              .count(),
                          InProcessRequested() ? "in process" : "child process"));
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
