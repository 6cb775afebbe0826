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

// The imported mesh's fields, in the order they are written and read (ChildFieldWriter):
// listed once, for both directions. M is LoadedMesh, or const LoadedMesh to write it.
template <typename Archive, typename M>
void MaterialFields(Archive& a, M& mat) {
    a(mat.name, mat.kd, mat.ks, mat.phong, mat.mirror, mat.texture, mat.textureScale, mat.wrapU, mat.wrapV,
      mat.alphaTexture, mat.alphaSource, mat.alphaCutoff, mat.alphaScale);
}

template <typename Archive, typename T>
void TextureSourceFields(Archive& a, T& t) {
    a(t.file, t.name, t.bytes, t.rawWidth, t.rawHeight);
}

template <typename Archive, typename C>
void CameraFields(Archive& a, C& c) {
    a(c.name, c.position, c.lookAt, c.up, c.horizontalFov, c.aspect, c.fov, c.orthographic);
}

template <typename Archive, typename L>
void LightFields(Archive& a, L& l) {
    a(l.name, l.type, l.unsupported, l.position, l.direction, l.color, l.constant, l.linear, l.quadratic, l.inner,
      l.outer, l.range);
}

template <typename Archive, typename M>
void LoadedMeshFields(Archive& a, M& m) {
    a(m.mesh.positions, m.mesh.normals, m.mesh.uvs, m.mesh.triangles, m.mesh.materialIds);
    a.List(m.materials, [&](auto& mat) { MaterialFields(a, mat); });
    a.List(m.textures, [&](auto& t) { TextureSourceFields(a, t); });
    a(m.meshesPlaced, m.meshesExcluded, m.excludeMaterialsMatched, m.excludeNamesMatched, m.warnings);
    a.List(m.cameras, [&](auto& c) { CameraFields(a, c); });
    a.List(m.lights, [&](auto& l) { LightFields(a, l); });
}

void WriteMeshResult(int fd, const LoadedMesh& m) {
    ChildWriter w;
    w.Pod<uint8_t>(kResultMesh);
    ChildFieldWriter fields(&w);
    LoadedMeshFields(fields, m);
    if (!w.WriteTo(fd)) _exit(3);
}

/// Throws std::runtime_error when a read mesh's indices or enumerations are out of range.
void CheckReadMesh(const LoadedMesh& m) {
    for (const Material& mat : m.materials)
        if (mat.texture >= static_cast<int>(m.textures.size()) || mat.alphaTexture >= static_cast<int>(m.textures.size()) ||
            static_cast<uint8_t>(mat.alphaSource) > static_cast<uint8_t>(Material::AlphaSource::OpacityMap))
            throw std::runtime_error("bad texture index");
    for (const FileCamera& c : m.cameras)
        if (static_cast<uint8_t>(c.fov) > static_cast<uint8_t>(FileCamera::Fov::GltfYfovTimesAspect))
            throw std::runtime_error("bad camera convention");
    for (const FileLight& l : m.lights)
        if (static_cast<uint8_t>(l.type) > static_cast<uint8_t>(FileLight::Type::Unsupported))
            throw std::runtime_error("bad light type");
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
    ChildFieldReader fields(&r);
    LoadedMeshFields(fields, m);
    CheckReadMesh(m);
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
