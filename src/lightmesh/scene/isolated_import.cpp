// isolated_import.cpp -- LoadMeshFile's import in a child process (fork) whose address space
// is limited to the import budget's memory, with a deadline: an importer crash, assertion,
// allocation bomb or endless loop becomes a MeshFileError. The child runs ImportMeshInProcess
// (assimp_import.cpp) and sends its result back serialised into a memfd.
#include "lightmesh/scene/mesh_import_internal.h"

#include <malloc.h>
#include <poll.h>
#include <signal.h>
#include <sys/syscall.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <mutex>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "lightmesh/util/error.h"

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

}  // namespace

void WriteErrorResult(int fd, const std::string& reason, bool unreadable) {
    ResultWriter w;
    w.Pod<uint8_t>(kResultMeshError);
    w.Str(reason);
    w.Pod<uint8_t>(unreadable ? 1 : 0);
    w.WriteTo(fd);
}

namespace {

void WriteMeshResult(int fd, const LoadedMesh& m) {
    ResultWriter w;
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

}  // namespace

/// LIGHTMESH_IMPORT_TIMEOUT (seconds) if set, else 60 s + 2 s per MB of the file (Assimp
/// parses tens of MB per second), at most kMaxDefaultImportSeconds (a 20 GB file of zeros
/// had 11 hours).
double ImportTimeoutSeconds(const std::string& path) {
    if (const char* env = std::getenv("LIGHTMESH_IMPORT_TIMEOUT"); env && *env) {
        char* end = nullptr;
        const double v = std::strtod(env, &end);
        if (end != env && *end == 0 && v > 0 && v < 1e7) return v;
    }
    struct stat st {};
    const double mb = stat(path.c_str(), &st) == 0 ? static_cast<double>(st.st_size) / 1e6 : 0;
    return std::min(60.0 + 2.0 * mb, kMaxDefaultImportSeconds);
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
        const bool capped = timeout >= kMaxDefaultImportSeconds && !std::getenv("LIGHTMESH_IMPORT_TIMEOUT");
        throw MeshFileError(path,
                            StringPrintf("the importer did not finish within %.0f s and was "
                                         "stopped (%s; "
                                         "LIGHTMESH_IMPORT_TIMEOUT sets the limit in seconds)",
                                         timeout,
                                         capped ? "the default limit's most, however large the file"
                                                : "Assimp loops forever on some malformed files"),
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

}  // namespace mesh_import
}  // namespace lm
