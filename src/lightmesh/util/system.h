// system.h -- files written atomically, interrupt clean-up, memory figures.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>

namespace lm {

/// Writes a file so that readers only ever see the old content or the complete new one:
/// `write` fills a temporary file in the same folder, which is then renamed over `path`.
/// If `write` throws, or the process is interrupted by SIGINT/SIGTERM meanwhile (see
/// InstallInterruptCleanup), the temporary file is removed and `path` is left untouched.
/// Throws Error naming `path` when the folder is missing or not writable.
/// Only a regular file (or nothing) at `path` is renamed over: an existing character
/// device (a copy of /dev/null or /dev/full) or FIFO is written into in place, the content
/// made in memory first (`write` gets a /proc/self/fd/N name), so the device stays; a FIFO
/// without a reader, a block device or a socket is an Error.
void WriteFileAtomically(const std::string& path,
                         const std::function<void(const std::string& tmpPath)>& write);

/// Installs SIGINT, SIGTERM and SIGHUP handlers that delete the temporary files of writes in
/// progress before the process dies with the signal. On SIGINT and SIGTERM the handler
/// also ends an open progress-bar line and prints one line, "lightmesh: interrupted" (or
/// "terminated"), followed by "; " and the SetInterruptMessage text if one is set.
void InstallInterruptCleanup();
/// The rest of the interrupt line ("out.png left as it was"); "" for none.
void SetInterruptMessage(const std::string& message);
/// Whether a progress bar's line, not ended by a newline, is on stderr (ProgressReporter).
void SetInterruptLineOpen(bool open);

/// Throws Error unless `path`'s folder exists and is writable (checked before a long
/// render, so a typo does not cost the render); for an existing device or FIFO (written
/// into in place), unless it is writable and not a block device or a socket.
void CheckWritableFolder(const std::string& path);

/// Why `path` cannot be read as a regular file, or "" when it can: "no such file", "is a
/// directory, not a KIND", "is not a regular file" (a FIFO, socket or device), "cannot
/// open: <strerror(errno)>" (a symlink loop, a name too long, a parent that is a file,
/// permissions). Opens without blocking (O_NONBLOCK), so a FIFO with no writer is
/// reported rather than waited on; every reader of user-named files checks this first.
std::string RegularFileProblem(const std::string& path, const char* kind);

/// RegularFileProblem, thrown as Error("PATH: reason").
void CheckRegularFile(const std::string& path, const char* kind);

/// The whole content of a regular file (checked as above), read until end of file, so
/// files that report a size of 0 (/proc) are read too. Throws Error naming `path`.
std::string ReadRegularFile(const std::string& path, const char* kind);

/// The name of the temporary file WriteFileAtomically uses for `path` in process `pid`:
/// ".NAME.tmpPID" in the same folder, with NAME shortened (and a hash of the full name
/// added) when the result would be longer than NAME_MAX (255 bytes).
std::string TemporaryPathFor(const std::string& path, long pid);

/// Peak resident memory of this process so far, in bytes (0 if unknown).
uint64_t PeakMemoryBytes();

/// The memory this process may use, in bytes (0 if unknown): the machine's physical memory,
/// lowered by a cgroup memory limit (a container's) and by the environment variable
/// LIGHTMESH_MEMORY_LIMIT (MemoryLimitFromEnvironment: bytes, or a number with K, M, G or T:
/// "512M", "8GB"), when set and smaller; throws its Error for a value that is not a size (the
/// executable checks it first). Light meshes and images that would need more than half are
/// refused up front.
uint64_t PhysicalMemoryBytes();

/// The message of the exception being handled, as one line: the project's errors as they
/// are, allocation failures with the peak and the budget, file-system errors with the path.
/// Call inside a catch block; every command (and every MPI rank) words its failure so.
std::string CurrentExceptionLine();

/// Seconds of wall time since `start` (steady clock).
inline double SecondsSince(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// The CPUs this process may run on (its affinity mask); 0 if unknown.
int AffinityCpuCount();

/// Why `text` is not a byte count ("" when it is, and then *bytes is set): a number (digits,
/// at most one '.'; no sign, no exponent), optional spaces, and a unit: none or "B" (bytes,
/// whole), or K, M, G, T alone or followed by "B" or "iB", any case, all powers of 1024
/// ("8G", "8GB", "8GiB", "8 gb", "1.5G", "512M", "4096"). The reasons: "not a size",
/// "not a size: unknown unit "X"", "too large (...)", "must be at least 1 byte", ...
std::string ByteCountProblem(const std::string& text, uint64_t* bytes);

/// ByteCountProblem's count, 0 for text that is not one.
uint64_t ParseByteCount(const std::string& text);

/// LIGHTMESH_MEMORY_LIMIT's bytes, 0 when it is unset or empty; throws Error, one line naming
/// the variable, its value and the grammar, for a value that is not a byte count (it was
/// ignored, leaving the process without a budget).
uint64_t MemoryLimitFromEnvironment();

/// "1.5 GiB", "320 MiB", "12 KiB", "17 B".
std::string FormatBytes(uint64_t bytes);

/// A duration as a person reads it: "8.5 s", "12 min 5 s", "3 h 12 min", "4 d 6 h".
std::string FormatDuration(double seconds);

/// "1,234,567": a count with thousands separators.
std::string FormatCount(uint64_t n);

/// The folder of lightmesh's cache `kind` ("templates", "models"):
/// $XDG_CACHE_HOME/lightmesh/KIND, else $HOME/.cache/lightmesh/KIND; empty if neither is set.
std::string CacheDir(const char* kind);

}  // namespace lm
