// texture.h -- an image a material samples: its mip-map pyramid in memory, bilinear and
// trilinear lookups with wrap modes, and the decoding of the files it comes from (PNG by
// libpng, JPEG by libjpeg-turbo, TGA and BMP by stb_image, OpenEXR). Loading each image once is texture_cache.h's.
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "lightmesh/math/vec.h"

namespace lm {

/// What a lookup outside [0, 1] reads (glTF's samplers, Assimp's aiTextureMapMode).
enum class TextureWrap : uint8_t { Repeat, Clamp, Mirror };

namespace texel {
/// Index i of a side of n texels, wrapped.
int WrapIndex(int i, int n, TextureWrap wrap);
/// A texture coordinate as a finite value whose texel index stays in int range (a huge or
/// NaN coordinate would overflow the index arithmetic).
inline float Tame(float u) {
    if (!std::isfinite(u)) return 0.0f;
    if (!(std::abs(u) < 1e5f)) return std::fmod(u, 1.0f);  // texel indices stay within int
    return u;
}
/// Where (u, v) falls among a w × h level's texel centres: the texel (x0, y0) below and left
/// of it (v runs up the image) and the fractions (fx, fy) towards the next ones.
inline void Position(int w, int h, float u, float v, int* x0, int* y0, float* fx, float* fy) {
    const float x = Tame(u) * static_cast<float>(w) - 0.5f;
    const float y = (1.0f - Tame(v)) * static_cast<float>(h) - 0.5f;
    // floor without a libm call (x is within ±2^24 after Tame)
    *x0 = static_cast<int>(x), *y0 = static_cast<int>(y);
    *x0 -= static_cast<float>(*x0) > x;
    *y0 -= static_cast<float>(*y0) > y;
    *fx = x - static_cast<float>(*x0), *fy = y - static_cast<float>(*y0);
}
/// The two texels a bilinear lookup reads along one axis of n texels: a = texel i wrapped,
/// b = its neighbour i + 1 wrapped. Repeat on a side of 2^k texels (most images) is a mask
/// instead of a division; otherwise the neighbour is a + 1 unless that leaves the image
/// (Repeat: i + 1 wraps to a + 1 below the edge; Clamp and Mirror: where i is in the image
/// itself), and i + 1 wrapped there.
inline void Neighbours(int i, int n, TextureWrap wrap, int* a, int* b) {
    if (wrap == TextureWrap::Repeat && (n & (n - 1)) == 0) {
        *a = i & (n - 1), *b = (i + 1) & (n - 1);
        return;
    }
    *a = WrapIndex(i, n, wrap);
    *b = (wrap == TextureWrap::Repeat || i == *a) && *a + 1 < n ? *a + 1 : WrapIndex(i + 1, n, wrap);
}
}  // namespace texel

/// A colour and its coverage, linear.
struct Texel {
    float r = 0, g = 0, b = 0, a = 1;
    Color Rgb() const { return {r, g, b}; }
};

/// An image in memory with its mip-maps (each level half the last, rounded up, down to
/// 1 × 1; box-filtered in linear space). 8-bit images keep their sRGB bytes (4 per texel,
/// decoded by a table at lookup: a quarter of the memory of floats); EXR and 16-bit images
/// keep linear floats. Immutable once built: shared between materials and threads.
class Texture {
  public:
    /// From 8-bit RGBA texels, row 0 at the top; colour sRGB-encoded, alpha linear.
    Texture(int width, int height, std::vector<uint8_t> rgba8);
    /// From linear float RGBA texels, row 0 at the top.
    Texture(int width, int height, std::vector<float> rgba);

    int Width() const { return levels_[0].w; }
    int Height() const { return levels_[0].h; }
    int Levels() const { return static_cast<int>(levels_.size()); }
    /// Whether some texel of the image has alpha below 1 (a cut-out can use it).
    bool HasAlpha() const { return hasAlpha_; }
    /// Bytes of all levels.
    size_t Bytes() const;

