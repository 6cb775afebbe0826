// obj_import.cpp -- Wavefront OBJ files read by lightmesh in Assimp's place (Assimp 5.2's
// OBJ reader looks each `o` name up among the objects before it, one by one, so a 12 MB
// file of 200,000 one-triangle objects takes minutes). The OBJ file is parsed
// here, linear in the file, each malformed record an error naming its line; its MTL files
// by tinyobjloader. It is laid out as Assimp's OBJ reader lays it out: a root node named
// after the file, a node per object or group in file order, a mesh per run of faces of one
// material (the first named after the object, the others after their material), polygons
// as polygons, the vertices welded as aiProcess_JoinIdenticalVertices welds them, and the
// materials' properties under Assimp's keys with its defaults. Assimp's other
// post-processing (triangulation, validation) and lightmesh's walk of the scene then run as
// for any format.
#include "lightmesh/scene/mesh_import_internal.h"

#include <assimp/BaseImporter.h>
#include <assimp/DefaultLogger.hpp>
#include <assimp/IOStream.hpp>
#include <assimp/IOSystem.hpp>
#include <assimp/Importer.hpp>
#include <assimp/importerdesc.h>
#include <assimp/material.h>
#include <assimp/scene.h>

#include <tiny_obj_loader.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <string_view>
#include <array>
#include <cstdlib>
#include <bit>
#include <cstdint>
#include <iterator>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "lightmesh/util/hash.h"

namespace lm::mesh_import {
namespace {

const aiImporterDesc kObjDescription = {
    "Wavefront Object (lightmesh's reader, MTL by tinyobjloader)", "", "", "", aiImporterFlags_SupportTextFlavour, 0, 0, 0, 0,
    "obj"};

/// The whole content of `file` through Assimp's IO system (lightmesh's: regular files only,
/// refusals recorded); false if it cannot be opened.
bool ReadThrough(Assimp::IOSystem* io, const std::string& file, std::string* text) {
    Assimp::IOStream* stream = io->Open(file.c_str(), "rb");
    if (!stream) return false;
    text->assign(stream->FileSize(), '\0');
    const size_t got = text->empty() ? 0 : stream->Read(text->data(), 1, text->size());
    io->Close(stream);
    text->resize(got);
    return true;
}

/// What an MTL file states, beyond tinyobjloader's values: tinyobjloader gives a material
/// without Kd a black diffuse and one without Ns a shininess of 1, where Assimp gives 0.6 grey
/// and 0; Pm and Pr make a metallic-roughness material only when stated.
struct Stated {
    std::set<std::string> kd, ns, pm, pr;
};

/// tinyobjloader's mtllib reader: the file beside the OBJ, opened through Assimp's IO system.
class MtlThroughIo final : public tinyobj::MaterialReader {
  public:
    MtlThroughIo(Assimp::IOSystem* io, std::string folder, Stated* stated)
        : io_(io), folder_(std::move(folder)), stated_(stated) {}
    bool operator()(const std::string& name, std::vector<tinyobj::material_t>* materials,
                    std::map<std::string, int>* map, std::string* warn, std::string* err) override {
        // (tinyobjloader's interface; the OBJ parser below calls it for each mtllib file.)
        std::string text;
        if (!ReadThrough(io_, folder_ + name, &text)) {
            *warn += "OBJ: Unable to locate material file " + name + "\n";
            return false;
        }
        std::istringstream in(text);
        tinyobj::LoadMtl(map, materials, &in, warn, err);
        std::istringstream lines(text);
        std::string line, current;
        while (std::getline(lines, line)) {
            std::istringstream words(line);
            std::string key;
            words >> key;
            if (key == "newmtl") {
                std::getline(words >> std::ws, current);
                while (!current.empty() && (current.back() == '\r' || current.back() == ' ')) current.pop_back();
            } else if (key == "Kd") {
                stated_->kd.insert(current);
            } else if (key == "Ns") {
                stated_->ns.insert(current);
            } else if (key == "Pm") {
                stated_->pm.insert(current);
            } else if (key == "Pr") {
                stated_->pr.insert(current);
            }
        }
        return true;
    }

