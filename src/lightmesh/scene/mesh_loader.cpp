// mesh_loader.cpp -- the mesh import's entry points (mesh_loader.h): LoadMeshFile, the budget
// for this machine, glob matching. The import itself is assimp_import.cpp, the child process
// it runs in isolated_import.cpp.
#include "lightmesh/scene/mesh_loader.h"

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string_view>

#include "lightmesh/scene/mesh_import_internal.h"
#include "lightmesh/util/log.h"
#include "lightmesh/util/system.h"

namespace lm {

using mesh_import::CheckReadable;
using mesh_import::ImportIsolated;

bool GlobMatch(std::string_view pattern, std::string_view text) {
    // Greedy matching with backtracking to the last '*' (linear in practice).
    size_t p = 0, s = 0, star = std::string_view::npos, mark = 0;
    while (s < text.size()) {
        if (p < pattern.size() && (pattern[p] == '?' || pattern[p] == text[s])) {
            ++p;
            ++s;
        } else if (p < pattern.size() && pattern[p] == '*') {
            star = p++;
            mark = s;
        } else if (star != std::string_view::npos) {
            p = star + 1;
            s = ++mark;
        } else {
            return false;
        }
    }
    while (p < pattern.size() && pattern[p] == '*') ++p;
    return p == pattern.size();
}

ImportBudget ImportBudget::ForThisMachine() {
    ImportBudget b;
    b.memory = PhysicalMemoryBytes() / 2;
    b.triangles = b.memory ? static_cast<size_t>(b.memory / kBytesPerTriangle) : SIZE_MAX;
    b.triangles = std::min<size_t>(b.triangles, size_t(1) << 31);
    b.instances = size_t(1) << 22;
    b.nodes = size_t(1) << 22;
    b.depth = 1024;
    return b;
}

namespace {

bool InProcessRequested() {
    const char* v = std::getenv("LIGHTMESH_IMPORT_IN_PROCESS");
    return v && *v && std::strcmp(v, "0") != 0;
}

}  // namespace

LoadedMesh LoadMeshFile(const std::string& path, const MeshLoadOptions& options) {
    CheckReadable(path);  // cheap and clear; the child would say the same
    const ImportBudget budget = ImportBudget::ForThisMachine();
    const auto t0 = std::chrono::steady_clock::now();
    LoadedMesh out = InProcessRequested() ? ImportMeshInProcess(path, options, budget)
                                          : ImportIsolated(path, options, budget);
    LogDebug(StringPrintf("%s: imported in %.3f ms (%s)", path.c_str(),
                          std::chrono::duration<double, std::milli>(
                              std::chrono::steady_clock::now() - t0)
                              .count(),
                          InProcessRequested() ? "in process" : "child process"));
    return out;
}

}  // namespace lm
