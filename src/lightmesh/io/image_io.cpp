#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "lightmesh/io/image.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

// stb's implementation lives in this one translation unit, with internal linkage.
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wunused-function"
#include <stb_image.h>
#include <stb_image_write.h>
#pragma GCC diagnostic pop

namespace lm {

ImageFormat ImageFormatFor(const std::string& path) {
    std::string ext;
    const size_t dot = path.find_last_of('.');
    const size_t slash = path.find_last_of('/');
    if (dot != std::string::npos && (slash == std::string::npos || dot > slash))
        ext = path.substr(dot);
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext == ".png") return ImageFormat::Png;
    if (ext == ".exr") return ImageFormat::Exr;
    ThrowError("%s: unknown image extension \"%s\" (use .png or .exr)", path.c_str(), ext.c_str());
}

unsigned char EncodeSrgb8Reference(float v) {
    if (!(v > 0)) return 0;  // also maps NaN to 0
    if (v >= 1) return 255;
    const float s = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
    return static_cast<unsigned char>(std::lround(s * 255.0f));
}

float DecodeSrgb8(unsigned char e) {
    const float s = static_cast<float>(e) / 255.0f;
    return s <= 0.04045f ? s / 12.92f : std::pow((s + 0.055f) / 1.055f, 2.4f);
}

namespace {

constexpr uint32_t FloatBits(float f) { return std::bit_cast<uint32_t>(f); }
constexpr float BitsFloat(uint32_t u) { return std::bit_cast<float>(u); }

// EncodeSrgb8Reference is monotonic, so its result is the number of its 255 steps at or
// below v. The steps (the smallest float that encodes to k, for k = 1..255) are found
// once, by bisection over float bit patterns with the reference itself. The encoder then
// looks v's top 16 bits (exponent and 7 mantissa bits) up in a table of buckets, each of
// which holds at most one step, and refines with one compare against that step.
class Srgb8Encoder {
  public:
    // Buckets are the floats sharing their top 16 bits, from 2^-15 (below the first step,
    // 1.5e-4) up to 1; everything below 2^-15 (and 0, after clamping) falls in bucket 0.
    static constexpr uint32_t kFirstBucket = (127 - 15) << 7;  // FloatBits(2^-15) >> 16
    static constexpr uint32_t kBuckets = (FloatBits(1.0f) >> 16) - kFirstBucket + 1;

    Srgb8Encoder() {
        float step[257];  // step[k]: the smallest float encoding to k; +-inf at the ends
        step[0] = -std::numeric_limits<float>::infinity();
        step[256] = std::numeric_limits<float>::infinity();
        for (int k = 1; k <= 255; ++k) {
            uint32_t lo = FloatBits(0.0f), hi = FloatBits(1.0f);  // Ref(lo) < k <= Ref(hi)
            while (hi - lo > 1) {
                const uint32_t mid = lo + (hi - lo) / 2;
                (EncodeSrgb8Reference(BitsFloat(mid)) >= k ? hi : lo) = mid;
            }
            step[k] = BitsFloat(hi);
        }
        for (uint32_t b = 0; b < kBuckets; ++b) {
            const float first = BitsFloat((kFirstBucket + b) << 16);
            int k = 0;
            while (k < 255 && step[k + 1] <= first) ++k;
            // At most one step per bucket, or one compare could not refine the lookup.
            assert(k == 255 || step[k + 2] > BitsFloat(((kFirstBucket + b + 1) << 16) - 1));
            bucket_[b] = {step[k + 1], k};
        }
    }

    unsigned char operator()(float v) const {
        float c = v > 0.0f ? v : 0.0f;  // NaN and negatives: 0
        c = c < 1.0f ? c : 1.0f;
        uint32_t b = FloatBits(c) >> 16;
        b = b > kFirstBucket ? b - kFirstBucket : 0;
        const Bucket& e = bucket_[b];
        return static_cast<unsigned char>(e.first + (c >= e.next));
    }