  private:
    Assimp::IOSystem* io_;
    std::string folder_;
    Stated* stated_;
};

void AddColor(aiMaterial* m, const float* c, const char* key, unsigned type, unsigned index) {
    const aiColor3D color(c[0], c[1], c[2]);
    m->AddProperty(&color, 1, key, type, index);
}

void AddTexture(aiMaterial* m, const std::string& name, const tinyobj::texture_option_t& options, aiTextureType type) {
    if (name.empty()) return;
    const aiString path(name);
    m->AddProperty(&path, AI_MATKEY_TEXTURE(type, 0));
    const int uvw = 0;
    m->AddProperty(&uvw, 1, AI_MATKEY_UVWSRC(type, 0));
    if (options.clamp) {
        const int clamp = aiTextureMapMode_Clamp;
        m->AddProperty(&clamp, 1, AI_MATKEY_MAPPINGMODE_U(type, 0));
        m->AddProperty(&clamp, 1, AI_MATKEY_MAPPINGMODE_V(type, 0));
    }
}

/// Assimp's OBJ material for `t` (ObjFileImporter::createMaterials' keys and defaults).
aiMaterial* MakeMaterial(const tinyobj::material_t& t, const Stated& stated) {
    auto* m = new aiMaterial;
    const aiString name(t.name);
    m->AddProperty(&name, AI_MATKEY_NAME);
    const int shading = t.illum == 0 ? aiShadingMode_NoShading : t.illum == 2 ? aiShadingMode_Phong : aiShadingMode_Gouraud;
    m->AddProperty(&shading, 1, AI_MATKEY_SHADING_MODEL);
    const float grey[3] = {0.6f, 0.6f, 0.6f};
    AddColor(m, t.ambient, AI_MATKEY_COLOR_AMBIENT);
    AddColor(m, stated.kd.count(t.name) ? t.diffuse : grey, AI_MATKEY_COLOR_DIFFUSE);
    AddColor(m, t.specular, AI_MATKEY_COLOR_SPECULAR);
    AddColor(m, t.emission, AI_MATKEY_COLOR_EMISSIVE);
    AddColor(m, t.transmittance, AI_MATKEY_COLOR_TRANSPARENT);
    const float shininess = stated.ns.count(t.name) ? t.shininess : 0.0f;
    m->AddProperty(&shininess, 1, AI_MATKEY_SHININESS);
    m->AddProperty(&t.dissolve, 1, AI_MATKEY_OPACITY);
    m->AddProperty(&t.ior, 1, AI_MATKEY_REFRACTI);
    if (stated.pr.count(t.name)) m->AddProperty(&t.roughness, 1, AI_MATKEY_ROUGHNESS_FACTOR);
    if (stated.pm.count(t.name)) m->AddProperty(&t.metallic, 1, AI_MATKEY_METALLIC_FACTOR);
    AddTexture(m, t.diffuse_texname, t.diffuse_texopt, aiTextureType_DIFFUSE);
    AddTexture(m, t.alpha_texname, t.alpha_texopt, aiTextureType_OPACITY);
    AddTexture(m, t.specular_texname, t.specular_texopt, aiTextureType_SPECULAR);
    AddTexture(m, t.ambient_texname, t.ambient_texopt, aiTextureType_AMBIENT);
    AddTexture(m, t.bump_texname, t.bump_texopt, aiTextureType_HEIGHT);
    return m;
}

/// What the OBJ file holds: the vertex data, and the faces in file order with their
/// corners (0-based indices; -1 for no normal or texture coordinates), material (an index
/// into `materials`, -1 for none) and object.
struct ObjData {
    std::vector<float> positions, normals, uvs;  // 3, 3 and 2 a vertex
    struct Corner {
        int64_t v, vt, vn;
    };
    struct Face {
        size_t firstCorner;
        uint32_t corners;
        int material;
        uint32_t object;
    };
    std::vector<Corner> corners;
    std::vector<Face> faces;
    std::vector<std::string> objects = {"defaultobject"};  // faces before any `o` or `g`
    std::vector<tinyobj::material_t> materials;
    std::map<std::string, int> materialIds;
    size_t pointsAndLines = 0;  // `p` and `l` records, and faces of one or two corners
    size_t shortFaces = 0, firstShortFace = 0;  // faces of one or two corners; the first's line
};

/// The OBJ parser: linear in the file (Assimp 5.2's looks each `o` name up among all before
/// it). Every malformed number or index is an error naming its line, where tinyobjloader's
/// parser reads a malformed number as 0. What lightmesh does not draw (curves, smoothing
/// groups, `p` and `l` records, vertex colours) is skipped.
class ObjParser {
  public:
    ObjParser(const std::string& file, ObjData* out, MtlThroughIo* mtl) : file_(file), o_(*out), mtl_(mtl) {}

