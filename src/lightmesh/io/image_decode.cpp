// image_decode.cpp -- PNG by libpng, JPEG by libjpeg-turbo, their errors as Errors.
//
// Both libraries report errors through a callback that must not return: libpng's through
// png_error's longjmp to png_jmpbuf, libjpeg's through error_exit, which jumps back here
// too. Everything those jumps cross is plain C data: the C++ objects of each decoder are
// made before its setjmp and live on after it, so no destructor is skipped; the decoders'
// own structures are freed by a guard that outlives the jump. Warnings are kept from
// stderr (a JPEG whose data ends early is an error, not an image padded with grey).
#include "lightmesh/io/image_decode.h"

#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <new>

#include <jerror.h>
#include <jpeglib.h>
#include <png.h>

#include "lightmesh/util/error.h"

namespace lm {
namespace {

uint32_t Be32(const uint8_t* p) { return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3]; }

const uint8_t kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

void CheckSide(const char* what, uint32_t w, uint32_t h, int maxSide) {
    if (w < 1 || h < 1) ThrowError("a %s of %u x %u pixels", what, w, h);
    if (w > static_cast<uint32_t>(maxSide) || h > static_cast<uint32_t>(maxSide))
        ThrowError("the image is %u x %u, more than the %d a side it may have", w, h, maxSide);
}

// --- PNG ---------------------------------------------------------------------------------

struct PngSource {
    const uint8_t* data;
    size_t size, pos = 0;
    bool cutShort = false;
    char message[200] = "";
};

void PngFail(png_structp png, png_const_charp message) {
    auto* s = static_cast<PngSource*>(png_get_error_ptr(png));
    std::snprintf(s->message, sizeof s->message, "%s", message ? message : "unknown error");
    png_longjmp(png, 1);
}

void PngWarn(png_structp, png_const_charp) {}  // ancillary chunks' complaints: not the user's concern

void PngRead(png_structp png, png_bytep out, size_t n) {
    auto* s = static_cast<PngSource*>(png_get_io_ptr(png));
    if (n > s->size - s->pos) {
        s->cutShort = true;
        png_error(png, "the data ends early");
    }
    std::memcpy(out, s->data + s->pos, n);
    s->pos += n;
}

struct PngGuard {
    png_structp png = nullptr;
    png_infop info = nullptr;
    ~PngGuard() {
        if (png) png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
    }
};

// --- JPEG --------------------------------------------------------------------------------

struct JpegErrors {
    jpeg_error_mgr mgr;
    std::jmp_buf jump;
    bool cutShort = false, outOfMemory = false;
    char message[JMSG_LENGTH_MAX] = "";
};

[[noreturn]] void JpegFail(j_common_ptr c) {
    auto* e = reinterpret_cast<JpegErrors*>(c->err);
    e->outOfMemory = c->err->msg_code == JERR_OUT_OF_MEMORY;
    c->err->format_message(c, e->message);
    std::longjmp(e->jump, 1);
}

// Warnings go nowhere, but data that ends before the image does is an error: libjpeg pads
// such a file with grey and calls it a warning.
void JpegEmit(j_common_ptr c, int level) {
    if (level >= 0) return;  // trace messages
    if (c->err->msg_code == JWRN_JPEG_EOF) {
        reinterpret_cast<JpegErrors*>(c->err)->cutShort = true;
        JpegFail(c);
    }
    c->err->num_warnings++;
}

void JpegQuiet(j_common_ptr) {}

constexpr int kMaxJpegScans = 1000;

// A progressive JPEG of many tiny scans costs time for nothing (libjpeg-turbo's own
// tools stop at 500); the progress monitor is called as each is read.
void JpegProgress(j_common_ptr c) {
    if (!c->is_decompressor) return;
    const auto* d = reinterpret_cast<j_decompress_ptr>(c);
    if (d->input_scan_number > kMaxJpegScans) {
        auto* e = reinterpret_cast<JpegErrors*>(c->err);
        std::snprintf(e->message, sizeof e->message, "more than %d scans", kMaxJpegScans);
        std::longjmp(e->jump, 1);
    }
}

struct JpegGuard {
    jpeg_decompress_struct* info = nullptr;
    ~JpegGuard() {
        if (info) jpeg_destroy_decompress(info);
    }
};

// stb_image's CMYK conversion: x * y / 255, rounded.
uint8_t Blinn(unsigned x, unsigned y) {
    const unsigned t = x * y + 128;
    return static_cast<uint8_t>((t + (t >> 8)) >> 8);
}

}  // namespace

