#include "lightmesh/util/system.h"

#include <fcntl.h>
#include <sys/resource.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "lightmesh/util/error.h"

namespace lm {
namespace {

// Temporary files being written, for the signal handler. Fixed-size storage, because a
// signal handler may only touch lock-free data and call async-signal-safe functions.
constexpr int kMaxPending = 8;
constexpr size_t kMaxPath = 4096;
char gPending[kMaxPending][kMaxPath];
std::atomic<bool> gPendingUsed[kMaxPending];

int RegisterPending(const std::string& path) {
    if (path.size() >= kMaxPath) return -1;
    for (int i = 0; i < kMaxPending; ++i) {
        bool expected = false;
        if (gPendingUsed[i].compare_exchange_strong(expected, true)) {
            std::memcpy(gPending[i], path.c_str(), path.size() + 1);
            return i;
        }
    }
    return -1;
}

void ReleasePending(int slot) {
    if (slot >= 0) gPendingUsed[slot].store(false);
}

extern "C" void OnInterrupt(int sig) {
    for (int i = 0; i < kMaxPending; ++i)
        if (gPendingUsed[i].load()) unlink(gPending[i]);
    std::signal(sig, SIG_DFL);
    std::raise(sig);
}

std::string FolderOf(const std::string& path) {
    std::filesystem::path p(path);
    std::filesystem::path dir = p.parent_path();
    return dir.empty() ? std::string(".") : dir.string();
}

}  // namespace

void InstallInterruptCleanup() {
    struct sigaction sa {};
    sa.sa_handler = OnInterrupt;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
}

void CheckWritableFolder(const std::string& path) {
    const std::string dir = FolderOf(path);
    std::error_code ec;
    if (!std::filesystem::is_directory(dir, ec))
        ThrowError("%s: folder \"%s\" does not exist", path.c_str(), dir.c_str());
    if (access(dir.c_str(), W_OK) != 0)
        ThrowError("%s: folder \"%s\" is not writable", path.c_str(), dir.c_str());
    if (std::filesystem::is_directory(path, ec))
        ThrowError("%s: is a folder, not a file", path.c_str());
}

void WriteFileAtomically(const std::string& path,
                         const std::function<void(const std::string& tmpPath)>& write) {
    CheckWritableFolder(path);
    const std::filesystem::path p(path);
    const std::string tmp = (std::filesystem::path(FolderOf(path)) /
                             ("." + p.filename().string() + StringPrintf(".tmp%d", getpid())))
                                .string();
    const int slot = RegisterPending(tmp);
    try {
        write(tmp);
        // Flush the data to disk before the rename makes it visible.
        int fd = open(tmp.c_str(), O_RDONLY);
        if (fd >= 0) {
            fsync(fd);
            close(fd);
        }
        if (std::rename(tmp.c_str(), path.c_str()) != 0)
            ThrowError("%s: cannot write: %s", path.c_str(), std::strerror(errno));
    } catch (...) {
        unlink(tmp.c_str());
        ReleasePending(slot);
        throw;
    }
    ReleasePending(slot);
}

uint64_t PeakMemoryBytes() {
    struct rusage usage {};
    if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
    return static_cast<uint64_t>(usage.ru_maxrss) * 1024;  // Linux reports KiB
}

uint64_t ParseByteCount(const std::string& text) {
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(text.c_str(), &end);
    if (end == text.c_str() || errno != 0 || !(v > 0) || v > 1e18) return 0;
    double scale = 1;
    const std::string unit(end);
    if (unit == "K" || unit == "k") scale = 1024.0;
    else if (unit == "M" || unit == "m") scale = 1024.0 * 1024;
    else if (unit == "G" || unit == "g") scale = 1024.0 * 1024 * 1024;
    else if (unit == "T" || unit == "t") scale = 1024.0 * 1024 * 1024 * 1024;
    else if (!unit.empty()) return 0;
    const double bytes = v * scale;
    return bytes < 1.8e19 ? static_cast<uint64_t>(bytes) : 0;
}

uint64_t PhysicalMemoryBytes() {
    const long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
    uint64_t limit = pages > 0 && size > 0 ? static_cast<uint64_t>(pages) * static_cast<uint64_t>(size) : 0;
    auto lower = [&limit](uint64_t bytes) {
        if (bytes > 0 && (limit == 0 || bytes < limit)) limit = bytes;
    };
    // A container's limit: cgroup v2, else v1 (which reports "no limit" as a huge number).
    for (const char* file : {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
        if (FILE* f = std::fopen(file, "r")) {
            char buf[64] = {};
            const bool ok = std::fgets(buf, sizeof buf, f) != nullptr;
            std::fclose(f);
            unsigned long long bytes = 0;
            if (ok && std::sscanf(buf, "%llu", &bytes) == 1) lower(bytes);  // "max": no limit
        }
    }
    if (const char* env = std::getenv("LIGHTMESH_MEMORY_LIMIT"); env && *env) lower(ParseByteCount(env));
    return limit;
}

std::string FormatBytes(uint64_t bytes) {
    const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
    double v = static_cast<double>(bytes);
    int u = 0;
    while (v >= 1024.0 && u < 4) {
        v /= 1024.0;
        ++u;
    }
    return u == 0 ? StringPrintf("%llu B", static_cast<unsigned long long>(bytes))
                  : StringPrintf("%.1f %s", v, units[u]);
}

}  // namespace lm
