#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <stdexcept>

#include <tbb/enumerable_thread_specific.h>
#include <zlib.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "lightmesh/io/image.h"
#include "lightmesh/io/image_decode.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/isolated_child.h"
#include "lightmesh/util/huge_pages.h"
#include "lightmesh/util/parallel.h"
#include "lightmesh/util/system.h"

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
    ThrowErrorAt({path}, "unknown image extension \"%s\" (use .png or .exr)", ext.c_str());
}

float SrgbEncode(float v) {
    if (!(v > 0)) return 0;  // also NaN
    if (v >= 1) return 1;
    return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

float SrgbDecode(float s) {
    if (!(s > 0)) return 0;
    if (s >= 1) return 1;
    return s <= 0.04045f ? s / 12.92f : std::pow((s + 0.055f) / 1.055f, 2.4f);
}

unsigned char EncodeSrgb8Reference(float v) {
    return static_cast<unsigned char>(std::lround(SrgbEncode(v) * 255.0f));  // NaN: 0
}

float DecodeSrgb8(unsigned char e) { return SrgbDecode(static_cast<float>(e) / 255.0f); }

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
        int k = 0;
        for (uint32_t b = 0; b < kBuckets; ++b) {
            const float first = BitsFloat((kFirstBucket + b) << 16);
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

// ---- PNG encoding: 8-bit RGB, Paeth-filtered, deflated by zlib in strips.
//
// The rows are cut into strips of a fixed number of rows (from the width only, never from
// the thread count, so the file is the same whatever the threads). Each strip is converted,
// filtered and deflated on its own, as raw deflate ending in a sync flush (a byte-aligned,
// non-final empty stored block; the last strip ends the stream instead), so the strips
// concatenate into one deflate stream. The zlib header goes before the first, and the
// Adler-32 of all filtered bytes (the strips' checksums combined) after the last.
// Each strip is one IDAT chunk.

// Measured on renders of builtin:gazebo (1024x768 and 3072x1536; rt, lmm and area shadows,
// anti-aliased) and on smooth and noisy synthetic images: Paeth with zlib's run-length
// strategy (matches at distance 1 only, the fastest zlib mode) gave files 10-20% smaller
// than stb_image_write's on the renders and was good on every kind of image. No filter at
// level 1 was about 20% faster and up to 9% smaller on the renders, but 50x larger on a
// smooth gradient; Up or Sub at level 1 were about as fast and 10-15% larger; Paeth at
// level 3 up to 5% smaller and 50% slower.
constexpr size_t kPngStripBytes = 256 * 1024;  // filtered bytes per strip, about
constexpr int kPngDeflateLevel = 1;             // any level > 0 is the same with Z_RLE
constexpr int kPngStrategy = Z_RLE;

void PutBe32(unsigned char* p, uint32_t v) {
    p[0] = static_cast<unsigned char>(v >> 24);
    p[1] = static_cast<unsigned char>(v >> 16);
    p[2] = static_cast<unsigned char>(v >> 8);
    p[3] = static_cast<unsigned char>(v);
}

// PNG's Paeth filter (type 4) on one row of n bytes, 3 per pixel, with `prev` the row above
// (zeros above the first): each byte minus the one of its left, upper and upper-left
// neighbours closest to left + upper - upper-left. In 16-bit integers, which the compiler
// vectorises 8 bytes at a time (twice as fast as with int).
void PaethFilterRow(const unsigned char* row, const unsigned char* prev, size_t n,
                    unsigned char* out) {
    out[0] = 4;
    ++out;
    for (size_t i = 0; i < 3 && i < n; ++i) out[i] = static_cast<unsigned char>(row[i] - prev[i]);
    for (size_t i = 3; i < n; ++i) {
        const int16_t a = row[i - 3], b = prev[i], c = prev[i - 3];
        // |p - a|, |p - b|, |p - c| for p = a + b - c.
        int16_t pa = static_cast<int16_t>(b - c), pb = static_cast<int16_t>(a - c);
        int16_t pc = static_cast<int16_t>(pa + pb);
        pa = pa < 0 ? static_cast<int16_t>(-pa) : pa;
        pb = pb < 0 ? static_cast<int16_t>(-pb) : pb;
        pc = pc < 0 ? static_cast<int16_t>(-pc) : pc;
        const int16_t pred = (pa <= pb && pa <= pc) ? a : (pb <= pc ? b : c);
        out[i] = static_cast<unsigned char>(row[i] - pred);
    }
}

struct PngStrip {
    std::vector<unsigned char> data;  // this strip's part of the zlib stream
    uLong adler = 1;                  // of its filtered bytes
    size_t filteredBytes = 0;
    uLong crc = 0;                    // of "IDAT" + data
};

// One worker thread's buffers and deflate state, reused from strip to strip.
class PngWorkspace {
  public:
    PngWorkspace() = default;
    PngWorkspace(const PngWorkspace&) = delete;
    PngWorkspace& operator=(const PngWorkspace&) = delete;
    ~PngWorkspace() {
        if (ready_) deflateEnd(&zs_);
    }

    // On huge pages (each is a strip's ~256 KiB, zero-filled by resize): 4 KiB pages cost
    // 200 page faults per thread, a few ms of a write.
    using Buffer = std::vector<unsigned char, HugePageAllocator<unsigned char>>;
    Buffer rgb, filtered;

    // Deflates n bytes (at most 1 GiB) as raw deflate, appending to `out`: a sync flush
    // at the end, or the end of the stream if `last`.
    void Deflate(const unsigned char* in, size_t n, bool last, std::vector<unsigned char>& out) {
        if (!ready_) {
            if (deflateInit2(&zs_, kPngDeflateLevel, Z_DEFLATED, -15, 8, kPngStrategy) != Z_OK)
                throw std::runtime_error("zlib: deflateInit2 failed");
            ready_ = true;
        } else if (deflateReset(&zs_) != Z_OK) {
            throw std::runtime_error("zlib: deflateReset failed");
        }
        deflated_.resize(deflateBound(&zs_, static_cast<uLong>(n)) + 64);
        zs_.next_in = const_cast<unsigned char*>(in);
        zs_.avail_in = static_cast<uInt>(n);
        const int flush = last ? Z_FINISH : Z_SYNC_FLUSH;
        size_t used = 0;
        for (;;) {
            zs_.next_out = deflated_.data() + used;
            zs_.avail_out = static_cast<uInt>(deflated_.size() - used);
            const int rc = deflate(&zs_, flush);
            if (rc != Z_OK && rc != Z_STREAM_END && rc != Z_BUF_ERROR)
                throw std::runtime_error("zlib: deflate failed");
            used = deflated_.size() - zs_.avail_out;
            // A sync flush is complete when deflate leaves output space unused.
            if (last ? rc == Z_STREAM_END : (zs_.avail_in == 0 && zs_.avail_out != 0)) break;
            if (zs_.avail_out != 0) throw std::runtime_error("zlib: deflate stopped early");
            deflated_.resize(deflated_.size() + deflated_.size() / 2 + 4096);  // more room
        }
        out.insert(out.end(), deflated_.data(), deflated_.data() + used);
    }

  private:
    Buffer deflated_;  // room for a strip's worst case
    z_stream zs_{};
    bool ready_ = false;
};

}  // namespace

unsigned char EncodeSrgb8(float v) { return Srgb8()(v); }

int PngStripRows(int width) {
    const size_t rowBytes = 1 + 3 * static_cast<size_t>(width);
    return static_cast<int>(std::max<size_t>(1, (kPngStripBytes + rowBytes - 1) / rowBytes));
}

std::vector<unsigned char> EncodePng(const Image& image) {
    static_assert(sizeof(Color) == 3 * sizeof(float), "a row of pixels is 3 * width floats");
    const int w = image.width, h = image.height;
    if (w <= 0 || h <= 0 || image.pixels.size() != static_cast<size_t>(w) * h)
        throw std::invalid_argument("EncodePng: bad image size");
    // A strip (one row at least) must fit zlib's 32-bit counts and a PNG chunk.
    if (static_cast<size_t>(w) > ((size_t(1) << 30) - 1) / 3)
        throw std::length_error("image too wide for PNG");
    const Srgb8Encoder& encode = Srgb8();
    const size_t rgbBytes = 3 * static_cast<size_t>(w), rowBytes = 1 + rgbBytes;
    const int stripRows = PngStripRows(w);
    const int strips = (h + stripRows - 1) / stripRows;
    std::vector<PngStrip> out(strips);
    tbb::enumerable_thread_specific<PngWorkspace> workspaces;
    ParallelFor(0, strips, [&](int s) {
        PngWorkspace& ws = workspaces.local();
        const int y0 = s * stripRows, y1 = std::min(h, y0 + stripRows);
        // Row y0 - 1 too (zeros above the image), which the filter predicts from.
        ws.rgb.resize(rgbBytes * (y1 - y0 + 1));
        if (y0 == 0) std::fill_n(ws.rgb.begin(), rgbBytes, 0);
        for (int y = std::max(0, y0 - 1); y < y1; ++y)
            encode(&image.pixels[static_cast<size_t>(y) * w].r, rgbBytes,
                   &ws.rgb[rgbBytes * (y - y0 + 1)]);
        ws.filtered.resize(rowBytes * (y1 - y0));
        for (int y = y0; y < y1; ++y)
            PaethFilterRow(&ws.rgb[rgbBytes * (y - y0 + 1)], &ws.rgb[rgbBytes * (y - y0)], rgbBytes,
                           &ws.filtered[rowBytes * (y - y0)]);
        PngStrip& strip = out[s];
        strip.filteredBytes = ws.filtered.size();
        strip.adler = adler32_z(1, ws.filtered.data(), ws.filtered.size());
        if (s == 0) strip.data = {0x78, 0x01};  // the zlib header: deflate, 32 KiB window
        ws.Deflate(ws.filtered.data(), ws.filtered.size(), s == strips - 1, strip.data);
        strip.crc = crc32_z(crc32(0, reinterpret_cast<const Bytef*>("IDAT"), 4), strip.data.data(),
                            strip.data.size());
    });

    uLong adler = 1;
    size_t total = 8 + 25 + 4 + 12;  // signature, IHDR, the Adler-32, IEND
    for (const PngStrip& strip : out) {
        adler = adler32_combine(adler, strip.adler, static_cast<z_off_t>(strip.filteredBytes));
        total += 12 + strip.data.size();
    }
    std::vector<unsigned char> png(total);
    unsigned char* p = png.data();
    auto chunk = [&](const char* type, const unsigned char* data, size_t n, uLong crc) {
        PutBe32(p, static_cast<uint32_t>(n));
        std::memcpy(p + 4, type, 4);
        if (n) std::memcpy(p + 8, data, n);
        PutBe32(p + 8 + n, static_cast<uint32_t>(crc));
        p += 12 + n;
    };
    static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    std::memcpy(p, kSignature, 8);
    p += 8;
    unsigned char ihdr[13];
    PutBe32(ihdr, static_cast<uint32_t>(w));
    PutBe32(ihdr + 4, static_cast<uint32_t>(h));
    ihdr[8] = 8;   // bits per channel
    ihdr[9] = 2;   // colour type: RGB
    ihdr[10] = 0;  // deflate
    ihdr[11] = 0;  // adaptive filtering (one filter type per row)
    ihdr[12] = 0;  // not interlaced
    chunk("IHDR", ihdr, 13, crc32(crc32(0, reinterpret_cast<const Bytef*>("IHDR"), 4), ihdr, 13));
    unsigned char adlerBytes[4];
    PutBe32(adlerBytes, static_cast<uint32_t>(adler));
    for (int s = 0; s < strips; ++s) {
        PngStrip& strip = out[s];
        if (s == strips - 1) {  // the stream's checksum ends the last IDAT
            strip.data.insert(strip.data.end(), adlerBytes, adlerBytes + 4);
            strip.crc = crc32(strip.crc, adlerBytes, 4);
        }
        chunk("IDAT", strip.data.data(), strip.data.size(), strip.crc);
    }
    chunk("IEND", nullptr, 0, crc32(0, reinterpret_cast<const Bytef*>("IEND"), 4));
    png.resize(static_cast<size_t>(p - png.data()));
    return png;
}

namespace {

void WritePng(const std::string& tmp, const Image& image) {
    const std::vector<unsigned char> bytes = EncodePng(image);
    std::ofstream out(tmp, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) ThrowErrorAt({tmp}, "write failed: %s", std::strerror(errno));
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
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) ThrowErrorAt({path}, "cannot open: %s", std::strerror(errno));
    const auto end = in.tellg();
    std::string bytes(end > 0 ? static_cast<size_t>(end) : 0, '\0');
    in.seekg(0);
    in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (in.bad() || static_cast<size_t>(in.gcount()) != bytes.size()) ThrowErrorAt({path}, "cannot read it");
    DecodedPixels p;
    try {
        // libpng; 16-bit PNGs at their depth (two that differ in every sample's
        // low byte would compare as identical if read at 8 bits).
        p = DecodePng(bytes.data(), bytes.size(), 3, INT32_MAX);
    } catch (const Error& e) {
        ThrowErrorAt({path}, "cannot read PNG: %s", e.what());
    }
    bytes = std::string();
    Image image(p.width, p.height);
    if (p.bits == 16) {
        auto decode = [](uint16_t v) { return SrgbDecode(static_cast<float>(v) / 65535.0f); };
        const uint16_t* d = p.rgba16.data();
        for (size_t i = 0; i < image.pixels.size(); ++i)
            image.pixels[i] = Color(decode(d[3 * i]), decode(d[3 * i + 1]), decode(d[3 * i + 2]));
        return image;
    }
    const uint8_t* d = p.rgba8.data();
    for (size_t i = 0; i < image.pixels.size(); ++i)
        image.pixels[i] = Color(DecodeSrgb8(d[3 * i]), DecodeSrgb8(d[3 * i + 1]), DecodeSrgb8(d[3 * i + 2]));
    return image;
}

/// The EXR channels to read as R, G and B: "R", "G", "B", or lower-case "r", "g", "b" (all
/// three of one kind), or a luminance-only "Y" (or "y") read into all three as grey. Any
/// other layout is refused by name, not read as black.
/// A luminance-chroma file (Y with RY, BY) is refused too: its chroma is subsampled.
std::array<std::string, 3> ExrChannels(const std::string& path, const Imf::ChannelList& channels) {
    std::vector<std::string> names;
    for (auto it = channels.begin(); it != channels.end(); ++it) names.push_back(it.name());
    auto has = [&](const char* name) { return channels.findChannel(name) != nullptr; };
    auto list = [&] {
        std::string s;
        for (size_t i = 0; i < names.size() && i < 12; ++i) s += (i ? ", " : "") + names[i];
        if (names.size() > 12) s += StringPrintf(" and %zu more", names.size() - 12);
        return s.empty() ? std::string("none") : s;
    };
    for (const char* set : {"RGB", "rgb"}) {
        const std::string r(1, set[0]), g(1, set[1]), b(1, set[2]);
        const int found = has(r.c_str()) + has(g.c_str()) + has(b.c_str());
        if (found == 3) return {r, g, b};
        if (found > 0)
            ThrowErrorAt({path}, "EXR has only some of the channels %s, %s, %s (its channels: %s)", r.c_str(),
                         g.c_str(), b.c_str(), list().c_str());
    }
    for (const char* y : {"Y", "y"}) {
        if (!has(y)) continue;
        if (has("RY") || has("BY") || has("ry") || has("by"))
            ThrowErrorAt({path}, "EXR is luminance-chroma (Y, RY, BY), which compare does not read; convert it to "
                         "R, G, B (its channels: %s)", list().c_str());
        return {y, y, y};
    }
    ThrowErrorAt({path}, "EXR has no R, G, B (or r, g, b) and no Y channel to read (its channels: %s)",
                 list().c_str());
}

Image ReadExr(const std::string& path, const ImageSize& head) {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i dw = file.header().dataWindow();
    const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
    if (w != head.width || h != head.height)  // the memory was judged by the head's size
        ThrowErrorAt({path}, "EXR whose dataWindow is %dx%d after its head said %dx%d", w, h, head.width, head.height);
    const std::array<std::string, 3> names = ExrChannels(path, file.header().channels());
    Image image(w, h);
    Imf::FrameBuffer fb;
    char* base = reinterpret_cast<char*>(image.pixels.data()) -
                 (static_cast<ptrdiff_t>(dw.min.x) + static_cast<ptrdiff_t>(dw.min.y) * w) *
                     static_cast<ptrdiff_t>(sizeof(Color));
    const size_t xs = sizeof(Color), ys = sizeof(Color) * w;
    fb.insert(names[0], Imf::Slice(Imf::FLOAT, base + offsetof(Color, r), xs, ys));
    if (names[1] != names[0]) {
        fb.insert(names[1], Imf::Slice(Imf::FLOAT, base + offsetof(Color, g), xs, ys));
        fb.insert(names[2], Imf::Slice(Imf::FLOAT, base + offsetof(Color, b), xs, ys));
    }
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    if (names[1] == names[0])  // grey: Y into G and B too
        for (Color& c : image.pixels) c.g = c.b = c.r;
    return image;
}

}  // namespace

