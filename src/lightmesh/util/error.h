// error.h -- the one exception type for bad user input, and printf-style formatting.
#pragma once

#include <cstdarg>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <utility>

namespace lm {

/// printf-style formatting into a std::string (g++ 12 has no std::format).
std::string StringPrintf(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string StringVPrintf(const char* fmt, va_list args);

/// The text with control characters other than tab (which a scene file can smuggle into a
/// message, e.g. terminal escapes in a key, or a newline in a file name that would split the
/// one-line error) shown as <U+001B>, <U+000A>; a NUL byte as <U+0000>.
std::string Printable(const std::string& text);

/// Where in the user's input an error lies: a file and, inside it, a line and column (a
/// text format's syntax) or a JSON pointer (a value of a scene file or bench matrix); or a
/// command-line option. Parts left empty (0 for line and column) are not known.
struct SourceLoc {
    SourceLoc() = default;
    SourceLoc(std::string file, size_t line = 0, size_t column = 0, std::string jsonPath = {})
        : file(std::move(file)), line(line), column(column), jsonPath(std::move(jsonPath)) {}

    std::string file;
    size_t line = 0, column = 0;
    std::string jsonPath;  ///< "/lights/1/position"; empty for the whole file
    std::string option;    ///< a command-line option ("--ki") instead of a file

    /// The place of a value given as a command-line option.
    static SourceLoc Option(std::string flag) {
        SourceLoc loc;
        loc.option = std::move(flag);
        return loc;
    }
    bool Known() const { return !file.empty() || line > 0 || !jsonPath.empty() || !option.empty(); }
    /// As messages write it: "scene.json /lights/1/position", "scene.json:3:14",
    /// "mesh.obj", "--ki"; empty when nothing is known.
    std::string Format() const;
};

/// An error in what the user gave us: a scene file, a mesh, an option, an output path.
/// The message is complete and names its origin, e.g.
/// `scene.json /lights/1/position: expected 3 numbers`; main() prints it and exits 1.
/// Where the origin is a place in a file, it is also kept as data (Where(), Reason()), so a
/// caller does not have to take the message apart to re-locate or re-word it.
/// Programmer errors are not Errors: they are assertions.
class Error : public std::runtime_error {
  public:
    /// An error whose message names its origin itself (an option, a path, a limit).
    explicit Error(const std::string& message) : std::runtime_error(Printable(message)), reason_(what()) {}
    /// An error at `where`: the message is "<where>: <reason>".
    Error(SourceLoc where, const std::string& reason);

    const SourceLoc& Where() const { return where_; }
    /// The message without its location.
    const std::string& Reason() const { return reason_; }

  private:
    SourceLoc where_;
    std::string reason_;
};

/// Throws an Error with a printf-style message.
[[noreturn]] void ThrowError(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
/// Throws an Error at `where` with a printf-style reason.
[[noreturn]] void ThrowErrorAt(const SourceLoc& where, const char* fmt, ...) __attribute__((format(printf, 2, 3)));

}  // namespace lm
