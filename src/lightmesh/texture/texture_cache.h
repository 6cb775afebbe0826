// texture_cache.h -- where a material's image comes from (a file beside the model, or bytes
// embedded in it), and the cache that reads each image once for a whole scene.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "lightmesh/texture/texture.h"

namespace lm {

/// An image a model's material refers to, as the import found it (it crosses from the
/// import's child process to the renderer, which decodes it).
struct TextureSource {
    /// The image file, resolved against the model's folder; empty for an embedded image.
    std::string file;
    /// For messages: the file as the model names it, or "embedded image N".
    std::string name;
    /// An embedded image: its file's bytes (PNG, JPEG, ...), or raw texels (below).
    std::string bytes;
    /// Raw embedded texels (Assimp's aiTexel: B, G, R, A bytes), rawWidth × rawHeight; 0
    /// for a file or encoded bytes.
    int rawWidth = 0, rawHeight = 0;
};

/// Reads each image once for a scene: sources naming the same file (by its canonical path)
/// or embedding the same bytes share one Texture.
class TextureCache {
  public:
    using Warn = std::function<void(const std::string&)>;
    /// The index into *textures of the image of `source`, read the first time it is asked
    /// for; -1 when it cannot be read, with one warning through `warn` ("<model>: texture
    /// <name>: <reason>; the material's flat colour is used").
    int Get(const TextureSource& source, const std::string& model,
            std::vector<std::shared_ptr<const Texture>>* textures, const Warn& warn);

  private:
    std::unordered_map<std::string, int> index_;
};

}  // namespace lm
