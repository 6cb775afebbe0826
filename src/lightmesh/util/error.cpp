#include "lightmesh/util/error.h"

#include <cstdio>
#include <utility>
#include <vector>

namespace lm {

std::string StringVPrintf(const char* fmt, va_list args) {
    va_list copy;
    va_copy(copy, args);
    int n = std::vsnprintf(nullptr, 0, fmt, copy);
    va_end(copy);
    if (n <= 0) return {};
    std::string s(static_cast<size_t>(n), '\0');
    std::vsnprintf(s.data(), s.size() + 1, fmt, args);
    return s;
}

std::string StringPrintf(const char* fmt, ...) {
    va_list args;
    va_start(args, fmt);
    std::string s = StringVPrintf(fmt, args);
    va_end(args);
    return s;
}

std::string Printable(const std::string& text) {
    // A newline or carriage return too: a message is one line, and a file name may hold one.
    auto control = [](unsigned char c) { return (c < 0x20 && c != '\t') || c == 0x7f; };
    bool any = false;
    for (unsigned char c : text) any = any || control(c);
    if (!any) return text;
    std::string out;
    for (unsigned char c : text) {
        if (control(c))
            out += StringPrintf("<U+%04X>", c);
        else
            out += static_cast<char>(c);
    }
    return out;
}

std::string SourceLoc::Format() const {
    if (!option.empty()) return option;
    std::string out = file;
    if (line > 0 && column > 0)
        out += StringPrintf(":%zu:%zu", line, column);
    else if (line > 0)
        out += StringPrintf(":%zu", line);
    if (!jsonPath.empty()) {
        if (!out.empty()) out += ' ';
        out += jsonPath;
    }
    return out;
}

Error::Error(SourceLoc where, const std::string& reason)
    : std::runtime_error(Printable(where.Known() ? where.Format() + ": " + reason : reason)),
      where_(std::move(where)),
      reason_(Printable(reason)) {}

void ThrowError(const char* fmt, ...) {
    va_list args;
    va_start(args, fmt);
    std::string s = StringVPrintf(fmt, args);
    va_end(args);
    throw Error(s);
}

void ThrowErrorAt(const SourceLoc& where, const char* fmt, ...) {
    va_list args;
    va_start(args, fmt);
    std::string s = StringVPrintf(fmt, args);
    va_end(args);
    throw Error(where, s);
}

}  // namespace lm
