#include "lightmesh/distributed/launch.h"

#include <cstdlib>
#include <initializer_list>

namespace lm {
namespace {

int FirstInt(std::initializer_list<const char*> names, int fallback) {
    for (const char* name : names) {
        const char* v = std::getenv(name);
        if (!v || !*v) continue;
        char* end = nullptr;
        const long n = std::strtol(v, &end, 10);
        if (*end == '\0' && n >= 0 && n < (1L << 30)) return static_cast<int>(n);
    }
    return fallback;
}

}  // namespace

int LauncherWorldSize() {
    return FirstInt({"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"}, 1);
}

bool LaunchedByMpi() { return FirstInt({"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"}, -1) > 0; }

int LauncherWorldRank() { return FirstInt({"OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"}, 0); }

}  // namespace lm
