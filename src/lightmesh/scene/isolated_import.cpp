// isolated_import.cpp -- LoadMeshFile's import in a child process (fork) whose address space
// is limited to the import budget's memory, with a deadline: an importer crash, assertion,
// allocation bomb or endless loop becomes a MeshFileError. The child runs ImportMeshInProcess
// (assimp_import.cpp) and sends its result back serialised into a memfd.
#include "lightmesh/scene/mesh_import_internal.h"

#include <malloc.h>
#include <sys/mman.h>
#include <sys/stat.h>

#include <algorithm>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "lightmesh/util/error.h"
#include "lightmesh/util/isolated_child.h"

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define LIGHTMESH_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || \
    __has_feature(memory_sanitizer)
#define LIGHTMESH_SANITIZED 1
#endif
#endif

namespace lm {
namespace mesh_import {
namespace {

// ---------------------------------------------------------------------------------------
// The child process: its result, serialised into a memfd

enum : uint8_t { kResultMesh = 1, kResultMeshError = 2 };

}  // namespace

void WriteErrorResult(int fd, const std::string& reason, bool unreadable) {
    ChildWriter w;
    w.Pod<uint8_t>(kResultMeshError);
    w.Str(reason);
    w.Pod<uint8_t>(unreadable ? 1 : 0);
    w.WriteTo(fd);
}

namespace {

void WriteMeshResult(int fd, const LoadedMesh& m) {
    ChildWriter w;
    w.Pod<uint8_t>(kResultMesh);
    w.Vec(m.mesh.positions);
    w.Vec(m.mesh.normals);
    w.Vec(m.mesh.uvs);
    w.Vec(m.mesh.triangles);
    w.Vec(m.mesh.materialIds);
    w.Pod<uint64_t>(m.materials.size());
    for (const Material& mat : m.materials) {
        w.Str(mat.name);
        w.Pod(mat.kd);
        w.Pod(mat.ks);
        w.Pod(mat.phong);
        w.Pod(mat.mirror);
        w.Pod(mat.texture);
        w.Pod(mat.textureScale);
        w.Pod(mat.wrapU);
        w.Pod(mat.wrapV);
        w.Pod(mat.alphaTexture);
        w.Pod(mat.alphaSource);
        w.Pod(mat.alphaCutoff);
        w.Pod(mat.alphaScale);
    }
    w.Pod<uint64_t>(m.textures.size());
    for (const TextureSource& t : m.textures) {
        w.Str(t.file);
        w.Str(t.name);
        w.Str(t.bytes);
        w.Pod(t.rawWidth);
        w.Pod(t.rawHeight);
    }
    w.Pod<uint64_t>(m.meshesPlaced);
    w.Pod<uint64_t>(m.meshesExcluded);
    w.Bools(m.excludeMaterialsMatched);
    w.Bools(m.excludeNamesMatched);
    w.Pod<uint64_t>(m.warnings.size());
    for (const std::string& s : m.warnings) w.Str(s);
    w.Pod<uint64_t>(m.cameras.size());
    for (const FileCamera& c : m.cameras) {
        w.Str(c.name);
        w.Pod(c.position), w.Pod(c.lookAt), w.Pod(c.up);
        w.Pod(c.horizontalFov), w.Pod(c.aspect), w.Pod(c.fov), w.Pod<uint8_t>(c.orthographic);
    }
    w.Pod<uint64_t>(m.lights.size());
    for (const FileLight& l : m.lights) {
        w.Str(l.name);
        w.Pod(l.type);
        w.Str(l.unsupported);
        w.Pod(l.position), w.Pod(l.direction), w.Pod(l.color);
        w.Pod(l.constant), w.Pod(l.linear), w.Pod(l.quadratic), w.Pod(l.inner), w.Pod(l.outer), w.Pod(l.range);
    }
    if (!w.WriteTo(fd)) _exit(3);
}

LoadedMesh ReadResult(const std::string& path, std::string_view bytes) {
    ChildReader r(bytes);
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
    m.mesh.uvs = r.Vec<TexCoord>();
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
        mat.texture = r.Pod<int>();
        mat.textureScale = r.Pod<Color>();
        mat.wrapU = r.Pod<TextureWrap>();
        mat.wrapV = r.Pod<TextureWrap>();
        mat.alphaTexture = r.Pod<int>();
        mat.alphaSource = r.Pod<Material::AlphaSource>();
        mat.alphaCutoff = r.Pod<float>();
        mat.alphaScale = r.Pod<float>();
        m.materials.push_back(std::move(mat));
    }
    const uint64_t textures = r.Pod<uint64_t>();
    for (uint64_t i = 0; i < textures; ++i) {
        TextureSource t;
        t.file = r.Str();
        t.name = r.Str();
        t.bytes = r.Str();
        t.rawWidth = r.Pod<int>();
        t.rawHeight = r.Pod<int>();
        m.textures.push_back(std::move(t));
    }
    for (Material& mat : m.materials)
        if (mat.texture >= static_cast<int>(m.textures.size()) || mat.alphaTexture >= static_cast<int>(m.textures.size()) ||
            static_cast<uint8_t>(mat.alphaSource) > static_cast<uint8_t>(Material::AlphaSource::OpacityMap))
            throw std::runtime_error("bad texture index");
    m.meshesPlaced = r.Pod<uint64_t>();
    m.meshesExcluded = r.Pod<uint64_t>();
    m.excludeMaterialsMatched = r.Bools();
    m.excludeNamesMatched = r.Bools();
    const uint64_t warnings = r.Pod<uint64_t>();
    for (uint64_t i = 0; i < warnings; ++i) m.warnings.push_back(r.Str());
    const uint64_t cameras = r.Pod<uint64_t>();
    for (uint64_t i = 0; i < cameras; ++i) {
        FileCamera c;
        c.name = r.Str();
        c.position = r.Pod<Vec3>(), c.lookAt = r.Pod<Vec3>(), c.up = r.Pod<Vec3>();
        c.horizontalFov = r.Pod<float>(), c.aspect = r.Pod<float>(), c.fov = r.Pod<FileCamera::Fov>();
        if (static_cast<uint8_t>(c.fov) > static_cast<uint8_t>(FileCamera::Fov::GltfYfovTimesAspect))
            throw std::runtime_error("bad camera convention");
        c.orthographic = r.Pod<uint8_t>() != 0;
        m.cameras.push_back(std::move(c));
    }
    const uint64_t lights = r.Pod<uint64_t>();
    for (uint64_t i = 0; i < lights; ++i) {
        FileLight l;
        l.name = r.Str();
        l.type = r.Pod<FileLight::Type>();
        if (static_cast<uint8_t>(l.type) > static_cast<uint8_t>(FileLight::Type::Unsupported))
            throw std::runtime_error("bad light type");
        l.unsupported = r.Str();
        l.position = r.Pod<Vec3>(), l.direction = r.Pod<Vec3>(), l.color = r.Pod<Color>();
        l.constant = r.Pod<float>(), l.linear = r.Pod<float>(), l.quadratic = r.Pod<float>();
        l.inner = r.Pod<float>(), l.outer = r.Pod<float>(), l.range = r.Pod<float>();
        m.lights.push_back(std::move(l));
    }
    return m;
}

/// A crash's signal as the import's message names it.
std::string ImporterSignal(int sig) {
    std::string name = SignalName(sig);
    if (name.rfind("SIG", 0) != 0) return "";
    if (sig == SIGSEGV) name += ": a stack overflow on a deep or cyclic node hierarchy, or a bad memory access";
    if (sig == SIGABRT) name += ": an internal check failed";
    if (sig == SIGKILL) name += ": killed, perhaps by the out-of-memory killer";
    return name;
}

}  // namespace

/// LIGHTMESH_IMPORT_TIMEOUT (seconds) if set, else 60 s + 2 s per MB of the file (Assimp
/// parses tens of MB per second), at most kMaxDefaultImportSeconds (a 20 GB file of zeros
/// had 11 hours).
double ImportTimeoutSeconds(const std::string& path) {
    struct stat st {};
    return ChildDeadlineSeconds(stat(path.c_str(), &st) == 0 ? static_cast<uint64_t>(st.st_size) : 0);
}

namespace {

// Assimp's OBJ and PLY readers fill a line cache of 16 MiB (IOStreamBuffer) however small
// the file: in the fresh child that is 4,096 first touches of 4 KiB pages, about 45 ms
// here per file (three small OBJ files took 0.19 s to load). So the child's large blocks
// come from its heap instead of separate mappings, and the first 48 MiB of that heap ask
// for transparent huge pages (Linux gives them on request, "madvise" mode): 24 faults
// instead. (The same as glibc's tunable glibc.malloc.hugetlb=1, which a running process
// cannot set.) The child exits after one import, so nothing of this reaches the parent.
void HugePagesForTheImporter() {
#ifndef LIGHTMESH_SANITIZED
    constexpr size_t kReserve = size_t(48) << 20, kHuge = size_t(2) << 20;
    mallopt(M_MMAP_THRESHOLD, 256 << 20);  // large blocks from the heap
    mallopt(M_TRIM_THRESHOLD, 512 << 20);  // and the heap kept when they are freed
    void* block = std::malloc(kReserve);
    if (!block) return;
    const uintptr_t begin = (reinterpret_cast<uintptr_t>(block) + kHuge - 1) & ~(kHuge - 1);
    const uintptr_t end = (reinterpret_cast<uintptr_t>(block) + kReserve) & ~(kHuge - 1);
    if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
    std::free(block);
#endif
}

}  // namespace

LoadedMesh ImportIsolated(const std::string& path, const MeshLoadOptions& options,
                          const ImportBudget& budget) {
    // Some malformed files make Assimp loop forever (a PLY header without end_header, found
    // by fuzz_mesh_import): the child gets a deadline, generous next to any real parse.
    const ChildLimits limits{budget.memory, ImportTimeoutSeconds(path)};
    const ChildOutcome child = RunInChild("lightmesh-import", limits, [&](int fd) {
        gResultFd = fd;
        HugePagesForTheImporter();
        try {
            WriteMeshResult(fd, ImportMeshInProcess(path, options, budget));
        } catch (const MeshFileError& e) {
            WriteErrorResult(fd, e.Reason(), e.Unreadable());
        } catch (const std::bad_alloc&) {
            WriteErrorResult(fd, ImportErrorReason("bad_alloc", budget), true);
        } catch (const std::exception& e) {
            WriteErrorResult(fd, StringPrintf("import failed: %s", e.what()), true);
        }
    });
    switch (child.end) {
        case ChildOutcome::End::NotStarted: return ImportMeshInProcess(path, options, budget);
        case ChildOutcome::End::TimedOut: {
            const bool capped =
                limits.seconds >= kMaxDefaultImportSeconds && !std::getenv("LIGHTMESH_IMPORT_TIMEOUT");
            throw MeshFileError(path,
                                StringPrintf("the importer did not finish within %.0f s and was "
                                             "stopped (%s; "
                                             "LIGHTMESH_IMPORT_TIMEOUT sets the limit in seconds)",
                                             limits.seconds,
                                             capped ? "the default limit's most, however large the file"
                                                    : "Assimp loops forever on some malformed files"),
                                true);
        }
        case ChildOutcome::End::Signalled:
            throw MeshFileError(path,
                                StringPrintf("the importer crashed (signal %d%s%s)%s", child.code,
                                             ImporterSignal(child.code).empty() ? "" : ", ",
                                             ImporterSignal(child.code).c_str(), child.Said().c_str()),
                                true);
        case ChildOutcome::End::Exited: break;
    }
    if (child.code != 0 || child.Bytes().empty())
        throw MeshFileError(path, StringPrintf("the importer crashed (exit status %d)%s", child.code, child.Said().c_str()),
                            true);
    try {
        return ReadResult(path, child.Bytes());
    } catch (const MeshFileError&) {
        throw;
    } catch (const std::exception&) {
        throw MeshFileError(path, "the importer's result is incomplete (it crashed?)", true);
    }
}

}  // namespace mesh_import
}  // namespace lm