CodedImageKind CodedImageKindOf(const void* data, size_t size) {
    const auto* p = static_cast<const uint8_t*>(data);
    if (size >= 8 && std::memcmp(p, kPngSignature, 8) == 0) return CodedImageKind::Png;
    if (size >= 3 && p[0] == 0xff && p[1] == 0xd8 && p[2] == 0xff) return CodedImageKind::Jpeg;
    return CodedImageKind::Other;
}

bool CodedImageHeadSize(const void* data, size_t size, int* width, int* height) {
    const auto* p = static_cast<const uint8_t*>(data);
    uint32_t w = 0, h = 0;
    switch (CodedImageKindOf(data, size)) {
        case CodedImageKind::Png:
            // Signature, then the IHDR chunk: length, "IHDR", width, height (big-endian).
            if (size < 24 || std::memcmp(p + 12, "IHDR", 4) != 0) return false;
            w = Be32(p + 16), h = Be32(p + 20);
            break;
        case CodedImageKind::Jpeg: {
            // Segments after SOI (FF D8): FF, a marker, a big-endian length that counts
            // itself, up to a frame header (SOF0-15 but DHT C4, JPG C8, DAC CC): length,
            // precision, height, width.
            size_t i = 2;
            for (;;) {
                while (i < size && p[i] == 0xff) ++i;  // fill bytes, and the marker's FF
                if (i + 1 > size) return false;
                const uint8_t marker = p[i++];
                if (marker == 0xd8 || marker == 0x01 || (marker >= 0xd0 && marker <= 0xd7)) continue;  // no length
                if (marker == 0xd9 || marker == 0xda || i + 2 > size) return false;  // EOI or a scan first
                const size_t length = size_t(p[i]) << 8 | p[i + 1];
                if (length < 2) return false;
                if (marker >= 0xc0 && marker <= 0xcf && marker != 0xc4 && marker != 0xc8 && marker != 0xcc) {
                    if (length < 7 || i + 7 > size) return false;
                    h = uint32_t(p[i + 3]) << 8 | p[i + 4];
                    w = uint32_t(p[i + 5]) << 8 | p[i + 6];
                    if (h == 0) return false;  // given later, by a DNL segment
                    break;
                }
                i += length;
            }
            break;
        }
        case CodedImageKind::Other: return false;
    }
    if (w < 1 || h < 1 || w > INT32_MAX || h > INT32_MAX) return false;
    *width = static_cast<int>(w), *height = static_cast<int>(h);
    return true;
}

DecodedPixels DecodePng(const void* data, size_t size, int channels, int maxSide) {
    PngSource source{static_cast<const uint8_t*>(data), size};
    DecodedPixels out;
    std::vector<png_bytep> rows;
    bool tooLarge = false;
    png_uint_32 w = 0, h = 0;
    PngGuard guard;
    guard.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &source, PngFail, PngWarn);
    if (!guard.png) throw std::bad_alloc();
    guard.info = png_create_info_struct(guard.png);
    if (!guard.info) throw std::bad_alloc();
    if (setjmp(png_jmpbuf(guard.png))) {
        if (source.cutShort) ThrowError("the PNG is cut short: its data ends before the image does");
        if (std::strstr(source.message, "Out of memory") || std::strstr(source.message, "out of memory"))
            throw std::bad_alloc();
        ThrowError("the PNG is corrupt (libpng: %s)", source.message);
    }
    png_set_read_fn(guard.png, &source, PngRead);
    png_set_user_limits(guard.png, 0x7fffffff, 0x7fffffff);  // maxSide is checked below, in our words
    png_read_info(guard.png, guard.info);
    int depth = 0, colour = 0, interlace = 0;
    png_get_IHDR(guard.png, guard.info, &w, &h, &depth, &colour, &interlace, nullptr, nullptr);
    if (w < 1 || h < 1 || w > static_cast<png_uint_32>(maxSide) || h > static_cast<png_uint_32>(maxSide)) {
        tooLarge = true;  // thrown below, after the guard has freed libpng's structures
    } else {
        png_set_expand(guard.png);  // palette to RGB, grey of 1-4 bits to 8, tRNS to alpha
        if (depth == 16) png_set_swap(guard.png);  // host order (PNG's is big-endian)
        if (!(colour & PNG_COLOR_MASK_COLOR)) png_set_gray_to_rgb(guard.png);
        const bool alpha = (colour & PNG_COLOR_MASK_ALPHA) || png_get_valid(guard.png, guard.info, PNG_INFO_tRNS);
        if (channels == 4 && !alpha) png_set_add_alpha(guard.png, depth == 16 ? 0xffff : 0xff, PNG_FILLER_AFTER);
        if (channels == 3 && alpha) png_set_strip_alpha(guard.png);
        png_set_interlace_handling(guard.png);
        png_read_update_info(guard.png, guard.info);
        out.width = static_cast<int>(w), out.height = static_cast<int>(h);
        out.channels = channels;
        out.bits = depth == 16 ? 16 : 8;
        const size_t rowSamples = static_cast<size_t>(w) * static_cast<size_t>(channels);
        if (png_get_rowbytes(guard.png, guard.info) != rowSamples * static_cast<size_t>(out.bits / 8))
            png_error(guard.png, "unexpected row size after the transformations");
        rows.resize(h);
        if (out.bits == 16) {
            out.rgba16.resize(rowSamples * h);
            for (png_uint_32 y = 0; y < h; ++y) rows[y] = reinterpret_cast<png_bytep>(out.rgba16.data() + rowSamples * y);
        } else {
            out.rgba8.resize(rowSamples * h);
            for (png_uint_32 y = 0; y < h; ++y) rows[y] = out.rgba8.data() + rowSamples * y;
        }
        png_read_image(guard.png, rows.data());
    }
    if (tooLarge) CheckSide("PNG", w, h, maxSide);
    return out;
}