void WriteImage(const std::string& path, const Image& image) {
    const ImageFormat format = ImageFormatFor(path);
    if (image.width <= 0 || image.height <= 0) ThrowErrorAt({path}, "empty image");
    WriteFileAtomically(path, [&](const std::string& tmp) {
        try {
            if (format == ImageFormat::Png) WritePng(tmp, image);
            else WriteExr(tmp, image);
        } catch (const Error&) {
            throw;
        } catch (const std::exception& e) {
            ThrowErrorAt({path}, "cannot write: %s", e.what());
        }
    });
}

ImageSize ReadImageSize(const std::string& path) {
    const ImageFormat format = ImageFormatFor(path);
    CheckRegularFile(path, "image");  // never blocks on a FIFO
    std::ifstream in(path, std::ios::binary);
    if (!in) ThrowErrorAt({path}, "cannot open: %s", std::strerror(errno));
    auto u32 = [](const unsigned char* p, bool bigEndian) {
        return bigEndian ? uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3]
                         : uint32_t(p[3]) << 24 | uint32_t(p[2]) << 16 | uint32_t(p[1]) << 8 | p[0];
    };
    unsigned char head[24] = {};
    in.read(reinterpret_cast<char*>(head), sizeof head);
    if (format == ImageFormat::Png) {
        // Signature, then the IHDR chunk: length, "IHDR", width, height (big-endian).
        static const unsigned char kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
        if (in.gcount() < 24 || std::memcmp(head, kSignature, 8) != 0 || std::memcmp(head + 12, "IHDR", 4) != 0)
            ThrowErrorAt({path}, "not a PNG file (no PNG signature and IHDR chunk at its start)");
        const uint32_t w = u32(head + 16, true), h = u32(head + 20, true);
        if (w < 1 || h < 1 || w > INT32_MAX || h > INT32_MAX) ThrowErrorAt({path}, "PNG of size %ux%u", w, h);
        return {static_cast<int>(w), static_cast<int>(h)};
    }
    // EXR: magic, version, then attributes (name, type, size, value) up to an empty name.
    if (in.gcount() < 8 || u32(head, false) != 20000630u) ThrowErrorAt({path}, "not an OpenEXR file (no EXR magic number)");
    in.seekg(8);
    auto text = [&](std::string* out) {
        out->clear();
        for (int c; (c = in.get()) != EOF;) {
            if (c == 0) return true;
            if (out->size() >= 255) return false;
            *out += static_cast<char>(c);
        }
        return false;
    };
    for (int attributes = 0; attributes < 4096; ++attributes) {
        std::string name, type;
        if (!text(&name)) break;
        if (name.empty()) break;  // the header's end: no dataWindow
        unsigned char size[4];
        if (!text(&type) || !in.read(reinterpret_cast<char*>(size), 4)) break;
        const uint32_t bytes = u32(size, false);
        if (name == "dataWindow" && type == "box2i" && bytes == 16) {
            unsigned char box[16];
            if (!in.read(reinterpret_cast<char*>(box), 16)) break;
            const int64_t w = int64_t(int32_t(u32(box + 8, false))) - int32_t(u32(box, false)) + 1;
            const int64_t h = int64_t(int32_t(u32(box + 12, false))) - int32_t(u32(box + 4, false)) + 1;
            if (w < 1 || h < 1 || w > INT32_MAX || h > INT32_MAX)
                ThrowErrorAt({path}, "EXR of size %lldx%lld", static_cast<long long>(w), static_cast<long long>(h));
            return {static_cast<int>(w), static_cast<int>(h)};
        }
        in.seekg(bytes, std::ios::cur);
    }
    ThrowErrorAt({path}, "cannot read EXR: its header has no dataWindow or is cut short");
}

