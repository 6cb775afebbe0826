// system.h -- files written atomically, interrupt clean-up, memory figures.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

namespace lm {

/// Writes a file so that readers only ever see the old content or the complete new one:
/// `write` fills a temporary file in the same folder, which is then renamed over `path`.
/// If `write` throws, or the process is interrupted by SIGINT/SIGTERM meanwhile (see
/// InstallInterruptCleanup), the temporary file is removed and `path` is left untouched.
/// Throws Error naming `path` when the folder is missing or not writable.
void WriteFileAtomically(const std::string& path,
                         const std::function<void(const std::string& tmpPath)>& write);

/// Installs SIGINT and SIGTERM handlers that delete the temporary files of writes in
/// progress before the process dies with the signal.
void InstallInterruptCleanup();

/// Throws Error unless `path`'s folder exists and is writable (checked before a long
/// render, so a typo does not cost the render).
void CheckWritableFolder(const std::string& path);

/// Peak resident memory of this process so far, in bytes (0 if unknown).
uint64_t PeakMemoryBytes();

/// The memory this process may use, in bytes (0 if unknown): the machine's physical memory,
/// lowered by a cgroup memory limit (a container's) and by the environment variable
/// LIGHTMESH_MEMORY_LIMIT (bytes, or a number with K, M, G or T: "512M"), when set and
/// smaller. Light meshes and images that would need more than half are refused up front.
uint64_t PhysicalMemoryBytes();

/// Parses "4096", "512K", "64M", "1.5G", "2T" (binary units); 0 for anything else.
uint64_t ParseByteCount(const std::string& text);

/// "1.5 GiB", "320 MiB", "12 KiB", "17 B".
std::string FormatBytes(uint64_t bytes);

}  // namespace lm
