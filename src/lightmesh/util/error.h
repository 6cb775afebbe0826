// error.h -- the one exception type for bad user input, and printf-style formatting.
#pragma once

#include <cstdarg>
#include <stdexcept>
#include <string>

namespace lm {

/// printf-style formatting into a std::string (g++ 12 has no std::format).
std::string StringPrintf(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string StringVPrintf(const char* fmt, va_list args);

/// The text with control characters other than newline and tab (which a scene file can
/// smuggle into a message, e.g. terminal escapes in a key) shown as <U+001B>.
std::string Printable(const std::string& text);

/// An error in what the user gave us: a scene file, a mesh, an option, an output path.
/// The message is complete and names its origin, e.g.
/// `scene.json /lights/1/position: expected 3 numbers`; main() prints it and exits 1.
/// Programmer errors are not Errors: they are assertions.
class Error : public std::runtime_error {
  public:
    explicit Error(const std::string& message) : std::runtime_error(Printable(message)) {}
};

/// Throws an Error with a printf-style message.
[[noreturn]] void ThrowError(const char* fmt, ...) __attribute__((format(printf, 1, 2)));

}  // namespace lm