    /// Encodes n floats: out[i] = (*this)(in[i]).
    void operator()(const float* in, size_t n, unsigned char* out) const {
        size_t i = 0;
#if defined(__SSE2__)
        const __m128 zero = _mm_setzero_ps(), one = _mm_set1_ps(1.0f);
        const __m128i firstBucket = _mm_set1_epi32(static_cast<int>(kFirstBucket));
        for (; i + 4 <= n; i += 4) {
            // max(v, 0) gives its second operand, 0, for NaN.
            const __m128 c = _mm_min_ps(_mm_max_ps(_mm_loadu_ps(in + i), zero), one);
            __m128i b = _mm_srli_epi32(_mm_castps_si128(c), 16);
            b = _mm_and_si128(_mm_sub_epi32(b, firstBucket), _mm_cmpgt_epi32(b, firstBucket));
            alignas(16) uint32_t idx[4];
            _mm_store_si128(reinterpret_cast<__m128i*>(idx), b);
            const __m128i e01 = _mm_unpacklo_epi64(
                _mm_loadl_epi64(reinterpret_cast<const __m128i*>(&bucket_[idx[0]])),
                _mm_loadl_epi64(reinterpret_cast<const __m128i*>(&bucket_[idx[1]])));
            const __m128i e23 = _mm_unpacklo_epi64(
                _mm_loadl_epi64(reinterpret_cast<const __m128i*>(&bucket_[idx[2]])),
                _mm_loadl_epi64(reinterpret_cast<const __m128i*>(&bucket_[idx[3]])));
            const __m128 next = _mm_shuffle_ps(_mm_castsi128_ps(e01), _mm_castsi128_ps(e23),
                                               _MM_SHUFFLE(2, 0, 2, 0));
            const __m128i first = _mm_castps_si128(_mm_shuffle_ps(
                _mm_castsi128_ps(e01), _mm_castsi128_ps(e23), _MM_SHUFFLE(3, 1, 3, 1)));
            // The compare's mask is -1 where c reaches the bucket's next step.
            __m128i k = _mm_sub_epi32(first, _mm_castps_si128(_mm_cmpge_ps(c, next)));
            k = _mm_packs_epi32(k, k);
            k = _mm_packus_epi16(k, k);
            const uint32_t bytes = static_cast<uint32_t>(_mm_cvtsi128_si32(k));
            std::memcpy(out + i, &bytes, 4);
        }
#endif
        for (; i < n; ++i) out[i] = (*this)(in[i]);
    }

  private:
    struct Bucket {
        float next;     // the step after `first`: the smallest float encoding to first + 1
        int32_t first;  // the encoding of the bucket's first float
    };
    static_assert(sizeof(Bucket) == 8);
    Bucket bucket_[kBuckets];
};

const Srgb8Encoder& Srgb8() {
    static const Srgb8Encoder encoder;
    return encoder;
}

}  // namespace

unsigned char EncodeSrgb8(float v) { return Srgb8()(v); }

