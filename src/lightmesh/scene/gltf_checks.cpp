// gltf_checks.cpp -- glTF node graphs, checked before Assimp expands them: its importer makes
// one aiNode per path through the graph, recursively, so a cycle or a deep chain overflows its
// stack and 24 levels of nodes sharing two children make 2^24 nodes.
#include "lightmesh/scene/mesh_import_internal.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {
namespace mesh_import {
namespace {

std::string LowerExtension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

/// The JSON of a .gltf, or the JSON chunk of a .glb; "" if it is neither.
std::string GltfJson(const std::string& path, const std::string& ext) {
    std::string bytes;
    try {
        bytes = ReadRegularFile(path, "mesh file");
    } catch (const Error&) {
        return "";
    }
    if (ext == ".gltf") return bytes;
    // .glb: magic "glTF", version, length; chunk 0: length, type "JSON", data.
    if (bytes.size() < 20 || bytes.compare(0, 4, "glTF") != 0) return "";
    uint32_t chunkLength = 0;
    std::memcpy(&chunkLength, bytes.data() + 12, 4);
    if (bytes.compare(16, 4, "JSON") != 0 || chunkLength > bytes.size() - 20) return "";
    return bytes.substr(20, chunkLength);
}

}  // namespace

void CheckGltfHierarchy(const std::string& path, const ImportBudget& budget) {
    const std::string ext = LowerExtension(path);
    if (ext != ".gltf" && ext != ".glb") return;
    const std::string text = GltfJson(path, ext);
    if (text.empty()) return;
    const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded() || !j.is_object()) return;  // Assimp reports it
    const auto nodesIt = j.find("nodes");
    if (nodesIt == j.end() || !nodesIt->is_array()) return;
    const nlohmann::json& nodes = *nodesIt;
    const size_t n = nodes.size();
    std::vector<std::vector<size_t>> children(n);
    std::vector<bool> isChild(n, false);
    for (size_t i = 0; i < n; ++i) {
        if (!nodes[i].is_object()) continue;
        const auto c = nodes[i].find("children");
        if (c == nodes[i].end() || !c->is_array()) continue;
        for (const auto& k : *c) {
            if (!k.is_number_unsigned() || k.get<uint64_t>() >= n) continue;  // Assimp reports it
            children[i].push_back(static_cast<size_t>(k.get<uint64_t>()));
            isChild[static_cast<size_t>(k.get<uint64_t>())] = true;
        }
    }
    // Depth-first, without recursion: expanded size and depth of each node's subtree.
    constexpr uint64_t kSaturated = uint64_t(1) << 62;
    std::vector<uint8_t> state(n, 0);  // 0 new, 1 on the stack, 2 done
    std::vector<uint64_t> size(n, 1), depth(n, 1);
    for (size_t start = 0; start < n; ++start) {
        if (state[start]) continue;
        std::vector<std::pair<size_t, size_t>> stack{{start, 0}};
        state[start] = 1;
        while (!stack.empty()) {
            auto& [node, next] = stack.back();
            if (next < children[node].size()) {
                const size_t c = children[node][next++];
                if (state[c] == 1)
                    throw MeshFileError(
                        path,
                        StringPrintf("glTF node %zu is its own descendant: the node hierarchy "
                                     "has a cycle",
                                     c),
                        true);
                if (state[c] == 0) {
                    state[c] = 1;
                    stack.push_back({c, 0});
                }
                continue;
            }
            uint64_t total = 1, deepest = 0;
            for (size_t c : children[node]) {
                total = std::min(kSaturated, total + size[c]);
                deepest = std::max(deepest, depth[c]);
            }
            size[node] = total;
            depth[node] = deepest + 1;
            state[node] = 2;
            stack.pop_back();
        }
    }
    uint64_t instances = 0, deepest = 0;
    for (size_t i = 0; i < n; ++i) {
        if (isChild[i]) continue;
        instances = std::min(kSaturated, instances + size[i]);
        deepest = std::max(deepest, depth[i]);
    }
    if (deepest > budget.depth)
        throw MeshFileError(path,
                            StringPrintf("the glTF node hierarchy is %s levels deep, more than "
                                         "the limit of %u",
                                         Thousands(deepest).c_str(), budget.depth),
                            true);
    if (instances > budget.nodes)
        throw MeshFileError(
            path,
            StringPrintf("the glTF nodes share children so that they expand to %s node "
                         "instances, more than the importer's budget of %s",
                         instances >= kSaturated ? "more than 4.6e18"
                                                 : Thousands(instances).c_str(),
                         Thousands(budget.nodes).c_str()),
            true);
}

}  // namespace mesh_import
}  // namespace lm
