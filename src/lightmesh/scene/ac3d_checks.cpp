// ac3d_checks.cpp -- AC3D files (.ac, .acc, .ac3d) whose objects carry several texture
// layers, made what Assimp reads. TORCS's tracks (.acc) give an object up to four `texture`
// lines (the base image, then "empty_texture_no_mapping" or tiled and skid layers) and one
// coordinate pair per layer on each `refs` line. Assimp 5.2's AC3D reader keeps the last
// `texture` line, which is usually an unquoted placeholder it reads as "ERROR", so a tree's
// leaf cards lose their image and its alpha cut-out and render as solid slabs. The first
// layer is the object's own image and its coordinates come first on each `refs` line (the
// pair Assimp reads), so every `texture` line after an object's first is left out.
#include "lightmesh/scene/mesh_import_internal.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <string_view>
#include <vector>

namespace lm {
namespace mesh_import {
namespace {

bool IsAc3dPath(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return ext == ".ac" || ext == ".acc" || ext == ".ac3d";
}

/// Whether `line` (leading blanks skipped) starts with the token `word`.
bool StartsWithToken(std::string_view line, std::string_view word) {
    const size_t at = line.find_first_not_of(" \t");
    if (at == std::string_view::npos) return false;
    line.remove_prefix(at);
    if (line.size() < word.size()) return false;
    for (size_t k = 0; k < word.size(); ++k)
        if (std::tolower(static_cast<unsigned char>(line[k])) != word[k]) return false;
    return line.size() == word.size() || line[word.size()] == ' ' || line[word.size()] == '\t' ||
           line[word.size()] == '\r';
}

}  // namespace

std::string RepairAc3dTextureLayers(const std::string& path, size_t* dropped) {
    if (dropped) *dropped = 0;
    if (!IsAc3dPath(path)) return "";
    std::ifstream in(path, std::ios::binary);
    if (!in) return "";  // Assimp names the problem
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (text.compare(0, 4, "AC3D") != 0) return "";
    std::string out;
    size_t removed = 0;
    int texturesInObject = 0;
    for (size_t at = 0; at < text.size();) {
        size_t end = text.find('\n', at);
        end = end == std::string::npos ? text.size() : end + 1;
        const std::string_view line(text.data() + at, end - at);
        if (StartsWithToken(line, "object")) texturesInObject = 0;
        if (StartsWithToken(line, "texture") && ++texturesInObject > 1) {
            if (removed == 0) out.assign(text, 0, at);  // the text so far, unchanged
            ++removed;
        } else if (removed > 0) {
            out.append(line);
        }
        at = end;
    }
    if (dropped) *dropped = removed;
    return removed ? out : "";
}

}  // namespace mesh_import
}  // namespace lm