    /// The texel at texture coordinates (u, v) (v grows upwards: row 0 of the image is at
    /// v = 1, Assimp's convention for every format), filtered bilinearly on mip level
    /// floor(`lod`) (0: the full image; clamped to the pyramid), as pbrt-v4's default
    /// "bilinear" filter: half the lookups of trilinear filtering.
    Texel Sample(float u, float v, float lod, TextureWrap wrapU, TextureWrap wrapV) const;
    /// The same, blended linearly between levels floor(lod) and floor(lod) + 1.
    Texel SampleTrilinear(float u, float v, float lod, TextureWrap wrapU, TextureWrap wrapV) const;
    /// The alpha at (u, v), bilinear on the full image: the cut-out test's lookup, the same
    /// for every ray query.
    float Alpha(float u, float v, TextureWrap wrapU, TextureWrap wrapV) const { return Opacity(u, v, wrapU, wrapV, 3); }
    /// Channel `channel` (0 red … 3 alpha) at (u, v), bilinear on the full image, as stored:
    /// an 8-bit byte / 255 with no sRGB decoding (an opacity map is data, not colour).
    float Opacity(float u, float v, TextureWrap wrapU, TextureWrap wrapV, int channel) const;
    /// The four texels Opacity at (u, v) reads on the full image, (xa, ya), (xb, ya), (xa, yb)
    /// and (xb, yb) (wrapped), and the fractions towards (xb, yb).
    struct TexelCell {
        int xa, xb, ya, yb;
        float fx, fy;
    };
    TexelCell CellAt(float u, float v, TextureWrap wrapU, TextureWrap wrapV) const {
        const Level& level = levels_[0];
        int x0, y0;
        TexelCell c;
        texel::Position(level.w, level.h, u, v, &x0, &y0, &c.fx, &c.fy);
        texel::Neighbours(x0, level.w, wrapU, &c.xa, &c.xb);
        texel::Neighbours(y0, level.h, wrapV, &c.ya, &c.yb);
        return c;
    }
    /// Opacity's bilinear value in `cell`: Opacity(u, v, …) is OpacityOf(CellAt(u, v, …), …).
    float OpacityOf(const TexelCell& cell, int channel) const;
    /// Channel `channel` of texel (x, y) of the full image (indices wrapped as lookups wrap
    /// them), as Opacity reads it.
    float TexelOpacity(int x, int y, TextureWrap wrapU, TextureWrap wrapV, int channel) const;

  private:
    struct Level {
        int w = 0, h = 0;
        std::vector<uint8_t> ldr;  // 4 bytes a texel, or empty
        std::vector<float> hdr;    // 4 floats a texel, or empty
    };
    Texel Fetch(const Level& level, int x, int y) const;
    Texel Bilinear(const Level& level, float u, float v, TextureWrap wrapU, TextureWrap wrapV) const;
    void BuildMipMaps();

    std::vector<Level> levels_;
    bool hasAlpha_ = false;
};

/// An image's full-resolution texels as a decoder gives them, before the mip-maps: 8-bit
/// RGBA (colour sRGB-encoded) or linear float RGBA, row 0 at the top. What crosses from the
/// decoding child process (texture_cache.h) to the renderer.
struct DecodedImage {
    int width = 0, height = 0;
    std::vector<uint8_t> ldr;  ///< 4 bytes a texel, or empty
    std::vector<float> hdr;    ///< 4 floats a texel, or empty
    /// Whether the texels are as many as width × height says, in one of the two forms.
    bool Consistent() const;
    /// The texture with its mip-maps.
    std::shared_ptr<const Texture> MakeTexture() &&;
};

/// Decodes an image file's bytes (PNG, JPEG, TGA, BMP; 8 or 16 bits per channel; grey,
/// grey+alpha, RGB or RGBA). Throws Error with the decoder's reason.
DecodedImage DecodeImageBytes(const std::string& bytes);
/// Reads an image file: OpenEXR by its extension (.exr), else DecodeImageBytes. Throws Error
/// naming the problem (not the file: the caller names it).
DecodedImage ReadImageFile(const std::string& path);
/// DecodeImageBytes and ReadImageFile as textures, decoded in this process (tests; the
/// renderer decodes in a child process, texture_cache.h).
std::shared_ptr<const Texture> DecodeTexture(const std::string& bytes);
std::shared_ptr<const Texture> ReadTextureFile(const std::string& path);

/// The largest width or height accepted (8192² RGBA8 texels are 341 MiB with the mips).
inline constexpr int kMaxTextureSize = 8192;
/// The head of an image file ReadImageFile reads first, to judge its format and size before
/// reading the rest: 1 MiB (a JPEG's size may follow its metadata).
inline constexpr uint64_t kImageProbeBytes = 1 << 20;
/// A file whose head tells no size is still read whole up to this (its decoder judges it).
inline constexpr uint64_t kImageWholeReadBytes = 64 << 20;

}  // namespace lm