uint64_t ImageReadBytes(const ImageSize& size) {
    return static_cast<uint64_t>(size.width) * static_cast<uint64_t>(size.height) * (sizeof(Color) + 6);
}

Image ReadImage(const std::string& path) {
    const ImageFormat format = ImageFormatFor(path);
    CheckRegularFile(path, "image");  // never blocks on a FIFO
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) ThrowErrorAt({path}, "cannot open: %s", std::strerror(errno));
    std::fclose(f);
    // What reading it takes, from its head (a PNG's IHDR, an EXR's dataWindow), before the
    // decoder sees it: an EXR of 2^28 pixels was decoded into 3 GiB first.
    const ImageSize head = ReadImageSize(path);
    const uint64_t pixels = static_cast<uint64_t>(head.width) * static_cast<uint64_t>(head.height);
    const uint64_t need = ImageReadBytes(head), budget = PhysicalMemoryBytes();
    if (budget && need > budget / 2)
        ThrowErrorAt({path}, "%s of %dx%d pixels: reading it takes about %s (%zu B a pixel), more than half of the "
                     "%s this process may use (LIGHTMESH_MEMORY_LIMIT)",
                     format == ImageFormat::Png ? "a PNG" : "an EXR", head.width, head.height, FormatBytes(need).c_str(),
                     sizeof(Color) + 6, FormatBytes(budget).c_str());
    if (pixels > (uint64_t(1) << 28))
        ThrowErrorAt({path}, "%s of %dx%d pixels, more than the 2^28 (268,435,456) an image read may have",
                     format == ImageFormat::Png ? "a PNG" : "an EXR", head.width, head.height);
    try {
        return format == ImageFormat::Png ? ReadPng(path) : ReadExr(path, head);
    } catch (const Error&) {
        throw;
    } catch (const std::bad_alloc&) {
        ThrowErrorAt({path}, "reading it needs more memory than this process may use");
    } catch (const std::exception& e) {
        // (A PNG's failure was worded "cannot read EXR: std::bad_alloc".)
        ThrowErrorAt({path}, "cannot read %s: %s", format == ImageFormat::Png ? "PNG" : "EXR", e.what());
    }
}

