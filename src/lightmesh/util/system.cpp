#include "lightmesh/util/system.h"

#include <dirent.h>
#include <fcntl.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <new>
#include <string_view>

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

// What the handler says on SIGINT/SIGTERM (SetInterruptMessage), and whether a progress
// bar's line is open on stderr (SetInterruptLineOpen): it ends that line first.
char gInterruptMessage[kMaxPath];
std::atomic<bool> gInterruptMessageSet{false};
std::atomic<bool> gInterruptLineOpen{false};

void WriteAll(const char* text, size_t n) {
    while (n > 0) {
        const ssize_t w = write(STDERR_FILENO, text, n);
        if (w <= 0) return;
        text += w;
        n -= static_cast<size_t>(w);
    }
}

// Set by the first signal handled. A process-directed signal can reach any thread, and
// `timeout` sends its signal twice (to the child, then to its process group): a second one,
// on another thread, must not print the line again, interleaved with the first.
std::atomic<bool> gInterruptHandled{false};
static_assert(std::atomic<bool>::is_always_lock_free, "the interrupt handler's flag must be lock-free");

extern "C" void OnInterrupt(int sig) {
    // The first handler ends the process; a later one waits for that (async-signal-safe:
    // a lock-free atomic and pause(2)). The handlers block each other's signals in their
    // own thread (InstallInterruptCleanup's mask), so this never waits on itself.
    if (gInterruptHandled.exchange(true))
        for (;;) pause();
    for (int i = 0; i < kMaxPending; ++i)
        if (gPendingUsed[i].load()) unlink(gPending[i]);
    // Async-signal-safe: write(2) only. SIGHUP (the terminal closed) has no one to tell.
    if (sig != SIGHUP) {
        if (gInterruptLineOpen.load()) WriteAll("\n", 1);
        const char* what = sig == SIGINT ? "lightmesh: interrupted" : "lightmesh: terminated";
        WriteAll(what, std::strlen(what));
        if (gInterruptMessageSet.load()) {
            WriteAll("; ", 2);
            WriteAll(gInterruptMessage, std::strlen(gInterruptMessage));
        }
        WriteAll("\n", 1);
    }
    std::signal(sig, SIG_DFL);
    std::raise(sig);
}

std::string FolderOf(const std::string& path) {
    std::filesystem::path p(path);
    std::filesystem::path dir = p.parent_path();
    return dir.empty() ? std::string(".") : dir.string();
}

}  // namespace

void SetInterruptMessage(const std::string& message) {
    gInterruptMessageSet.store(false);
    if (message.empty() || message.size() >= kMaxPath) return;
    std::memcpy(gInterruptMessage, message.c_str(), message.size() + 1);
    gInterruptMessageSet.store(true);
}

void SetInterruptLineOpen(bool open) { gInterruptLineOpen.store(open); }

void InstallInterruptCleanup() {
    struct sigaction sa {};
    sa.sa_handler = OnInterrupt;
    sigemptyset(&sa.sa_mask);
    sigaddset(&sa.sa_mask, SIGINT);
    sigaddset(&sa.sa_mask, SIGTERM);
    sigaddset(&sa.sa_mask, SIGHUP);
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    sigaction(SIGHUP, &sa, nullptr);  // the terminal closed: the same clean-up
}

std::string RegularFileProblem(const std::string& path, const char* kind) {
    if (path.find('\0') != std::string::npos) return "the name contains a NUL byte";
    // O_NONBLOCK: opening a FIFO with no writer returns at once instead of waiting.
    const int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        const int err = errno;
        if (err == ENOENT) {
            struct stat ls {};
            if (lstat(path.c_str(), &ls) == 0 && S_ISLNK(ls.st_mode))
                return "is a symbolic link to a file that does not exist";
            return "no such file";
        }
        if (err == ENOTDIR) return "cannot open: a folder on its path is a file (Not a directory)";
        return StringPrintf("cannot open: %s", std::strerror(err));
    }
    struct stat st {};
    const int statResult = fstat(fd, &st);
    const int err = errno;
    close(fd);
    if (statResult != 0) return StringPrintf("cannot open: %s", std::strerror(err));
    if (S_ISDIR(st.st_mode)) return StringPrintf("is a directory, not a %s", kind);
    if (!S_ISREG(st.st_mode)) return "is not a regular file";
    return "";
}

