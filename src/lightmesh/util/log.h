// log.h -- warnings and information on stderr, one whole line at a time.
#pragma once

#include <string>

namespace lm {

enum class LogLevel { Debug, Info, Warning, Error, Silent };

/// Messages below this level are dropped: --quiet sets Error, --verbose sets Debug.
void SetLogLevel(LogLevel level);
LogLevel GetLogLevel();

/// Prints "lightmesh: warning: <message>" etc. on stderr, under a lock so lines from
/// several threads never interleave; an exact repeat of the previous warning is dropped.
void LogWarning(const std::string& message);
void LogInfo(const std::string& message);
void LogDebug(const std::string& message);

}  // namespace lm