DecodedPixels DecodeJpeg(const void* data, size_t size, int channels, int maxSide) {
    jpeg_decompress_struct info;
    JpegErrors errors;
    jpeg_progress_mgr progress{};
    DecodedPixels out;
    std::vector<uint8_t> row;
    JpegGuard guard;
    info.err = jpeg_std_error(&errors.mgr);
    errors.mgr.error_exit = JpegFail;
    errors.mgr.emit_message = JpegEmit;
    errors.mgr.output_message = JpegQuiet;
    if (setjmp(errors.jump)) {
        if (errors.outOfMemory) throw std::bad_alloc();
        if (errors.cutShort) ThrowError("the JPEG is cut short: its data ends before the image does");
        ThrowError("the JPEG is corrupt (libjpeg: %s)", errors.message);
    }
    jpeg_create_decompress(&info);
    guard.info = &info;
    progress.progress_monitor = JpegProgress;
    info.progress = &progress;
    jpeg_mem_src(&info, static_cast<const unsigned char*>(data), static_cast<unsigned long>(size));
    if (jpeg_read_header(&info, TRUE) != JPEG_HEADER_OK) {
        std::snprintf(errors.message, sizeof errors.message, "it holds tables but no image");
        std::longjmp(errors.jump, 1);
    }
    const uint32_t w = info.image_width, h = info.image_height;
    if (w < 1 || h < 1 || w > static_cast<uint32_t>(maxSide) || h > static_cast<uint32_t>(maxSide)) {
        guard.info = nullptr;
        jpeg_destroy_decompress(&info);
        CheckSide("JPEG", w, h, maxSide);
    }
    switch (info.jpeg_color_space) {
        case JCS_GRAYSCALE: info.out_color_space = JCS_GRAYSCALE; break;
        case JCS_CMYK:
        case JCS_YCCK: info.out_color_space = JCS_CMYK; break;
        default: info.out_color_space = JCS_RGB; break;
    }
    jpeg_start_decompress(&info);
    const int in = info.output_components;
    if ((in != 1 && in != 3 && in != 4) || info.output_width != w || info.output_height != h) {
        std::snprintf(errors.message, sizeof errors.message, "unexpected output of %d components", in);
        std::longjmp(errors.jump, 1);
    }
    out.width = static_cast<int>(w), out.height = static_cast<int>(h);
    out.channels = channels, out.bits = 8;
    out.rgba8.resize(static_cast<size_t>(w) * h * static_cast<size_t>(channels));
    row.resize(static_cast<size_t>(w) * static_cast<size_t>(in));
    while (info.output_scanline < h) {
        JSAMPROW line = row.data();
        const JDIMENSION y = info.output_scanline;
        if (jpeg_read_scanlines(&info, &line, 1) != 1) {
            std::snprintf(errors.message, sizeof errors.message, "no scanline %u", y);
            std::longjmp(errors.jump, 1);
        }
        uint8_t* o = out.rgba8.data() + static_cast<size_t>(y) * w * static_cast<size_t>(channels);
        for (uint32_t x = 0; x < w; ++x, o += channels) {
            const uint8_t* s = row.data() + static_cast<size_t>(x) * static_cast<size_t>(in);
            if (in == 1) o[0] = o[1] = o[2] = s[0];
            else if (in == 3) o[0] = s[0], o[1] = s[1], o[2] = s[2];
            else o[0] = Blinn(s[0], s[3]), o[1] = Blinn(s[1], s[3]), o[2] = Blinn(s[2], s[3]);  // Adobe's inverted CMYK
            if (channels == 4) o[3] = 255;
        }
    }
    // Not jpeg_finish_decompress: what follows the image (up to EOI) is not needed.
    return out;
}

}  // namespace lm