void CheckRegularFile(const std::string& path, const char* kind) {
    if (std::string problem = RegularFileProblem(path, kind); !problem.empty())
        throw Error(path + ": " + problem);
}

std::string ReadRegularFile(const std::string& path, const char* kind) {
    CheckRegularFile(path, kind);
    const int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) ThrowErrorAt({path}, "cannot open: %s", std::strerror(errno));
    struct stat st {};
    // Re-checked on the descriptor read from: the name may have changed meanwhile.
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        ThrowErrorAt({path}, "is not a regular file");
    }
    std::string out;
    if (st.st_size > 0) out.reserve(static_cast<size_t>(st.st_size));
    char buf[65536];
    for (;;) {
        const ssize_t n = read(fd, buf, sizeof buf);
        if (n == 0) break;
        if (n < 0) {
            if (errno == EINTR) continue;
            const int err = errno;
            close(fd);
            ThrowErrorAt({path}, "read error: %s", std::strerror(err));
        }
        out.append(buf, static_cast<size_t>(n));
    }
    close(fd);
    return out;
}

namespace {

/// Whether an existing output that is neither a regular file nor a folder can be written
/// into in place ("" if so): a character device (a copy of /dev/null) or a FIFO can; a
/// block device (a disk) or a socket cannot.
std::string SpecialOutputProblem(const std::string& path, const struct stat& st) {
    if (S_ISBLK(st.st_mode)) return "is a block device: refusing to write an output over it";
    if (S_ISSOCK(st.st_mode)) return "is a socket, not a file";
    if (access(path.c_str(), W_OK) != 0) return StringPrintf("is not writable: %s", std::strerror(errno));
    return "";
}

/// An existing output that is not a regular file (nor a folder), as stat() sees it through
/// symbolic links; false if there is none or it is a regular file.
bool IsSpecialOutput(const std::string& path, struct stat* st) {
    return stat(path.c_str(), st) == 0 && !S_ISREG(st->st_mode) && !S_ISDIR(st->st_mode);
}

}  // namespace

void CheckWritableFolder(const std::string& path) {
    if (path.find('\0') != std::string::npos)
        ThrowErrorAt({path}, "the name contains a NUL byte");
    if (struct stat target {}; IsSpecialOutput(path, &target)) {
        // Written into in place (WriteFileAtomically), so its folder need not be writable.
        if (std::string problem = SpecialOutputProblem(path, target); !problem.empty())
            ThrowErrorAt({path}, "%s", problem.c_str());
        return;
    }
    const std::string dir = FolderOf(path);
    std::error_code ec;
    struct stat st {};
    if (stat(dir.c_str(), &st) != 0) {
        const int err = errno;
        if (err == ENOENT)
            ThrowErrorAt({path}, "folder \"%s\" does not exist", dir.c_str());
        if (err == ENOTDIR)
            ThrowErrorAt({path}, "folder \"%s\" cannot exist: a folder on its path is a file", dir.c_str());
        ThrowErrorAt({path}, "folder \"%s\": %s", dir.c_str(), std::strerror(err));
    }
    if (!S_ISDIR(st.st_mode))
        ThrowErrorAt({path}, "\"%s\" is a file, not a folder", dir.c_str());
    if (access(dir.c_str(), W_OK) != 0)
        ThrowErrorAt({path}, "folder \"%s\" is not writable", dir.c_str());
    if (std::filesystem::is_directory(path, ec))
        ThrowErrorAt({path}, "is a folder, not a file");
}