namespace {

void WritePng(const std::string& tmp, const Image& image) {
    static_assert(sizeof(Color) == 3 * sizeof(float), "the pixels are 3 * width * height floats");
    std::vector<unsigned char> rgb(image.pixels.size() * 3);
    Srgb8()(&image.pixels[0].r, rgb.size(), rgb.data());
    std::vector<unsigned char> bytes;
    auto append = [](void* ctx, void* data, int size) {
        auto* out = static_cast<std::vector<unsigned char>*>(ctx);
        out->insert(out->end(), static_cast<unsigned char*>(data),
                    static_cast<unsigned char*>(data) + size);
    };
    if (!stbi_write_png_to_func(append, &bytes, image.width, image.height, 3, rgb.data(),
                                image.width * 3))
        ThrowError("%s: PNG encoding failed", tmp.c_str());
    std::ofstream out(tmp, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) ThrowError("%s: write failed: %s", tmp.c_str(), std::strerror(errno));
}

void WriteExr(const std::string& tmp, const Image& image) {
    Imf::Header header(image.width, image.height);
    header.channels().insert("R", Imf::Channel(Imf::FLOAT));
    header.channels().insert("G", Imf::Channel(Imf::FLOAT));
    header.channels().insert("B", Imf::Channel(Imf::FLOAT));
    Imf::OutputFile file(tmp.c_str(), header);
    Imf::FrameBuffer fb;
    char* base = reinterpret_cast<char*>(const_cast<Color*>(image.pixels.data()));
    const size_t xs = sizeof(Color), ys = sizeof(Color) * image.width;
    fb.insert("R", Imf::Slice(Imf::FLOAT, base + offsetof(Color, r), xs, ys));
    fb.insert("G", Imf::Slice(Imf::FLOAT, base + offsetof(Color, g), xs, ys));
    fb.insert("B", Imf::Slice(Imf::FLOAT, base + offsetof(Color, b), xs, ys));
    file.setFrameBuffer(fb);
    file.writePixels(image.height);
}

Image ReadPng(const std::string& path) {
    int w = 0, h = 0, n = 0;
    unsigned char* data = stbi_load(path.c_str(), &w, &h, &n, 3);
    if (!data) ThrowError("%s: cannot read PNG: %s", path.c_str(), stbi_failure_reason());
    Image image(w, h);
    for (size_t i = 0; i < image.pixels.size(); ++i)
        image.pixels[i] = Color(DecodeSrgb8(data[3 * i]), DecodeSrgb8(data[3 * i + 1]),
                                DecodeSrgb8(data[3 * i + 2]));
    stbi_image_free(data);
    return image;
}

Image ReadExr(const std::string& path) {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i dw = file.header().dataWindow();
    const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
    if (w <= 0 || h <= 0 || static_cast<int64_t>(w) * h > (int64_t(1) << 28))
        ThrowError("%s: unsupported EXR size %dx%d", path.c_str(), w, h);
    Image image(w, h);
    Imf::FrameBuffer fb;
    char* base = reinterpret_cast<char*>(image.pixels.data()) -
                 (static_cast<ptrdiff_t>(dw.min.x) + static_cast<ptrdiff_t>(dw.min.y) * w) *
                     static_cast<ptrdiff_t>(sizeof(Color));
    const size_t xs = sizeof(Color), ys = sizeof(Color) * w;
    fb.insert("R", Imf::Slice(Imf::FLOAT, base + offsetof(Color, r), xs, ys));
    fb.insert("G", Imf::Slice(Imf::FLOAT, base + offsetof(Color, g), xs, ys));
    fb.insert("B", Imf::Slice(Imf::FLOAT, base + offsetof(Color, b), xs, ys));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    return image;
}

}  // namespace

void WriteImage(const std::string& path, const Image& image) {
    const ImageFormat format = ImageFormatFor(path);
    if (image.width <= 0 || image.height <= 0) ThrowError("%s: empty image", path.c_str());
    WriteFileAtomically(path, [&](const std::string& tmp) {
        try {
            if (format == ImageFormat::Png) WritePng(tmp, image);
            else WriteExr(tmp, image);
        } catch (const Error&) {
            throw;
        } catch (const std::exception& e) {
            ThrowError("%s: cannot write: %s", path.c_str(), e.what());
        }
    });
}

Image ReadImage(const std::string& path) {
    const ImageFormat format = ImageFormatFor(path);
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) ThrowError("%s: cannot open: %s", path.c_str(), std::strerror(errno));
    std::fclose(f);
    try {
        return format == ImageFormat::Png ? ReadPng(path) : ReadExr(path);
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        ThrowError("%s: cannot read EXR: %s", path.c_str(), e.what());
    }
}

}  // namespace lm
