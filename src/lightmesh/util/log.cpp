#include "lightmesh/util/log.h"

#include <atomic>
#include <cstdio>
#include <mutex>

#include "lightmesh/util/error.h"

namespace lm {
namespace {
std::atomic<LogLevel> gLevel{LogLevel::Info};
std::mutex gMutex;
std::string gLastWarning;

void Emit(LogLevel level, const char* tag, const std::string& message) {
    if (level < gLevel.load(std::memory_order_relaxed)) return;
    std::lock_guard<std::mutex> lock(gMutex);
    if (level == LogLevel::Warning) {
        if (message == gLastWarning) return;
        gLastWarning = message;
    }
    std::fprintf(stderr, "lightmesh: %s%s\n", tag, Printable(message).c_str());
    std::fflush(stderr);
}
}  // namespace

void SetLogLevel(LogLevel level) { gLevel.store(level); }
LogLevel GetLogLevel() { return gLevel.load(); }
void LogWarning(const std::string& message) { Emit(LogLevel::Warning, "warning: ", message); }
void LogInfo(const std::string& message) { Emit(LogLevel::Info, "", message); }
void LogDebug(const std::string& message) { Emit(LogLevel::Debug, "debug: ", message); }

}  // namespace lm