    void Parse(const std::string& text) {
        size_t at = 0;
        std::string joined;
        while (at < text.size()) {
            size_t end = text.find('\n', at);
            if (end == std::string::npos) end = text.size();
            ++line_;
            std::string_view l(text.data() + at, end - at);
            at = end + 1;
            if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
            if (!l.empty() && l.back() == '\\') {  // continued on the next line
                joined.append(l.substr(0, l.size() - 1)).push_back(' ');
                continue;
            }
            if (!joined.empty()) {
                joined.append(l);
                Line(joined);
                joined.clear();
            } else {
                Line(l);
            }
        }
        if (!joined.empty()) Line(joined);
    }

  private:
    [[noreturn]] void Fail(const std::string& what) const {
        throw std::runtime_error("OBJ: line " + std::to_string(line_) + ": " + what);
    }

    static std::string_view Word(std::string_view* l) {
        const size_t begin = l->find_first_not_of(" \t");
        if (begin == std::string_view::npos) {
            *l = {};
            return {};
        }
        size_t end = l->find_first_of(" \t", begin);
        if (end == std::string_view::npos) end = l->size();
        const std::string_view w = l->substr(begin, end - begin);
        l->remove_prefix(end);
        return w;
    }

    static std::string Rest(std::string_view l) {
        const size_t begin = l.find_first_not_of(" \t"), end = l.find_last_not_of(" \t");
        return begin == std::string_view::npos ? std::string() : std::string(l.substr(begin, end - begin + 1));
    }

    float Number(std::string_view w, const char* record) const {
        if (!w.empty() && w[0] == '+') w.remove_prefix(1);
        float v = 0;
        const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), v);
        if (w.empty() || end != w.data() + w.size() || (ec != std::errc() && ec != std::errc::result_out_of_range))
            Fail(std::string("expected a number in a `") + record + "` record, got \"" + std::string(w) + "\"");
        return ec == std::errc::result_out_of_range ? (w[0] == '-' ? -INFINITY : INFINITY) : v;
    }

    void Numbers(std::string_view l, const char* record, int need, int most, std::vector<float>* into) {
        int got = 0;
        for (std::string_view w = Word(&l); !w.empty() && got < most; w = Word(&l), ++got) into->push_back(Number(w, record));
        if (got < need)
            Fail(std::string("a `") + record + "` record needs " + std::to_string(need) + " numbers, got " +
                 std::to_string(got));
        for (; got < most; ++got) into->push_back(0.0f);  // vt's optional v
    }

    /// Index `w` (1-based, or counted back from the last when negative) among `count`, as
    /// 0-based; -1 for an empty field.
    int64_t Index(std::string_view w, size_t count, const char* what) const {
        if (w.empty()) return -1;
        int64_t i = 0;
        const auto [end, ec] = std::from_chars(w.data(), w.data() + w.size(), i);
        if (ec != std::errc() || end != w.data() + w.size() || i == 0)
            Fail("expected a " + std::string(what) + " index (1, 2, ... or -1, -2, ...) in a face, got \"" +
                 std::string(w) + "\"");
        return i > 0 ? i - 1 : static_cast<int64_t>(count) + i;
    }

