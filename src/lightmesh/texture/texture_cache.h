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
/// or embedding the same bytes share one Texture. The decoders (libpng, libjpeg-turbo, stb_image, OpenEXR) run in a
/// child process (util/isolated_child.h) with the memory limit and a deadline, as the
/// importers do: a malformed image that crashes a decoder, or makes it allocate or loop
/// without end, costs that image (one warning, the flat colour), not the render.
class TextureCache {
  public:
    using Warn = std::function<void(const std::string&)>;
    /// What turns a source into texels (throws Error with the reason); run in the child.
    using Decoder = std::function<DecodedImage(const TextureSource&)>;
    /// The decoders of texture.h.
    TextureCache();
    /// Another decoder (tests).
    explicit TextureCache(Decoder decoder);

    /// The indices into *textures of the images of `sources`, those not read before decoded
    /// in one child process (another one for the rest when a decoder crashes); -1 for an
    /// image that cannot be read, with one warning through `warn` ("<model>: texture
    /// <name>: <reason>; the material's flat colour is used").
    std::vector<int> GetAll(const std::vector<TextureSource>& sources, const std::string& model,
                            std::vector<std::shared_ptr<const Texture>>* textures, const Warn& warn);
    /// GetAll of one source.
    int Get(const TextureSource& source, const std::string& model, std::vector<std::shared_ptr<const Texture>>* textures,
            const Warn& warn);

  private:
    Decoder decoder_;
    std::unordered_map<std::string, int> index_;
};

/// The texels of a source as texture.h's decoders read them (a file, encoded bytes or raw
/// BGRA texels), in this process. Throws Error with the reason.
DecodedImage DecodeSource(const TextureSource& source);

}  // namespace lm