namespace {

enum : uint8_t { kImage = 1, kError = 2 };

// An image's fields, in the order the reading child writes them and the parent reads them
// (ChildFieldWriter): listed once, for both directions. I is Image, or const Image to
// write it. The pixels go without a length: width × height of them.
template <typename Archive, typename I>
void ImageFields(Archive& a, I& image) {
    a(image.width, image.height);
    a.Require(image.width > 0 && image.height > 0 && static_cast<int64_t>(image.width) * image.height <= (int64_t(1) << 28),
              "bad size");
    a.Array(image.pixels, static_cast<size_t>(image.width) * static_cast<size_t>(image.height));
}

/// The reading child's record: kImage and the image, or kError and why it cannot be read.
void WriteImageRecord(int fd, const std::string& path) {
    ChildWriter w;
    Image image;
    const auto failed = [&](const std::string& why) {
        w = ChildWriter();
        w.Pod<uint8_t>(kError);
        w.Str(why);
    };
    try {
        image = ReadImage(path);
        w.Pod<uint8_t>(kImage);
        ChildFieldWriter fields(&w);
        ImageFields(fields, image);
    } catch (const Error& e) {
        failed(e.what());
    } catch (const std::bad_alloc&) {
        failed(path + ": reading it needs more memory than this process may use");
    }
    if (!w.WriteTo(fd)) _exit(3);
}

/// The image of the record WriteImageRecord wrote; throws Error with the child's reason, or
/// std::runtime_error on a record cut short or malformed.
Image ReadImageRecord(std::string_view bytes) {
    ChildReader r(bytes);
    const uint8_t kind = r.Pod<uint8_t>();
    if (kind == kError) throw Error(r.Str());
    if (kind != kImage) throw std::runtime_error("bad result");
    Image image;
    ChildFieldReader fields(&r);
    ImageFields(fields, image);
    return image;
}

}  // namespace