    void Face(std::string_view l) {
        const size_t first = o_.corners.size();
        const size_t vertices = o_.positions.size() / 3, uvs = o_.uvs.size() / 2, normals = o_.normals.size() / 3;
        for (std::string_view w = Word(&l); !w.empty(); w = Word(&l)) {
            const size_t s1 = w.find('/'), s2 = s1 == std::string_view::npos ? s1 : w.find('/', s1 + 1);
            const int64_t v = Index(w.substr(0, s1), vertices, "vertex");
            if (v < 0 || static_cast<size_t>(v) >= vertices)
                Fail("face corner \"" + std::string(w) + "\" refers to vertex " + std::to_string(v + 1) + ", but " +
                     std::to_string(vertices) + (vertices == 1 ? " vertex is" : " vertices are") + " defined before it");
            int64_t vt = s1 == std::string_view::npos ? -1 : Index(w.substr(s1 + 1, s2 - s1 - 1), uvs, "texture");
            int64_t vn = s2 == std::string_view::npos ? -1 : Index(w.substr(s2 + 1), normals, "normal");
            // A texture or normal index past those defined drops them from the mesh, as
            // Assimp's reader does (its `uvok`, `normalsok`).
            if (vt >= static_cast<int64_t>(uvs)) vt = -2;
            if (vn >= static_cast<int64_t>(normals)) vn = -2;
            o_.corners.push_back({v, vt, vn});
        }
        const size_t n = o_.corners.size() - first;
        if (n < 3) {
            ++o_.pointsAndLines;
            if (o_.shortFaces++ == 0) o_.firstShortFace = line_;
            o_.corners.resize(first);
            return;
        }
        o_.faces.push_back({first, static_cast<uint32_t>(n), material_, static_cast<uint32_t>(o_.objects.size() - 1)});
    }

    void Line(std::string_view l) {
        if (const size_t hash = l.find('#'); hash != std::string_view::npos) l = l.substr(0, hash);
        const std::string_view key = Word(&l);
        if (key.empty()) return;
        if (key == "v") {
            Numbers(l, "v", 3, 3, &o_.positions);
        } else if (key == "vn") {
            Numbers(l, "vn", 3, 3, &o_.normals);
        } else if (key == "vt") {
            Numbers(l, "vt", 1, 2, &o_.uvs);
        } else if (key == "f") {
            Face(l);
        } else if (key == "o" || key == "g") {
            // Assimp makes an object of every `o` and `g` record (a group's names joined).
            std::string name = Rest(l);
            if (key == "g") {
                name.clear();
                for (std::string_view w = Word(&l); !w.empty(); w = Word(&l)) name += (name.empty() ? "" : " ") + std::string(w);
            }
            o_.objects.push_back(name);
        } else if (key == "usemtl") {
            // A name no mtllib file defines is a material of Assimp's defaults (0.6 grey).
            const std::string name = Rest(l);
            auto it = o_.materialIds.find(name);
            if (it == o_.materialIds.end()) {
                Assimp::DefaultLogger::get()->warn(("OBJ: material \"" + name + "\" (line " + std::to_string(line_) +
                                                    ") is in no mtllib file; Assimp's default grey is used")
                                                       .c_str());
                tinyobj::material_t m{};
                m.name = name;
                m.dissolve = m.ior = 1;
                m.illum = 1;
                o_.materials.push_back(m);
                it = o_.materialIds.emplace(name, static_cast<int>(o_.materials.size() - 1)).first;
            }
            material_ = it->second;
        } else if (key == "mtllib") {
            for (std::string_view w = Word(&l); !w.empty(); w = Word(&l)) {
                std::string warn, err;
                (*mtl_)(std::string(w), &o_.materials, &o_.materialIds, &warn, &err);
                std::istringstream lines(warn + err);
                for (std::string m; std::getline(lines, m);)
                    if (!m.empty()) Assimp::DefaultLogger::get()->warn(m.c_str());
            }
        } else if (key == "p" || key == "l") {
            ++o_.pointsAndLines;
        }
    }

    const std::string& file_;
    ObjData& o_;
    MtlThroughIo* mtl_;
    size_t line_ = 0;
    int material_ = -1;
};

