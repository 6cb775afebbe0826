#include "lightmesh/util/error.h"

#include <cstdio>
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

void ThrowError(const char* fmt, ...) {
    va_list args;
    va_start(args, fmt);
    std::string s = StringVPrintf(fmt, args);
    va_end(args);
    throw Error(s);
}

}  // namespace lm
