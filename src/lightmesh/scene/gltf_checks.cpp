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
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {
        // Its place and the token, not Assimp's "no reader for this file format" (bare NaN or
        // Infinity tokens, which JSON does not have, made it say so).
        std::string what = e.what();
        if (const size_t at = what.find("parse error at "); at != std::string::npos)
            what = "at " + what.substr(at + 15);
        else if (const size_t end = what.find("] "); what.rfind("[json.exception.", 0) == 0 && end != std::string::npos)
            what = what.substr(end + 2);  // a number beyond double's range
        throw MeshFileError(path, "its glTF JSON does not parse, " + Printable(what), true);
    }
    if (!j.is_object()) return;  // Assimp reports it
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

std::string RepairGltfDataUris(const std::string& path, std::vector<std::string>* warnings) {
    if (LowerExtension(path) != ".gltf") return "";
    const std::string text = GltfJson(path, ".gltf");
    nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (j.is_discarded() || !j.is_object() || !j.contains("images") || !j["images"].is_array()) return "";
    bool changed = false;
    nlohmann::json& images = j["images"];
    for (size_t i = 0; i < images.size(); ++i) {
        if (!images[i].is_object() || !images[i].contains("uri") || !images[i]["uri"].is_string()) continue;
        const std::string uri = images[i]["uri"].get<std::string>();
        const size_t comma = uri.find(',');
        if (uri.rfind("data:", 0) != 0 || comma == std::string::npos || comma < 12 ||
            uri.compare(comma - 7, 7, ";base64") != 0)
            continue;
        std::string payload = uri.substr(comma + 1);
        std::string which = "image " + std::to_string(i);
        if (images[i].contains("name") && images[i]["name"].is_string())
            which += " (\"" + images[i]["name"].get<std::string>() + "\")";
        const std::string rest = "; the materials using it get their flat colour";
        if (payload.empty()) {
            warnings->push_back(path + ": " + which + ": its data: URI holds no bytes" + rest);
            continue;
        }
        const size_t bad = payload.find_first_not_of(
            "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/=");
        const size_t pad = payload.find('=');
        const bool padded = pad == std::string::npos || payload.find_first_not_of('=', pad) == std::string::npos;
        if (bad != std::string::npos || !padded || payload.size() % 4 == 1) {
            warnings->push_back(
                path + ": " + which + ": its data: URI is not base64 (" +
                (bad != std::string::npos ? "\"" + Printable(payload.substr(bad, 1)) + "\" at character " +
                                                std::to_string(bad + 1) + " of " + std::to_string(payload.size())
                                          : std::string("cut short or padded inside")) +
                ")" + rest);
            images[i]["uri"] = uri.substr(0, comma + 1);  // as an empty payload: no image
            changed = true;
        } else if (payload.size() % 4 != 0) {
            payload.append(4 - payload.size() % 4, '=');  // unpadded: Assimp 5.2 refused the whole file
            images[i]["uri"] = uri.substr(0, comma + 1) + payload;
            changed = true;
        }
    }
    return changed ? j.dump() : "";
}

}  // namespace mesh_import
}  // namespace lm