/// A run of faces [first, end) of one material: a mesh as Assimp's OBJ reader and its
/// aiProcess_JoinIdenticalVertices make it, polygons as polygons; null if the run has no
/// surface (points and lines are not surfaces).
aiMesh* MakeMesh(const ObjData& o, size_t first, size_t end, const std::string& name, unsigned material) {
    size_t corners = 0, faces = 0;
    bool normals = true, uvs = true, polygons = false;
    for (size_t f = first; f < end; ++f) {
        const ObjData::Face& face = o.faces[f];
        if (face.corners < 3) continue;
        ++faces;
        corners += face.corners;
        polygons |= face.corners > 3;
        for (size_t c = face.firstCorner; c < face.firstCorner + face.corners; ++c) {
            const ObjData::Corner& k = o.corners[c];
            normals &= k.vn >= 0 && 3 * static_cast<size_t>(k.vn) + 2 < o.normals.size();
            uvs &= k.vt >= 0 && 2 * static_cast<size_t>(k.vt) + 1 < o.uvs.size();
        }
    }
    if (faces == 0) return nullptr;
    if (corners > AI_MAX_VERTICES) throw std::runtime_error("OBJ: too many vertices");
    // A vertex per distinct (position, normal, texture coordinates) in order of first use,
    // which is what aiProcess_JoinIdenticalVertices makes of Assimp's vertex per corner
    // (but for values within its epsilon of each other, which it merges too): done here by
    // hashing, it costs a tenth of what that step took (2.2 s on 600,000 corners).
    // An open-addressed table of indices into `unique` (a node-based map's allocations and
    // cache misses cost 0.5 s on 600,000 corners).
    using Key = std::array<float, 8>;
    auto hash = [](const Key& k) {
        uint64_t h = 0;
        for (int i = 0; i < 8; i += 2) {  // splitmix64's finaliser over pairs of floats
            uint64_t x = h + (uint64_t(std::bit_cast<uint32_t>(k[i])) << 32 | std::bit_cast<uint32_t>(k[i + 1])) +
                         0x9e3779b97f4a7c15ull;
            h = Mix64(x);
        }
        return h;
    };
    size_t slots = 16;
    while (slots < 2 * corners) slots *= 2;
    std::vector<uint32_t> table(slots, UINT32_MAX);
    std::vector<Key> unique;
    std::vector<unsigned> cornerIds;
    cornerIds.reserve(corners);
    auto value = [](float f) { return f == 0.0f ? 0.0f : f; };  // -0 and 0 are one value
    for (size_t f = first; f < end; ++f) {
        const ObjData::Face& face = o.faces[f];
        if (face.corners < 3) continue;
        for (size_t c = face.firstCorner; c < face.firstCorner + face.corners; ++c) {
            const ObjData::Corner& k = o.corners[c];
            Key key{};
            for (int i = 0; i < 3; ++i) key[i] = value(o.positions[3 * static_cast<size_t>(k.v) + i]);
            if (normals)
                for (int i = 0; i < 3; ++i) key[3 + i] = value(o.normals[3 * static_cast<size_t>(k.vn) + i]);
            if (uvs)
                for (int i = 0; i < 2; ++i) key[6 + i] = value(o.uvs[2 * static_cast<size_t>(k.vt) + i]);
            size_t slot = hash(key) & (slots - 1);
            while (table[slot] != UINT32_MAX && unique[table[slot]] != key) slot = (slot + 1) & (slots - 1);
            if (table[slot] == UINT32_MAX) {
                table[slot] = static_cast<uint32_t>(unique.size());
                unique.push_back(key);
            }
            cornerIds.push_back(table[slot]);
        }
    }
    auto m = std::make_unique<aiMesh>();
    m->mName = aiString(name);
    m->mMaterialIndex = material;
    m->mPrimitiveTypes = aiPrimitiveType_TRIANGLE | (polygons ? aiPrimitiveType_POLYGON : 0);
    m->mNumVertices = static_cast<unsigned>(unique.size());
    m->mVertices = new aiVector3D[unique.size()];
    if (normals) m->mNormals = new aiVector3D[unique.size()];
    if (uvs) {
        m->mTextureCoords[0] = new aiVector3D[unique.size()];
        m->mNumUVComponents[0] = 2;
    }
    for (size_t v = 0; v < unique.size(); ++v) {
        const Key& k = unique[v];
        m->mVertices[v] = aiVector3D(k[0], k[1], k[2]);
        if (normals) m->mNormals[v] = aiVector3D(k[3], k[4], k[5]);
        if (uvs) m->mTextureCoords[0][v] = aiVector3D(k[6], k[7], 0);
    }
    m->mNumFaces = static_cast<unsigned>(faces);
    m->mFaces = new aiFace[faces];
    aiFace* out = m->mFaces;
    const unsigned* id = cornerIds.data();
    for (size_t f = first; f < end; ++f) {
        const uint32_t n = o.faces[f].corners;
        if (n < 3) continue;
        out->mNumIndices = n;
        out->mIndices = new unsigned[n];
        std::copy(id, id + n, out->mIndices);
        id += n;
        ++out;
    }
    return m.release();
}

