// texture_cache.cpp -- each image of a scene read once.
#include "lightmesh/texture/texture_cache.h"

#include <filesystem>
#include <system_error>

#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {
namespace {

std::string KeyOf(const TextureSource& s) {
    if (!s.file.empty()) {
        std::error_code ec;
        const std::filesystem::path canonical = std::filesystem::weakly_canonical(s.file, ec);
        return "file:" + (ec ? s.file : canonical.string());
    }
    return "embedded:" + std::to_string(s.rawWidth) + "x" + std::to_string(s.rawHeight) + ":" +
           std::to_string(s.bytes.size()) + ":" + std::to_string(std::hash<std::string>()(s.bytes));
}

std::shared_ptr<const Texture> Read(const TextureSource& s) {
    if (!s.file.empty()) {
        if (const std::string problem = RegularFileProblem(s.file, "file"); !problem.empty())
            ThrowError("%s", problem.c_str());
        return ReadTextureFile(s.file);
    }
    if (s.rawWidth > 0) {
        if (s.rawWidth > kMaxTextureSize || s.rawHeight < 1 || s.rawHeight > kMaxTextureSize ||
            s.bytes.size() != static_cast<size_t>(s.rawWidth) * static_cast<size_t>(s.rawHeight) * 4)
            ThrowError("its embedded texels are malformed");
        std::vector<uint8_t> rgba(s.bytes.size());
        for (size_t i = 0; i < rgba.size(); i += 4) {  // B, G, R, A to R, G, B, A
            rgba[i] = static_cast<uint8_t>(s.bytes[i + 2]);
            rgba[i + 1] = static_cast<uint8_t>(s.bytes[i + 1]);
            rgba[i + 2] = static_cast<uint8_t>(s.bytes[i]);
            rgba[i + 3] = static_cast<uint8_t>(s.bytes[i + 3]);
        }
        return std::make_shared<Texture>(s.rawWidth, s.rawHeight, std::move(rgba));
    }
    return DecodeTexture(s.bytes);
}

}  // namespace

int TextureCache::Get(const TextureSource& source, const std::string& model,
                      std::vector<std::shared_ptr<const Texture>>* textures, const Warn& warn) {
    const std::string key = KeyOf(source);
    if (auto it = index_.find(key); it != index_.end()) return it->second;
    int index = -1;
    try {
        textures->push_back(Read(source));
        index = static_cast<int>(textures->size() - 1);
    } catch (const std::exception& e) {
        // Error's what() is the reason alone here (ThrowError names no file).
        warn(model + ": texture \"" + source.name + "\": " + e.what() + "; the material's flat colour is used");
    }
    index_[key] = index;
    return index;
}

}  // namespace lm
