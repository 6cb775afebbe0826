// texture.cpp -- images in memory with their mip-maps, their lookups, and their decoding.
#include "lightmesh/texture/texture.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>

#include "lightmesh/io/image.h"
#include "lightmesh/io/image_decode.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

// PNG and JPEG by libpng and libjpeg-turbo (io/image_decode.h); stb_image only for the
// formats those do not read, TGA and BMP (its PNG and JPEG readers are compiled out: Debian
// 12's is a 2022 snapshot, and fuzzing found memory errors in its JPEG Huffman tables).
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_TGA
#define STBI_ONLY_BMP
#define STBI_NO_STDIO
#define STBI_FAILURE_USERMSG
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wsign-compare"
#pragma GCC diagnostic ignored "-Wunused-but-set-variable"
#include <stb_image.h>
#pragma GCC diagnostic pop

namespace lm {
namespace {

/// The linear value of each sRGB byte.
const std::array<float, 256>& SrgbTable() {
    static const std::array<float, 256> table = [] {
        std::array<float, 256> t{};
        for (int i = 0; i < 256; ++i) t[static_cast<size_t>(i)] = DecodeSrgb8(static_cast<unsigned char>(i));
        return t;
    }();
    return table;
}

}  // namespace

int texel::WrapIndex(int i, int n, TextureWrap wrap) {
    switch (wrap) {
        case TextureWrap::Clamp: return std::clamp(i, 0, n - 1);
        case TextureWrap::Mirror: {
            int m = i % (2 * n);
            if (m < 0) m += 2 * n;
            return m < n ? m : 2 * n - 1 - m;
        }
        case TextureWrap::Repeat:
        default: {
            const int m = i % n;
            return m < 0 ? m + n : m;
        }
    }
}

Texture::Texture(int width, int height, std::vector<uint8_t> rgba8) {
    Level l;
    l.w = width;
    l.h = height;
    l.ldr = std::move(rgba8);
    for (size_t i = 3; i < l.ldr.size(); i += 4) hasAlpha_ = hasAlpha_ || l.ldr[i] < 255;
    levels_.push_back(std::move(l));
    BuildMipMaps();
}

Texture::Texture(int width, int height, std::vector<float> rgba) {
    Level l;
    l.w = width;
    l.h = height;
    l.hdr = std::move(rgba);
    for (float& x : l.hdr)
        if (!std::isfinite(x)) x = 0;
    for (size_t i = 3; i < l.hdr.size(); i += 4) hasAlpha_ = hasAlpha_ || l.hdr[i] < 1;
    levels_.push_back(std::move(l));
    BuildMipMaps();
}

size_t Texture::Bytes() const {
    size_t n = 0;
    for (const Level& l : levels_) n += l.ldr.size() + l.hdr.size() * sizeof(float);
    return n;
}

// Each level from the one above by a 2 × 2 box in linear space (an odd side's last texel
// is taken twice), colour re-encoded to sRGB bytes for 8-bit images.
void Texture::BuildMipMaps() {
    while (levels_.back().w > 1 || levels_.back().h > 1) {
        const Level& up = levels_.back();
        Level l;
        l.w = std::max(1, (up.w + 1) / 2);
        l.h = std::max(1, (up.h + 1) / 2);
        const bool ldr = !up.ldr.empty();
        if (ldr)
            l.ldr.resize(static_cast<size_t>(l.w) * l.h * 4);
        else
            l.hdr.resize(static_cast<size_t>(l.w) * l.h * 4);
        for (int y = 0; y < l.h; ++y)
            for (int x = 0; x < l.w; ++x) {
                Texel sum;
                sum.a = 0;
                for (int dy = 0; dy < 2; ++dy)
                    for (int dx = 0; dx < 2; ++dx) {
                        const Texel t = Fetch(up, std::min(2 * x + dx, up.w - 1), std::min(2 * y + dy, up.h - 1));
                        sum.r += t.r, sum.g += t.g, sum.b += t.b, sum.a += t.a;
                    }
                const size_t i = (static_cast<size_t>(y) * l.w + x) * 4;
                if (ldr) {
                    l.ldr[i + 0] = EncodeSrgb8(sum.r * 0.25f);
                    l.ldr[i + 1] = EncodeSrgb8(sum.g * 0.25f);
                    l.ldr[i + 2] = EncodeSrgb8(sum.b * 0.25f);
                    l.ldr[i + 3] = static_cast<uint8_t>(std::lround(std::clamp(sum.a * 0.25f, 0.0f, 1.0f) * 255.0f));
                } else {
                    l.hdr[i + 0] = sum.r * 0.25f;
                    l.hdr[i + 1] = sum.g * 0.25f;
                    l.hdr[i + 2] = sum.b * 0.25f;
                    l.hdr[i + 3] = sum.a * 0.25f;
                }
            }
        levels_.push_back(std::move(l));
    }
}

Texel Texture::Fetch(const Level& level, int x, int y) const {
    const size_t i = (static_cast<size_t>(y) * static_cast<size_t>(level.w) + static_cast<size_t>(x)) * 4;
    if (!level.ldr.empty()) {
        const auto& srgb = SrgbTable();
        return {srgb[level.ldr[i]], srgb[level.ldr[i + 1]], srgb[level.ldr[i + 2]],
                static_cast<float>(level.ldr[i + 3]) * (1.0f / 255.0f)};
    }
    return {level.hdr[i], level.hdr[i + 1], level.hdr[i + 2], level.hdr[i + 3]};
}

Texel Texture::Bilinear(const Level& level, float u, float v, TextureWrap wrapU, TextureWrap wrapV) const {
    int x0, y0;
    float fx, fy;
    texel::Position(level.w, level.h, u, v, &x0, &y0, &fx, &fy);
    int xa, xb, ya, yb;
    texel::Neighbours(x0, level.w, wrapU, &xa, &xb);
    texel::Neighbours(y0, level.h, wrapV, &ya, &yb);
    const float w[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
    const size_t row0 = static_cast<size_t>(ya) * static_cast<size_t>(level.w),
                 row1 = static_cast<size_t>(yb) * static_cast<size_t>(level.w);
    const size_t at[4] = {(row0 + static_cast<size_t>(xa)) * 4, (row0 + static_cast<size_t>(xb)) * 4,
                          (row1 + static_cast<size_t>(xa)) * 4, (row1 + static_cast<size_t>(xb)) * 4};
    Texel t;
    t.a = 0;
    if (!level.ldr.empty()) {
        const auto& srgb = SrgbTable();
        const uint8_t* p = level.ldr.data();
        for (int k = 0; k < 4; ++k) {
            const uint8_t* q = p + at[k];
            t.r += srgb[q[0]] * w[k];
            t.g += srgb[q[1]] * w[k];
            t.b += srgb[q[2]] * w[k];
            t.a += static_cast<float>(q[3]) * w[k];
        }
        t.a *= 1.0f / 255.0f;
    } else {
        const float* p = level.hdr.data();
        for (int k = 0; k < 4; ++k) {
            const float* q = p + at[k];
            t.r += q[0] * w[k];
            t.g += q[1] * w[k];
            t.b += q[2] * w[k];
            t.a += q[3] * w[k];
        }
    }
    return t;
}

Texel Texture::Sample(float u, float v, float lod, TextureWrap wrapU, TextureWrap wrapV) const {
    const float top = static_cast<float>(levels_.size() - 1);
    if (!(lod > 0)) return Bilinear(levels_[0], u, v, wrapU, wrapV);
    if (lod >= top) return Bilinear(levels_.back(), u, v, wrapU, wrapV);
    return Bilinear(levels_[static_cast<size_t>(lod)], u, v, wrapU, wrapV);
}

Texel Texture::SampleTrilinear(float u, float v, float lod, TextureWrap wrapU, TextureWrap wrapV) const {
    const float top = static_cast<float>(levels_.size() - 1);
    if (!(lod > 0)) return Bilinear(levels_[0], u, v, wrapU, wrapV);
    if (lod >= top) return Bilinear(levels_.back(), u, v, wrapU, wrapV);
    const int l = static_cast<int>(lod);
    const float f = lod - static_cast<float>(l);
    const Texel a = Bilinear(levels_[static_cast<size_t>(l)], u, v, wrapU, wrapV);
    if (f == 0) return a;
    const Texel b = Bilinear(levels_[static_cast<size_t>(l) + 1], u, v, wrapU, wrapV);
    return {a.r + (b.r - a.r) * f, a.g + (b.g - a.g) * f, a.b + (b.b - a.b) * f, a.a + (b.a - a.a) * f};
}

float Texture::TexelOpacity(int x, int y, TextureWrap wrapU, TextureWrap wrapV, int channel) const {
    const Level& level = levels_[0];
    const size_t i = (static_cast<size_t>(texel::WrapIndex(y, level.h, wrapV)) * static_cast<size_t>(level.w) +
                      static_cast<size_t>(texel::WrapIndex(x, level.w, wrapU))) * 4 + static_cast<size_t>(channel);
    return !level.ldr.empty() ? static_cast<float>(level.ldr[i]) * (1.0f / 255.0f) : level.hdr[i];
}

float Texture::OpacityOf(const TexelCell& cell, int channel) const {
    const Level& level = levels_[0];
    const float fx = cell.fx, fy = cell.fy;
    const size_t w = static_cast<size_t>(level.w), c = static_cast<size_t>(channel);
    const size_t i00 = (static_cast<size_t>(cell.ya) * w + static_cast<size_t>(cell.xa)) * 4 + c,
                 i10 = (static_cast<size_t>(cell.ya) * w + static_cast<size_t>(cell.xb)) * 4 + c,
                 i01 = (static_cast<size_t>(cell.yb) * w + static_cast<size_t>(cell.xa)) * 4 + c,
                 i11 = (static_cast<size_t>(cell.yb) * w + static_cast<size_t>(cell.xb)) * 4 + c;
    float a00, a10, a01, a11;
    if (!level.ldr.empty()) {
        const uint8_t* p = level.ldr.data();
        a00 = p[i00], a10 = p[i10], a01 = p[i01], a11 = p[i11];
        return ((a00 * (1 - fx) + a10 * fx) * (1 - fy) + (a01 * (1 - fx) + a11 * fx) * fy) * (1.0f / 255.0f);
    } else {
        const float* p = level.hdr.data();
        a00 = p[i00], a10 = p[i10], a01 = p[i01], a11 = p[i11];
    }
    return (a00 * (1 - fx) + a10 * fx) * (1 - fy) + (a01 * (1 - fx) + a11 * fx) * fy;
}

float Texture::Opacity(float u, float v, TextureWrap wrapU, TextureWrap wrapV, int channel) const {
    return OpacityOf(CellAt(u, v, wrapU, wrapV), channel);
}

bool DecodedImage::Consistent() const {
    if (width < 1 || height < 1 || width > kMaxTextureSize || height > kMaxTextureSize) return false;
    const size_t n = static_cast<size_t>(width) * static_cast<size_t>(height) * 4;
    return (ldr.size() == n && hdr.empty()) || (hdr.size() == n && ldr.empty());
}

std::shared_ptr<const Texture> DecodedImage::MakeTexture() && {
    if (!ldr.empty()) return std::make_shared<Texture>(width, height, std::move(ldr));
    return std::make_shared<Texture>(width, height, std::move(hdr));
}

namespace {

/// The width and height an image's head tells: a PNG's or JPEG's (io/image_decode.h), or
/// stb_image's reading of a TGA or BMP head. False when it tells none.
bool HeadSize(const std::string& bytes, int* w, int* h) {
    if (CodedImageKindOf(bytes.data(), bytes.size()) != CodedImageKind::Other)
        return CodedImageHeadSize(bytes.data(), bytes.size(), w, h);
    int n = 0;
    return stbi_info_from_memory(reinterpret_cast<const stbi_uc*>(bytes.data()),
                                 static_cast<int>(std::min<size_t>(bytes.size(), INT32_MAX)), w, h, &n) != 0;
}

}  // namespace

DecodedImage DecodeImageBytes(const std::string& bytes) {
    if (bytes.empty()) ThrowError("the image is empty");
    if (bytes.size() > static_cast<size_t>(INT32_MAX)) ThrowError("the image is larger than 2 GiB");
    const CodedImageKind kind = CodedImageKindOf(bytes.data(), bytes.size());
    int w = 0, h = 0;
    if (kind != CodedImageKind::Other && !CodedImageHeadSize(bytes.data(), bytes.size(), &w, &h))
        ThrowError("cannot decode the image (its %s head is cut short or malformed)",
                   kind == CodedImageKind::Png ? "PNG" : "JPEG");
    if (kind == CodedImageKind::Other && !HeadSize(bytes, &w, &h))
        ThrowError("cannot decode the image (%s)", stbi_failure_reason());
    if (w < 1 || h < 1 || w > kMaxTextureSize || h > kMaxTextureSize)
        ThrowError("the image is %d x %d, beyond the %d x %d textures may have", w, h, kMaxTextureSize,
                   kMaxTextureSize);
    const size_t texels = static_cast<size_t>(w) * static_cast<size_t>(h);
    DecodedImage image;
    if (kind != CodedImageKind::Other) {
        DecodedPixels p;
        try {
            p = kind == CodedImageKind::Png ? DecodePng(bytes.data(), bytes.size(), 4, kMaxTextureSize)
                                            : DecodeJpeg(bytes.data(), bytes.size(), 4, kMaxTextureSize);
        } catch (const Error& e) {
            ThrowError("cannot decode the image (%s)", e.what());
        }
        if (p.width != w || p.height != h) ThrowError("cannot decode the image (its size changed while it was read)");
        if (p.bits == 16) {
            image.hdr.resize(texels * 4);
            for (size_t i = 0; i < texels * 4; ++i) {
                const float x = static_cast<float>(p.rgba16[i]) / 65535.0f;
                image.hdr[i] = i % 4 == 3 ? x : SrgbDecode(x);
            }
        } else {
            image.ldr = std::move(p.rgba8);
        }
    } else {  // TGA, BMP: stb_image, 8 bits
        const auto* data = reinterpret_cast<const stbi_uc*>(bytes.data());
        int lw = 0, lh = 0;
        stbi_uc* p = stbi_load_from_memory(data, static_cast<int>(bytes.size()), &lw, &lh, nullptr, 4);
        if (!p) ThrowError("cannot decode the image (%s)", stbi_failure_reason());
        if (lw != w || lh != h) {
            stbi_image_free(p);
            ThrowError("cannot decode the image (its size changed while it was read)");
        }
        image.ldr.assign(p, p + texels * 4);
        stbi_image_free(p);
    }
    image.width = w, image.height = h;
    return image;
}

DecodedImage ReadImageFile(const std::string& path) {
    std::string ext = path.size() >= 4 ? path.substr(path.size() - 4) : "";
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (ext == ".exr") {
        // Its size from its header first: one past the textures' limit is not decoded.
        ImageSize head;
        try {
            head = ReadImageSize(path);
        } catch (const Error&) {  // ReadImage says what is wrong with it
        }
        if (head.width > kMaxTextureSize || head.height > kMaxTextureSize)
            ThrowError("the image is %d x %d, beyond the %d x %d textures may have; not read", head.width, head.height,
                       kMaxTextureSize, kMaxTextureSize);
        const Image exr = ReadImage(path);
        if (exr.width > kMaxTextureSize || exr.height > kMaxTextureSize)
            ThrowError("the image is %d x %d, beyond the %d x %d textures may have", exr.width, exr.height,
                       kMaxTextureSize, kMaxTextureSize);
        DecodedImage image;
        image.width = exr.width, image.height = exr.height;
        image.hdr.resize(exr.pixels.size() * 4);
        for (size_t i = 0; i < exr.pixels.size(); ++i) {
            image.hdr[4 * i] = exr.pixels[i].r;
            image.hdr[4 * i + 1] = exr.pixels[i].g;
            image.hdr[4 * i + 2] = exr.pixels[i].b;
            image.hdr[4 * i + 3] = 1;
        }
        return image;
    }
    // The format and size are judged from the file's head before it is read whole (a 20 GB
    // sparse file named .png would be read for 38 s and 7.9 GB before a warning).
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) ThrowError("cannot open it");
    const auto end = in.tellg();
    const uint64_t size = end > 0 ? static_cast<uint64_t>(end) : 0;
    in.seekg(0);
    std::string bytes(static_cast<size_t>(std::min<uint64_t>(size, kImageProbeBytes)), '\0');
    in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (in.bad() || static_cast<size_t>(in.gcount()) != bytes.size()) ThrowError("cannot read it");
    if (size > bytes.size()) {
        const size_t zeros = std::min<size_t>(bytes.size(), 4096);
        if (std::all_of(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(zeros), [](char c) { return c == 0; }))
            ThrowError("its first %zu bytes are all zero (NUL): not an image (a zeroed or sparse file?); not read", zeros);
        int w = 0, h = 0;
        // A JPEG's size may follow more than a MiB of metadata: up to 64 MiB, such a file
        // is read whole and the decoder judges it.
        const bool known = HeadSize(bytes, &w, &h);
        if (!known && size <= kImageWholeReadBytes) w = h = 1;
        else if (!known)
            ThrowError("its first %s (of %s) are not the head of a PNG, JPEG, TGA or BMP image; not read",
                       FormatBytes(bytes.size()).c_str(), FormatBytes(size).c_str());
        if (w < 1 || h < 1 || w > kMaxTextureSize || h > kMaxTextureSize)
            ThrowError("the image is %d x %d, beyond the %d x %d textures may have; not read", w, h, kMaxTextureSize,
                       kMaxTextureSize);
        // The largest file those texels make: 16-bit RGBA stored without compression (with
        // the PNG rows' filter bytes and deflate's block headers), and room for metadata.
        const uint64_t most = static_cast<uint64_t>(w) * static_cast<uint64_t>(h) * 8 * 102 / 100 + (16u << 20);
        if (known && size > most)
            ThrowError("the file is %s, more than a %d x %d image takes (at most %s); not read",
                       FormatBytes(size).c_str(), w, h, FormatBytes(most).c_str());
        bytes.resize(static_cast<size_t>(size));
        in.read(bytes.data() + kImageProbeBytes, static_cast<std::streamsize>(size - kImageProbeBytes));
        if (in.bad() || static_cast<uint64_t>(in.gcount()) != size - kImageProbeBytes) ThrowError("cannot read it");
    }
    return DecodeImageBytes(bytes);
}

std::shared_ptr<const Texture> DecodeTexture(const std::string& bytes) {
    return DecodeImageBytes(bytes).MakeTexture();
}

std::shared_ptr<const Texture> ReadTextureFile(const std::string& path) { return ReadImageFile(path).MakeTexture(); }

}  // namespace lm