namespace {

constexpr size_t kNameMax = 255;  // NAME_MAX of Linux file systems

/// ".NAME.tmp", shortened so that ".NAME.tmp" + a PID fits in NAME_MAX.
std::string TemporaryPrefix(const std::string& name) {
    std::string prefix = "." + name + ".tmp";
    constexpr size_t kPidDigits = 10;
    if (prefix.size() + kPidDigits <= kNameMax) return prefix;
    // FNV-1a of the whole name keeps two long names with a common start apart.
    uint64_t h = 0xcbf29ce484222325ull;
    for (unsigned char c : name) h = (h ^ c) * 0x100000001b3ull;
    const std::string tail = StringPrintf("~%016llx.tmp", static_cast<unsigned long long>(h));
    std::string head = name.substr(0, kNameMax - kPidDigits - tail.size() - 1);
    // Do not cut a UTF-8 sequence in half.
    while (!head.empty() && (static_cast<unsigned char>(head.back()) & 0xC0) == 0x80) head.pop_back();
    if (!head.empty() && (static_cast<unsigned char>(head.back()) & 0x80)) head.pop_back();
    return "." + head + tail;
}

/// Removes the temporary files of `path` left by processes that no longer exist (killed
/// by SIGKILL, or the machine stopped, during a write).
void RemoveStaleTemporaries(const std::string& folder, const std::string& prefix) {
    DIR* d = opendir(folder.c_str());
    if (!d) return;
    while (const dirent* e = readdir(d)) {
        const std::string_view name(e->d_name);
        if (name.size() <= prefix.size() || name.substr(0, prefix.size()) != prefix) continue;
        const std::string_view digits = name.substr(prefix.size());
        if (digits.size() > 10 ||
            digits.find_first_not_of("0123456789") != std::string_view::npos)
            continue;
        const long pid = std::strtol(std::string(digits).c_str(), nullptr, 10);
        if (pid <= 0 || pid == getpid()) continue;
        if (kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // alive
        unlinkat(dirfd(d), e->d_name, 0);
    }
    closedir(d);
}

}  // namespace

std::string TemporaryPathFor(const std::string& path, long pid) {
    const std::filesystem::path p(path);
    return (std::filesystem::path(FolderOf(path)) /
            (TemporaryPrefix(p.filename().string()) + std::to_string(pid)))
        .string();
}

namespace {

/// WriteFileAtomically for an existing output that is not a regular file: a rename would
/// replace the device or FIFO itself (as root, `--csv /dev/null` would have replaced the
/// system's /dev/null by a regular file). The content is made in an anonymous memory file
/// (the callback writes by name: /proc/self/fd/N), then written into the target in place,
/// as `cp` would: a copy of /dev/null takes it, /dev/full fails with ENOSPC, a FIFO's
/// reader gets it. A FIFO with no reader is an error, not a wait.
void WriteIntoSpecialFile(const std::string& path, const struct stat& st,
                          const std::function<void(const std::string& tmpPath)>& write) {
    if (std::string problem = SpecialOutputProblem(path, st); !problem.empty())
        ThrowErrorAt({path}, "%s", problem.c_str());
    struct Fd {
        int fd = -1;
        ~Fd() {
            if (fd >= 0) close(fd);
        }
    } mem, out;
    mem.fd = memfd_create("lightmesh-output", MFD_CLOEXEC);
    if (mem.fd < 0) ThrowErrorAt({path}, "cannot write: %s", std::strerror(errno));
    write("/proc/self/fd/" + std::to_string(mem.fd));
    out.fd = open(path.c_str(), O_WRONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
    if (out.fd < 0) {
        if (errno == ENXIO) ThrowErrorAt({path}, "is a FIFO with no reader: nothing written");
        ThrowErrorAt({path}, "cannot write: %s", std::strerror(errno));
    }
    struct stat now {};
    if (fstat(out.fd, &now) != 0 || S_ISREG(now.st_mode) || S_ISDIR(now.st_mode))
        ThrowErrorAt({path}, "cannot write: it changed while the output was made");
    // Blocking from here: a FIFO's reader takes the data at its own pace.
    const int flags = fcntl(out.fd, F_GETFL);
    if (flags >= 0) fcntl(out.fd, F_SETFL, flags & ~O_NONBLOCK);
    char buf[65536];
    for (off_t at = 0;;) {
        const ssize_t n = pread(mem.fd, buf, sizeof buf, at);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) ThrowErrorAt({path}, "cannot write: %s", std::strerror(errno));
        if (n == 0) break;
        at += n;
        for (ssize_t done = 0; done < n;) {
            const ssize_t w = ::write(out.fd, buf + done, static_cast<size_t>(n - done));
            if (w < 0 && errno == EINTR) continue;
            if (w <= 0) ThrowErrorAt({path}, "cannot write: %s", std::strerror(w < 0 ? errno : EIO));
            done += w;
        }
    }
    const int fd = out.fd;
    out.fd = -1;
    if (close(fd) != 0) ThrowErrorAt({path}, "cannot write: %s", std::strerror(errno));
}

}  // namespace

void WriteFileAtomically(const std::string& path,
                         const std::function<void(const std::string& tmpPath)>& write) {
    if (struct stat target {}; path.find('\0') == std::string::npos && IsSpecialOutput(path, &target))
        return WriteIntoSpecialFile(path, target, write);
    CheckWritableFolder(path);
    const std::filesystem::path p(path);
    RemoveStaleTemporaries(FolderOf(path), TemporaryPrefix(p.filename().string()));
    const std::string tmp = TemporaryPathFor(path, getpid());
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
            ThrowErrorAt({path}, "cannot write: %s", std::strerror(errno));
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

std::string ByteCountProblem(const std::string& text, uint64_t* bytes) {
    // [spaces] number [spaces] [unit] [spaces]: the number is digits, or digits '.' digits;
    // the unit "", "B", or K, M, G, T alone or followed by "B" or "iB" (any case; all
    // powers of 1024, as docker, systemd and Slurm read "8G" and "8GB").
    const size_t begin = text.find_first_not_of(' ');
    const size_t last = text.find_last_not_of(' ');
    const std::string t = begin == std::string::npos ? std::string() : text.substr(begin, last - begin + 1);
    const auto isDigit = [](char c) { return c >= '0' && c <= '9'; };
    size_t i = 0;
    while (i < t.size() && isDigit(t[i])) ++i;
    const size_t wholeEnd = i;
    if (i < t.size() && t[i] == '.' && i > 0) {
        ++i;
        while (i < t.size() && isDigit(t[i])) ++i;
        if (i == wholeEnd + 1) i = wholeEnd;  // "1." : the '.' is not part of the number
    }
    if (wholeEnd == 0) return !t.empty() && (t[0] == '-' || t[0] == '+') ? "not a size: no sign is allowed" : "not a size";
    const std::string number = t.substr(0, i);
    size_t u = i;
    while (u < t.size() && t[u] == ' ') ++u;
    std::string unit = t.substr(u);
    for (char& c : unit) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    int power = -1;
    if (unit.empty() || unit == "b") power = 0;
    else if (const size_t at = std::string("kmgt").find(unit[0]);
             at != std::string::npos && (unit.size() == 1 || unit.substr(1) == "b" || unit.substr(1) == "ib"))
        power = static_cast<int>(at) + 1;
    if (power < 0) return "not a size: unknown unit \"" + Printable(t.substr(u)) + "\"";
    const bool fraction = number.size() > wholeEnd;
    if (power == 0 && fraction) return "not a size: a fraction of a byte";
    uint64_t result = 0;
    if (!fraction) {
        bool overflow = false;
        for (size_t k = 0; k < wholeEnd && !overflow; ++k) {
            const uint64_t d = static_cast<uint64_t>(t[k] - '0');
            overflow = result > (UINT64_MAX - d) / 10;
            result = result * 10 + d;
        }
        const int shift = 10 * power;
        if (overflow || (shift > 0 && result > (UINT64_MAX >> shift))) return "too large (more than 16 EiB)";
        result <<= shift;
    } else {
        const double value = std::ldexp(std::strtod(number.c_str(), nullptr), 10 * power);
        if (!(value < 18446744073709551616.0)) return "too large (more than 16 EiB)";
        result = static_cast<uint64_t>(value);
    }
    if (result == 0) return "must be at least 1 byte";
    if (bytes) *bytes = result;
    return {};
}

uint64_t ParseByteCount(const std::string& text) {
    uint64_t bytes = 0;
    return ByteCountProblem(text, &bytes).empty() ? bytes : 0;
}

uint64_t MemoryLimitFromEnvironment() {
    const char* env = std::getenv("LIGHTMESH_MEMORY_LIMIT");
    if (!env || !*env) return 0;  // unset or empty: no limit of its own
    uint64_t bytes = 0;
    if (const std::string problem = ByteCountProblem(env, &bytes); !problem.empty())
        throw Error("LIGHTMESH_MEMORY_LIMIT=" + Printable(env) + ": " + problem +
                    "; write bytes or a number with K, M, G or T (powers of 1024), e.g. 8G, 8GB, 8GiB, 512M, "
                    "1073741824");
    return bytes;
}

std::string CurrentExceptionLine() {
    try {
        throw;
    } catch (const Error& e) {
        return e.what();
    } catch (const std::bad_alloc&) {
        uint64_t budget = 0;
        try {
            budget = PhysicalMemoryBytes();
        } catch (...) {  // a LIGHTMESH_MEMORY_LIMIT that is not a size: the budget is unknown
        }
        return StringPrintf("out of memory: an allocation failed (peak %s; this machine's budget %s, "
                            "LIGHTMESH_MEMORY_LIMIT lowers it)",
                            FormatBytes(PeakMemoryBytes()).c_str(), budget ? FormatBytes(budget).c_str() : "unknown");
    } catch (const std::filesystem::filesystem_error& e) {
        return Printable(e.path1().string()) + ": " + Printable(e.code().message());
    } catch (const std::exception& e) {
        return Printable(e.what());
    } catch (...) {
        return "unknown failure";
    }
}

int AffinityCpuCount() {
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof(set), &set) != 0) return 0;
    return CPU_COUNT(&set);
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
    lower(MemoryLimitFromEnvironment());
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

std::string FormatDuration(double seconds) {
    if (!(seconds >= 0)) return "?";
    if (seconds < 60) return StringPrintf("%.1f s", seconds);
    if (seconds > 1e12) return StringPrintf("%.2g years", seconds / 31557600.0);
    const uint64_t s = static_cast<uint64_t>(std::llround(seconds));
    if (s < 3600) return StringPrintf("%llu min %llu s", static_cast<unsigned long long>(s / 60),
                                      static_cast<unsigned long long>(s % 60));
    if (s < 86400) return StringPrintf("%llu h %llu min", static_cast<unsigned long long>(s / 3600),
                                       static_cast<unsigned long long>(s % 3600 / 60));
    return StringPrintf("%s d %llu h", FormatCount(s / 86400).c_str(), static_cast<unsigned long long>(s % 86400 / 3600));
}

std::string FormatCount(uint64_t n) {
    const std::string digits = std::to_string(n);
    std::string s;
    s.reserve(digits.size() + digits.size() / 3);
    for (size_t i = 0; i < digits.size(); ++i) {
        if (i > 0 && (digits.size() - i) % 3 == 0) s += ',';
        s += digits[i];
    }
    return s;
}

std::string CacheDir(const char* kind) {
    if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
        return (std::filesystem::path(xdg) / "lightmesh" / kind).string();
    if (const char* home = std::getenv("HOME"); home && *home)
        return (std::filesystem::path(home) / ".cache" / "lightmesh" / kind).string();
    return {};
}

}  // namespace lm
