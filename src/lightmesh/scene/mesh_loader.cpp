#include "lightmesh/scene/mesh_loader.h"

#include <assimp/DefaultLogger.hpp>
#include <assimp/Importer.hpp>
#include <assimp/LogStream.hpp>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <unordered_map>

namespace lm {

// ---------------------------------------------------------------------------------------
// Affine transforms

Affine Affine::Scale(const Vec3& s) {
    Affine a;
    for (int i = 0; i < 3; ++i) a.m[i][i] = s[i];
    return a;
}

Affine Affine::Rotate(const Vec3& axis, float degrees) {
    // Rodrigues' formula: R = cos·I + sin·[k]× + (1 − cos)·k kᵀ.
    const Vec3 k = Normalize(axis);
    const double rad = static_cast<double>(degrees) * 3.14159265358979323846 / 180.0;
    const float c = static_cast<float>(std::cos(rad)), s = static_cast<float>(std::sin(rad));
    const float t = 1 - c;
    Affine a;
    a.m[0][0] = c + t * k.x * k.x;
    a.m[0][1] = t * k.x * k.y - s * k.z;
    a.m[0][2] = t * k.x * k.z + s * k.y;
    a.m[1][0] = t * k.x * k.y + s * k.z;
    a.m[1][1] = c + t * k.y * k.y;
    a.m[1][2] = t * k.y * k.z - s * k.x;
    a.m[2][0] = t * k.x * k.z - s * k.y;
    a.m[2][1] = t * k.y * k.z + s * k.x;
    a.m[2][2] = c + t * k.z * k.z;
    return a;
}

Affine Affine::Translate(const Vec3& t) {
    Affine a;
    for (int i = 0; i < 3; ++i) a.m[i][3] = t[i];
    return a;
}

Affine Affine::operator*(const Affine& b) const {
    Affine r;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 4; ++j) {
            double v = j == 3 ? m[i][3] : 0.0;
            for (int k = 0; k < 3; ++k) v += static_cast<double>(m[i][k]) * b.m[k][j];
            r.m[i][j] = static_cast<float>(v);
        }
    }
    return r;
}

Vec3 Affine::ApplyPoint(const Vec3& p) const {
    return ApplyVector(p) + Vec3(m[0][3], m[1][3], m[2][3]);
}

Vec3 Affine::ApplyVector(const Vec3& v) const {
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
            m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
}

float Affine::Determinant() const {
    const double d =
        static_cast<double>(m[0][0]) *
            (static_cast<double>(m[1][1]) * m[2][2] - static_cast<double>(m[1][2]) * m[2][1]) -
        static_cast<double>(m[0][1]) *
            (static_cast<double>(m[1][0]) * m[2][2] - static_cast<double>(m[1][2]) * m[2][0]) +
        static_cast<double>(m[0][2]) *
            (static_cast<double>(m[1][0]) * m[2][1] - static_cast<double>(m[1][1]) * m[2][0]);
    return static_cast<float>(d);
}

void TransformMesh(TriangleMesh* mesh, const Affine& t) {
    for (Vec3& p : mesh->positions) p = t.ApplyPoint(p);
    if (!mesh->normals.empty()) {
        // Normals transform by the inverse transpose of the linear part; the cofactor
        // matrix is that times det, and the scale disappears when renormalising. Its sign
        // is kept (multiplying by sign(det)) so a normal stays on the same side.
        const float(*a)[4] = t.m;
        const float cof[3][3] = {
            {a[1][1] * a[2][2] - a[1][2] * a[2][1], a[1][2] * a[2][0] - a[1][0] * a[2][2],
             a[1][0] * a[2][1] - a[1][1] * a[2][0]},
            {a[0][2] * a[2][1] - a[0][1] * a[2][2], a[0][0] * a[2][2] - a[0][2] * a[2][0],
             a[0][1] * a[2][0] - a[0][0] * a[2][1]},
            {a[0][1] * a[1][2] - a[0][2] * a[1][1], a[0][2] * a[1][0] - a[0][0] * a[1][2],
             a[0][0] * a[1][1] - a[0][1] * a[1][0]}};
        const float sign = t.Determinant() < 0 ? -1.0f : 1.0f;
        for (Vec3& n : mesh->normals) {
            const Vec3 r(cof[0][0] * n.x + cof[0][1] * n.y + cof[0][2] * n.z,
                         cof[1][0] * n.x + cof[1][1] * n.y + cof[1][2] * n.z,
                         cof[2][0] * n.x + cof[2][1] * n.y + cof[2][2] * n.z);
            const float len = Length(r);
            n = len > 0 ? r * (sign / len) : r;
        }
    }
    if (t.Determinant() < 0)
        for (auto& tri : mesh->triangles) std::swap(tri[1], tri[2]);
}

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
                LoadedMesh* out)
        : path_(path), scene_(scene), options_(options), out_(out) {
        out_->excludeMaterialsMatched.assign(options.excludeMaterials.size(), false);
        out_->excludeNamesMatched.assign(options.excludeNames.size(), false);
    }

    void Walk(const aiNode& node, const aiMatrix4x4& parent, bool excludedByAncestor) {
        const aiMatrix4x4 transform = parent * node.mTransformation;
        const bool excluded =
            MatchesAny(options_.excludeNames, node.mName.C_Str(), &out_->excludeNamesMatched) ||
            excludedByAncestor;
        for (unsigned i = 0; i < node.mNumMeshes; ++i) {
            if (node.mMeshes[i] >= scene_.mNumMeshes) continue;
            PlaceMesh(*scene_.mMeshes[node.mMeshes[i]], transform, excluded);
        }
        for (unsigned i = 0; i < node.mNumChildren; ++i)
            if (node.mChildren[i]) Walk(*node.mChildren[i], transform, excluded);
    }

    size_t nonTriangleMeshes = 0;  ///< meshes of points or lines seen (and dropped)

  private:
    void PlaceMesh(const aiMesh& am, const aiMatrix4x4& transform, bool excludedByNode) {
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
    LoadedMesh* out_;
    std::unordered_map<unsigned, uint32_t> materialMap_;
};