Image ReadImageIsolated(const std::string& path) {
    ImageFormatFor(path);
    CheckRegularFile(path, "image");  // never blocks on a FIFO
    if (const char* v = std::getenv("LIGHTMESH_IMPORT_IN_PROCESS"); v && *v && std::string(v) != "0")
        return ReadImage(path);
    struct stat st {};
    const ChildLimits limits{PhysicalMemoryBytes() / 2,
                             ChildDeadlineSeconds(stat(path.c_str(), &st) == 0 ? static_cast<uint64_t>(st.st_size) : 0)};
    const ChildOutcome child = RunInChild("lightmesh-image", limits, [&](int fd) { WriteImageRecord(fd, path); });
    switch (child.end) {
        case ChildOutcome::End::NotStarted: return ReadImage(path);
        case ChildOutcome::End::TimedOut:
            ThrowErrorAt({path}, "the image reader did not finish within %.0f s and was stopped", child.seconds);
        case ChildOutcome::End::Signalled:
            ThrowErrorAt({path}, "the image reader crashed on it (signal %d, %s)%s", child.code,
                         SignalName(child.code).c_str(), child.Said().c_str());
        case ChildOutcome::End::Exited: break;
    }
    try {
        return ReadImageRecord(child.Bytes());
    } catch (const Error&) {
        throw;
    } catch (const std::exception&) {
        ThrowErrorAt({path}, "the image reader crashed on it (exit status %d)", child.code);
    }
}

}  // namespace lm
