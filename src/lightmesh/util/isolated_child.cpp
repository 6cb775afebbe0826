// isolated_child.cpp -- RunInChild: fork, limits, deadline, the result through a memfd.
#include "lightmesh/util/isolated_child.h"

#include <poll.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <mutex>

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define LIGHTMESH_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
#define LIGHTMESH_SANITIZED 1
#endif
#endif

namespace lm {
namespace {

/// The address space this process maps now, in bytes (0 if unknown).
uint64_t MappedBytes() {
    FILE* f = std::fopen("/proc/self/statm", "r");
    if (!f) return 0;
    unsigned long long pages = 0;
    const int got = std::fscanf(f, "%llu", &pages);
    std::fclose(f);
    return got == 1 ? pages * static_cast<uint64_t>(sysconf(_SC_PAGE_SIZE)) : 0;
}

/// Waits for the child until the deadline; kills it there. Returns whether it timed out.
bool WaitWithDeadline(pid_t pid, double seconds, int* status) {
    const auto deadline = std::chrono::steady_clock::now() +
                          std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(seconds));
    const int pidfd = static_cast<int>(syscall(SYS_pidfd_open, pid, 0));
    bool timedOut = false;
    for (;;) {
        const pid_t done = waitpid(pid, status, WNOHANG);
        if (done == pid || (done < 0 && errno != EINTR)) break;
        const auto now = std::chrono::steady_clock::now();
        if (now >= deadline) {
            kill(pid, SIGKILL);
            while (waitpid(pid, status, 0) < 0 && errno == EINTR) {
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
    return timedOut;
}

}  // namespace

ChildOutcome& ChildOutcome::operator=(ChildOutcome&& o) noexcept {
    if (this != &o) {
        if (map_) munmap(map_, size_);
        end = o.end, code = o.code, seconds = o.seconds, map_ = o.map_, size_ = o.size_;
        lastErrorLine_ = std::move(o.lastErrorLine_);
        o.map_ = nullptr, o.size_ = 0;
    }
    return *this;
}

ChildOutcome::~ChildOutcome() {
    if (map_) munmap(map_, size_);
}

ChildOutcome RunInChild(const char* name, const ChildLimits& limits, const std::function<void(int fd)>& work) {
    ChildOutcome out;
    out.seconds = limits.seconds;
    const int fd = memfd_create(name, MFD_CLOEXEC);
    if (fd < 0) return out;
#ifndef LIGHTMESH_SANITIZED
    // The child's standard error, kept from the user's: one error line is the rule, and a
    // crash's line quotes the library's last words.
    const int errFd = memfd_create("lightmesh-stderr", MFD_CLOEXEC);
#else
    const int errFd = -1;
#endif
    static std::mutex forkMutex;
    std::unique_lock<std::mutex> lock(forkMutex);
    std::fflush(nullptr);
    [[maybe_unused]] const uint64_t mappedNow = MappedBytes();
    const pid_t pid = fork();
    if (pid < 0) {
        close(fd);
        if (errFd >= 0) close(errFd);
        return out;
    }
    if (pid == 0) {
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        if (errFd >= 0) dup2(errFd, STDERR_FILENO);
        for (int sig : {SIGINT, SIGTERM, SIGHUP}) std::signal(sig, SIG_DFL);
#ifndef LIGHTMESH_SANITIZED
        if (limits.memory && mappedNow) {
            const rlim_t limit =
                static_cast<rlim_t>(mappedNow + std::max<uint64_t>(limits.memory, uint64_t(64) << 20));
            struct rlimit rl {limit, limit};
            setrlimit(RLIMIT_AS, &rl);
        }
#endif
        try {
            work(fd);
        } catch (...) {
            _exit(3);
        }
        _exit(0);
    }
    int status = 0;
    const bool timedOut = WaitWithDeadline(pid, limits.seconds, &status);
    lock.unlock();
    if (timedOut) {
        out.end = ChildOutcome::End::TimedOut;
    } else if (WIFSIGNALED(status)) {
        out.end = ChildOutcome::End::Signalled;
        out.code = WTERMSIG(status);
    } else {
        out.end = ChildOutcome::End::Exited;
        out.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    }
    // The result, mapped rather than read: one copy, into the caller's structures.
    struct stat st {};
    if (!timedOut && fstat(fd, &st) == 0 && st.st_size > 0) {
        void* m = mmap(nullptr, static_cast<size_t>(st.st_size), PROT_READ, MAP_PRIVATE, fd, 0);
        if (m != MAP_FAILED) out.map_ = m, out.size_ = static_cast<size_t>(st.st_size);
    }
    close(fd);
    if (errFd >= 0) {
        // Its last line (of the last KiB).
        char tail[1024];
        const off_t size = lseek(errFd, 0, SEEK_END);
        const off_t from = std::max<off_t>(0, size - static_cast<off_t>(sizeof tail));
        const ssize_t got = size > 0 ? pread(errFd, tail, static_cast<size_t>(size - from), from) : 0;
        std::string text(tail, got > 0 ? static_cast<size_t>(got) : 0);
        while (!text.empty() && (text.back() == '\n' || text.back() == '\r' || text.back() == ' ')) text.pop_back();
        if (const size_t nl = text.find_last_of('\n'); nl != std::string::npos) text.erase(0, nl + 1);
        if (text.size() > 160) text = text.substr(0, 157) + "...";
        for (char& c : text)
            if (static_cast<unsigned char>(c) < 0x20) c = ' ';
        out.lastErrorLine_ = text;
        close(errFd);
    }
    return out;
}

std::string ChildOutcome::Said() const {
    return lastErrorLine_.empty() ? std::string() : " (it said: \"" + lastErrorLine_ + "\")";
}

double ChildDeadlineSeconds(uint64_t bytes) {
    if (const char* env = std::getenv("LIGHTMESH_IMPORT_TIMEOUT"); env && *env) {
        char* end = nullptr;
        const double v = std::strtod(env, &end);
        if (end != env && *end == 0 && v > 0 && v < 1e7) return v;
    }
    return std::min(60.0 + 2.0 * static_cast<double>(bytes) / 1e6, kMaxDefaultChildSeconds);
}

std::string SignalName(int sig) {
    switch (sig) {
        case SIGSEGV: return "SIGSEGV";
        case SIGABRT: return "SIGABRT";
        case SIGBUS: return "SIGBUS";
        case SIGFPE: return "SIGFPE";
        case SIGILL: return "SIGILL";
        case SIGKILL: return "SIGKILL";
        default: return "signal " + std::to_string(sig);
    }
}

void ChildWriter::Bools(const std::vector<bool>& v) {
    Pod<uint64_t>(v.size());
    std::string b;
    for (bool x : v) b.push_back(x ? 1 : 0);
    Bytes(b.data(), b.size(), true);
}

void ChildWriter::Bytes(const void* data, size_t size, bool copy) {
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

bool ChildWriter::Write(int fd) const {
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

bool ChildWriter::WriteTo(int fd) const {
    if (ftruncate(fd, 0) != 0 || lseek(fd, 0, SEEK_SET) != 0) return false;
    return Write(fd);
}

bool ChildWriter::AppendTo(int fd) const {
    if (lseek(fd, 0, SEEK_END) < 0) return false;
    return Write(fd);
}

std::vector<bool> ChildReader::Bools() {
    const uint64_t n = Pod<uint64_t>();
    Need(n);
    std::vector<bool> v(n);
    for (uint64_t i = 0; i < n; ++i) v[i] = bytes_[at_ + i] != 0;
    at_ += n;
    return v;
}

}  // namespace lm