// Checks what Assimp would report less clearly: a missing file, a directory, an empty or
// unreadable file.
void CheckReadable(const std::string& path) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::file_status status = fs::status(path, ec);
    if (!fs::exists(status)) throw MeshFileError(path, "no such file", true);
    if (fs::is_directory(status))
        throw MeshFileError(path, "is a directory, not a mesh file", true);
    if (!fs::is_regular_file(status)) throw MeshFileError(path, "is not a regular file", true);
    std::ifstream in(path, std::ios::binary);
    if (!in) throw MeshFileError(path, StringPrintf("cannot open: %s", std::strerror(errno)), true);
    const auto size = fs::file_size(path, ec);
    if (!ec && size == 0) throw MeshFileError(path, "the file is empty", true);
}

}  // namespace

LoadedMesh LoadMeshFile(const std::string& path, const MeshLoadOptions& options) {
    CheckReadable(path);
    LoadedMesh out;
    std::vector<std::string> log;
    try {
        ScopedAssimpLog scopedLog(&log);
        Assimp::Importer importer;
        // Triangulate polygons; split meshes by primitive type so points and lines sit in
        // meshes of their own, which the walk skips. No normals are generated: shading
        // uses face normals where the file has none. Instances are expanded by the walk
        // (not aiProcess_PreTransformVertices) so node names stay available to excludes.
        const unsigned flags = aiProcess_Triangulate | aiProcess_SortByPType |
                               aiProcess_JoinIdenticalVertices | aiProcess_ValidateDataStructure;
        const aiScene* scene = importer.ReadFile(path, flags);
        if (!scene) {
            std::string err = importer.GetErrorString();
            if (err.rfind("No suitable reader found", 0) == 0)
                err = "Assimp has no reader for this file format";
            if (err.find("mNumMeshes is 0") != std::string::npos)
                err = "no meshes found in it (is the file really in this format?)";
            else if (err.find("contains no faces") != std::string::npos)
                err = "a mesh in it has no faces (is the file truncated?)";
            else if (err.rfind("Validation failed: ", 0) == 0)
                err = "malformed or truncated (Assimp: " + err.substr(19) + ")";
            if (err.empty()) err = "Assimp could not import it";
            throw MeshFileError(path, err, true);
        }
        if (!scene->mRootNode)
            throw MeshFileError(path, "the file has no scene graph (no meshes)", true);
        SceneWalker walker(path, *scene, options, &out);
        walker.Walk(*scene->mRootNode, aiMatrix4x4(), false);
        if (out.mesh.TriangleCount() == 0 && out.meshesExcluded == 0) {
            throw MeshFileError(
                path,
                walker.nonTriangleMeshes > 0 ? "no triangles (only points/lines)" : "no triangles",
                false);
        }
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        // Assimp catches its own import errors, but allocation failures and the like can
        // still escape; they must not cross LoadMeshFile as anything but an Error.
        throw MeshFileError(path, StringPrintf("import failed: %s", e.what()), true);
    }
    // Keep a handful of the importer's complaints; a broken file can produce thousands.
    constexpr size_t MaxLogLines = 5;
    for (size_t i = 0; i < log.size() && i < MaxLogLines; ++i)
        out.warnings.push_back(path + ": " + log[i]);
    if (log.size() > MaxLogLines)
        out.warnings.push_back(
            path + StringPrintf(": ... and %zu more importer messages", log.size() - MaxLogLines));
    return out;
}

}  // namespace lm