class TinyObjImporter final : public Assimp::BaseImporter {
  public:
    bool CanRead(const std::string& file, Assimp::IOSystem* io, bool checkSig) const override {
        static const char* tokens[] = {"mtllib", "usemtl", "v ", "vt ", "vn ", "o ", "g ", "s ", "f "};
        if (!checkSig) return SimpleExtensionCheck(file, "obj");
        return SearchFileHeaderForToken(io, file, tokens, std::size(tokens), 200, false, true);
    }
    const aiImporterDesc* GetInfo() const override { return &kObjDescription; }
    void SetupProperties(const Assimp::Importer* importer) override {
        merge_ = importer->GetPropertyBool(kObjMergeObjects, false);
    }

  protected:
    void InternReadFile(const std::string& file, aiScene* scene, Assimp::IOSystem* io) override {
        std::string text;
        if (!ReadThrough(io, file, &text)) throw std::runtime_error("Failed to open file " + file + ".");
        const size_t slash = file.find_last_of('/');
        Stated stated;
        MtlThroughIo mtl(io, slash == std::string::npos ? std::string() : file.substr(0, slash + 1), &stated);
        ObjData o;
        ObjParser(file, &o, &mtl).Parse(text);
        if (o.shortFaces > 0)
            Assimp::DefaultLogger::get()->warn(
                ("OBJ: " + std::to_string(o.shortFaces) + (o.shortFaces == 1 ? " face" : " faces") +
                 " of fewer than 3 corners left out (line " + std::to_string(o.firstShortFace) +
                 (o.shortFaces == 1 ? "" : " the first") + "; is the file truncated?)")
                    .c_str());
        if (o.faces.empty() && o.pointsAndLines == 0 && !o.positions.empty())  // (none: "no meshes found")
            throw std::runtime_error("OBJ: " + std::to_string(o.positions.size() / 3) +
                                     " vertices but no faces (is the file truncated?)");
        if (o.faces.empty() && o.pointsAndLines > 0 && o.positions.size() >= 3) {
            // Points and lines only: one line mesh, which the walk drops and counts, so the
            // file is "no triangles (only points/lines)" as with Assimp's reader.
            auto* m = new aiMesh;
            m->mPrimitiveTypes = aiPrimitiveType_POINT;
            m->mNumVertices = 1;
            m->mVertices = new aiVector3D[1]{aiVector3D(o.positions[0], o.positions[1], o.positions[2])};
            m->mNumFaces = 1;
            m->mFaces = new aiFace[1];
            m->mFaces[0].mNumIndices = 1;
            m->mFaces[0].mIndices = new unsigned[1]{0};
            scene->mNumMeshes = 1;
            scene->mMeshes = new aiMesh*[1]{m};
            scene->mNumMaterials = 1;
            scene->mMaterials = new aiMaterial*[1]{new aiMaterial};
            scene->mRootNode = new aiNode("points and lines");
            scene->mRootNode->mNumMeshes = 1;
            scene->mRootNode->mMeshes = new unsigned[1]{0};
            return;
        }

        // Materials: Assimp's default first (faces without usemtl, or naming an unknown one).
        scene->mNumMaterials = static_cast<unsigned>(o.materials.size() + 1);
        scene->mMaterials = new aiMaterial*[scene->mNumMaterials];
        tinyobj::material_t standIn{};  // Assimp's defaults: no colour but the grey, opaque
        standIn.name = AI_DEFAULT_MATERIAL_NAME;
        standIn.dissolve = standIn.ior = 1;
        standIn.illum = 1;
        scene->mMaterials[0] = MakeMaterial(standIn, stated);
        for (size_t i = 0; i < o.materials.size(); ++i) scene->mMaterials[i + 1] = MakeMaterial(o.materials[i], stated);

        // A node per object (or group) and a mesh per run of faces of one material, the
        // first named after the object, the others after their material; merged, the runs
        // of one material whatever their object, on the root node.
        std::vector<aiMesh*> meshes;
        std::vector<std::vector<unsigned>> placed(o.objects.size() + 1);  // the last: the root's
        auto materialOf = [&](int id) {
            return id >= 0 && static_cast<size_t>(id) < o.materials.size() ? static_cast<unsigned>(id + 1) : 0u;
        };
        std::vector<char> named(o.objects.size(), 0);  // an object's first mesh is named after it
        try {
            for (size_t f = 0; f < o.faces.size();) {
                const ObjData::Face& face = o.faces[f];
                size_t end = f + 1;
                while (end < o.faces.size() && o.faces[end].material == face.material &&
                       (merge_ || o.faces[end].object == face.object))
                    ++end;
                std::vector<unsigned>& into = merge_ ? placed.back() : placed[face.object];
                const unsigned material = materialOf(face.material);
                const std::string name = !named[face.object] ? o.objects[face.object]
                                         : material ? o.materials[material - 1].name
                                                    : std::string(AI_DEFAULT_MATERIAL_NAME);
                named[face.object] = 1;
                if (aiMesh* m = MakeMesh(o, f, end, name, material)) {
                    into.push_back(static_cast<unsigned>(meshes.size()));
                    meshes.push_back(m);
                }
                f = end;
            }
        } catch (...) {
            for (aiMesh* m : meshes) delete m;
            throw;
        }
        if (!meshes.empty()) {
            scene->mNumMeshes = static_cast<unsigned>(meshes.size());
            scene->mMeshes = new aiMesh*[meshes.size()];
            std::copy(meshes.begin(), meshes.end(), scene->mMeshes);
        }
        auto attach = [](aiNode* node, const std::vector<unsigned>& ids) {
            if (ids.empty()) return;
            node->mNumMeshes = static_cast<unsigned>(ids.size());
            node->mMeshes = new unsigned[ids.size()];
            std::copy(ids.begin(), ids.end(), node->mMeshes);
        };
        scene->mRootNode = new aiNode(slash == std::string::npos ? file : file.substr(slash + 1));
        attach(scene->mRootNode, placed.back());
        if (merge_) return;
        // Assimp's nodes: an object or group without faces is a node of its own too, but
        // the one for faces before any `o` or `g` only if there are such faces.
        const size_t firstNode = placed[0].empty() ? 1 : 0;
        if (o.objects.size() == firstNode) return;
        scene->mRootNode->mNumChildren = static_cast<unsigned>(o.objects.size() - firstNode);
        scene->mRootNode->mChildren = new aiNode*[scene->mRootNode->mNumChildren];
        for (size_t i = firstNode; i < o.objects.size(); ++i) {
            auto* node = new aiNode(o.objects[i]);
            node->mParent = scene->mRootNode;
            attach(node, placed[i]);
            scene->mRootNode->mChildren[i - firstNode] = node;
        }
    }

  private:
    bool merge_ = false;
};

}  // namespace

bool UseTinyObjReader(Assimp::Importer* importer) {
    if (const char* v = std::getenv("LIGHTMESH_OBJ_READER"); v && std::string(v) == "assimp") return false;
    if (Assimp::BaseImporter* assimps = importer->GetImporter("obj")) {
        importer->UnregisterLoader(assimps);
        delete assimps;  // unregistered loaders are the caller's
    }
    importer->RegisterLoader(new TinyObjImporter);
    return true;
}

bool HasObjExtension(const std::string& path) {
    return Assimp::BaseImporter::SimpleExtensionCheck(path, "obj");
}

}  // namespace lm::mesh_import
