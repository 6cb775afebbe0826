// image_decode_test.cpp -- PNG (libpng) and JPEG (libjpeg-turbo) decoding: the pixels of
// every kind of file, and one Error, never a crash or a word on stderr, for broken ones.
#include "lightmesh/io/image_decode.h"

#include <gtest/gtest.h>

#include <jpeglib.h>
#include <png.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "lightmesh/util/error.h"

namespace lm {
namespace image_decode_test {
namespace {

void Append(png_structp png, png_bytep data, size_t n) {
    static_cast<std::string*>(png_get_io_ptr(png))->append(reinterpret_cast<const char*>(data), n);
}

/// A PNG of w x h pixels written by libpng: `rows` hold each row as the format stores it
/// (samples packed, 16-bit ones big-endian).
struct PngSpec {
    int w = 2, h = 2, depth = 8, colour = PNG_COLOR_TYPE_RGB;
    bool interlaced = false;
    std::vector<std::vector<uint8_t>> rows;
    std::vector<png_color> palette;
    std::vector<uint8_t> paletteAlpha;  // tRNS of a palette image
};

std::string WritePng(const PngSpec& spec) {
    std::string out;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        ADD_FAILURE() << "libpng could not write the test image";
        return {};
    }
    png_set_write_fn(png, &out, Append, nullptr);
    png_set_IHDR(png, info, static_cast<png_uint_32>(spec.w), static_cast<png_uint_32>(spec.h), spec.depth,
                 spec.colour, spec.interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    if (!spec.palette.empty()) png_set_PLTE(png, info, spec.palette.data(), static_cast<int>(spec.palette.size()));
    if (!spec.paletteAlpha.empty())
        png_set_tRNS(png, info, spec.paletteAlpha.data(), static_cast<int>(spec.paletteAlpha.size()), nullptr);
    png_write_info(png, info);
    std::vector<png_bytep> rows;
    for (const auto& r : spec.rows) rows.push_back(const_cast<png_bytep>(r.data()));
    png_write_image(png, rows.data());
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    return out;
}

DecodedPixels Png(const std::string& bytes, int channels = 4) {
    return DecodePng(bytes.data(), bytes.size(), channels, 8192);
}

TEST(ImageDecode, PngOfEveryColourTypeAndDepth) {
    // RGB, 8 bits: alpha 255 added.
    {
        PngSpec s;
        s.rows = {{255, 0, 0, 0, 255, 0}, {0, 0, 255, 10, 20, 30}};
        const DecodedPixels p = Png(WritePng(s));
        ASSERT_EQ(p.width, 2);
        ASSERT_EQ(p.height, 2);
        EXPECT_EQ(p.bits, 8);
        EXPECT_EQ(p.rgba8, (std::vector<uint8_t>{255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 10, 20, 30, 255}));
        EXPECT_EQ(Png(WritePng(s), 3).rgba8, (std::vector<uint8_t>{255, 0, 0, 0, 255, 0, 0, 0, 255, 10, 20, 30}));
    }
    // RGBA, 8 bits: alpha kept (and dropped for 3 channels).
    {
        PngSpec s;
        s.colour = PNG_COLOR_TYPE_RGBA;
        s.rows = {{1, 2, 3, 0, 4, 5, 6, 128}, {7, 8, 9, 255, 10, 11, 12, 1}};
        EXPECT_EQ(Png(WritePng(s)).rgba8, (std::vector<uint8_t>{1, 2, 3, 0, 4, 5, 6, 128, 7, 8, 9, 255, 10, 11, 12, 1}));
        EXPECT_EQ(Png(WritePng(s), 3).rgba8, (std::vector<uint8_t>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12}));
    }
    // Grey, 8 bits, and grey with alpha: grey replicated.
    {
        PngSpec s;
        s.colour = PNG_COLOR_TYPE_GRAY;
        s.rows = {{0, 100}, {200, 255}};
        EXPECT_EQ(Png(WritePng(s)).rgba8, (std::vector<uint8_t>{0, 0, 0, 255, 100, 100, 100, 255, 200, 200, 200, 255,
                                                                255, 255, 255, 255}));
        s.colour = PNG_COLOR_TYPE_GRAY_ALPHA;
        s.rows = {{0, 10, 100, 20}, {200, 30, 255, 40}};
        EXPECT_EQ(Png(WritePng(s)).rgba8, (std::vector<uint8_t>{0, 0, 0, 10, 100, 100, 100, 20, 200, 200, 200, 30,
                                                                255, 255, 255, 40}));
    }
    // Grey of 1 bit a pixel: 0 and 1 are black and white.
    {
        PngSpec s;
        s.colour = PNG_COLOR_TYPE_GRAY;
        s.depth = 1;
        s.rows = {{0x80}, {0x40}};  // row 0: 1, 0; row 1: 0, 1
        EXPECT_EQ(Png(WritePng(s)).rgba8, (std::vector<uint8_t>{255, 255, 255, 255, 0, 0, 0, 255, 0, 0, 0, 255,
                                                                255, 255, 255, 255}));
    }
    // A palette of 4 bits with a tRNS chunk: colours looked up, tRNS as alpha.
    {
        PngSpec s;
        s.colour = PNG_COLOR_TYPE_PALETTE;
        s.depth = 4;
        s.palette = {{255, 0, 0}, {0, 255, 0}, {0, 0, 255}};
        s.paletteAlpha = {0, 128};  // index 2 has none: opaque
        s.rows = {{0x01}, {0x20}};   // row 0: 0, 1; row 1: 2, 0
        EXPECT_EQ(Png(WritePng(s)).rgba8, (std::vector<uint8_t>{255, 0, 0, 0, 0, 255, 0, 128, 0, 0, 255, 255,
                                                                255, 0, 0, 0}));
    }
    // RGB and RGBA of 16 bits: samples in host order, alpha 65535 added.
    {
        PngSpec s;
        s.depth = 16;
        s.w = 1, s.h = 1;
        s.rows = {{0x12, 0x34, 0xab, 0xcd, 0x00, 0x01}};
        const DecodedPixels p = Png(WritePng(s));
        EXPECT_EQ(p.bits, 16);
        EXPECT_EQ(p.rgba16, (std::vector<uint16_t>{0x1234, 0xabcd, 0x0001, 0xffff}));
        EXPECT_EQ(Png(WritePng(s), 3).rgba16, (std::vector<uint16_t>{0x1234, 0xabcd, 0x0001}));
        s.colour = PNG_COLOR_TYPE_RGBA;
        s.rows = {{0x12, 0x34, 0xab, 0xcd, 0x00, 0x01, 0x80, 0x00}};
        EXPECT_EQ(Png(WritePng(s)).rgba16, (std::vector<uint16_t>{0x1234, 0xabcd, 0x0001, 0x8000}));
        s.colour = PNG_COLOR_TYPE_GRAY;
        s.rows = {{0xfe, 0xdc}};
        EXPECT_EQ(Png(WritePng(s)).rgba16, (std::vector<uint16_t>{0xfedc, 0xfedc, 0xfedc, 0xffff}));
    }
}

TEST(ImageDecode, InterlacedPngGivesThePlainImage) {
    PngSpec s;
    s.w = 13, s.h = 11;
    for (int y = 0; y < s.h; ++y) {
        s.rows.emplace_back();
        for (int x = 0; x < s.w; ++x)
            s.rows.back().insert(s.rows.back().end(), {uint8_t(x * 19), uint8_t(y * 23), uint8_t(x * y)});
    }
    const std::string plain = WritePng(s);
    s.interlaced = true;
    const std::string adam7 = WritePng(s);
    ASSERT_NE(plain, adam7);
    EXPECT_EQ(Png(adam7).rgba8, Png(plain).rgba8);
    EXPECT_EQ(Png(plain).rgba8[(5 * 13 + 7) * 4 + 0], 7 * 19);
    EXPECT_EQ(Png(plain).rgba8[(5 * 13 + 7) * 4 + 1], 5 * 23);
}

/// A JPEG written by libjpeg at quality 100, without chroma subsampling: `rgb` holds w x h
/// pixels of `components` (1: grey, 3: RGB) samples.
std::string WriteJpeg(int w, int h, int components, const std::vector<uint8_t>& samples, bool progressive) {
    jpeg_compress_struct c;
    jpeg_error_mgr e;
    c.err = jpeg_std_error(&e);
    jpeg_create_compress(&c);
    unsigned char* buffer = nullptr;
    unsigned long size = 0;
    jpeg_mem_dest(&c, &buffer, &size);
    c.image_width = static_cast<JDIMENSION>(w), c.image_height = static_cast<JDIMENSION>(h);
    c.input_components = components;
    c.in_color_space = components == 1 ? JCS_GRAYSCALE : JCS_RGB;
    jpeg_set_defaults(&c);
    jpeg_set_quality(&c, 100, TRUE);
    for (int i = 0; i < c.num_components; ++i) c.comp_info[i].h_samp_factor = c.comp_info[i].v_samp_factor = 1;
    if (progressive) jpeg_simple_progression(&c);
    jpeg_start_compress(&c, TRUE);
    while (c.next_scanline < c.image_height) {
        JSAMPROW row = const_cast<JSAMPROW>(samples.data() + static_cast<size_t>(c.next_scanline) * w * components);
        jpeg_write_scanlines(&c, &row, 1);
    }
    jpeg_finish_compress(&c);
    jpeg_destroy_compress(&c);
    std::string out(reinterpret_cast<const char*>(buffer), size);
    std::free(buffer);
    return out;
}

/// 16 x 16 pixels of four flat 8 x 8 blocks (the DCT's blocks: each decodes to its colour).
std::vector<uint8_t> Blocks(int components) {
    const uint8_t colours[4][3] = {{200, 30, 40}, {20, 180, 60}, {30, 50, 220}, {128, 128, 128}};
    std::vector<uint8_t> s;
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 16; ++x) {
            const uint8_t* c = colours[(y / 8) * 2 + x / 8];
            if (components == 1) s.push_back(c[0]);
            else s.insert(s.end(), c, c + 3);
        }
    return s;
}

void ExpectBlocks(const DecodedPixels& p, int components) {
    ASSERT_EQ(p.width, 16);
    ASSERT_EQ(p.height, 16);
    ASSERT_EQ(p.rgba8.size(), 16u * 16 * 4);
    const std::vector<uint8_t> want = Blocks(components);
    int worst = 0;
    for (size_t i = 0; i < 256; ++i) {
        for (int k = 0; k < 3; ++k) {
            const int expected = want[i * static_cast<size_t>(components) + (components == 1 ? 0 : k)];
            worst = std::max(worst, std::abs(int(p.rgba8[i * 4 + static_cast<size_t>(k)]) - expected));
        }
        EXPECT_EQ(p.rgba8[i * 4 + 3], 255);
    }
    EXPECT_LE(worst, 2);  // YCbCr's rounding
}

TEST(ImageDecode, JpegGreyRgbAndProgressive) {
    for (const bool progressive : {false, true}) {
        SCOPED_TRACE(progressive ? "progressive" : "baseline");
        const std::string grey = WriteJpeg(16, 16, 1, Blocks(1), progressive);
        const std::string rgb = WriteJpeg(16, 16, 3, Blocks(3), progressive);
        ExpectBlocks(DecodeJpeg(grey.data(), grey.size(), 4, 8192), 1);
        ExpectBlocks(DecodeJpeg(rgb.data(), rgb.size(), 4, 8192), 3);
        const DecodedPixels three = DecodeJpeg(rgb.data(), rgb.size(), 3, 8192);
        EXPECT_EQ(three.rgba8.size(), 16u * 16 * 3);
        int w = 0, h = 0;
        EXPECT_TRUE(CodedImageHeadSize(rgb.data(), rgb.size(), &w, &h));
        EXPECT_EQ(w, 16);
        EXPECT_EQ(h, 16);
    }
}

/// The message of the Error `decode` throws, checking that nothing reached stderr.
template <typename F>
std::string FailureOf(F decode) {
    ::testing::internal::CaptureStderr();
    std::string message = "(no error)";
    try {
        decode();
    } catch (const Error& e) {
        message = e.what();
    }
    EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
    return message;
}

TEST(ImageDecode, BrokenPngAndJpegAreOneErrorNeverACrash) {
    PngSpec s;
    s.w = s.h = 64;
    for (int y = 0; y < s.h; ++y) {
        s.rows.emplace_back();
        for (int x = 0; x < s.w * 3; ++x) s.rows.back().push_back(uint8_t(x * y + x * 7));
    }
    const std::string png = WritePng(s);
    const std::string cut = png.substr(0, png.size() / 2);
    EXPECT_EQ(FailureOf([&] { Png(cut); }), "the PNG is cut short: its data ends before the image does");
    const size_t idat = png.find("IDAT");
    const size_t length = size_t(uint8_t(png[idat - 4])) << 24 | size_t(uint8_t(png[idat - 3])) << 16 |
                          size_t(uint8_t(png[idat - 2])) << 8 | uint8_t(png[idat - 1]);
    std::string crc = png;
    crc[idat + 4 + length] ^= 0x55;  // the chunk's CRC
    EXPECT_EQ(FailureOf([&] { Png(crc); }), "the PNG is corrupt (libpng: IDAT: CRC error)");
    std::string deflate = png;
    deflate[idat + 10] ^= 0x55;  // the compressed data (zlib's complaint comes before the CRC's)
    EXPECT_EQ(FailureOf([&] { Png(deflate); }).rfind("the PNG is corrupt (libpng: IDAT: ", 0), 0u);
    EXPECT_EQ(FailureOf([&] { DecodePng(png.data(), png.size(), 4, 32); }),
              "the image is 64 x 64, more than the 32 a side it may have");
    const std::string garbage = png.substr(0, 8) + std::string(100, 'x');
    EXPECT_NE(FailureOf([&] { Png(garbage); }).find("the PNG is"), std::string::npos);

    std::vector<uint8_t> noise;
    for (int i = 0; i < 64 * 64 * 3; ++i) noise.push_back(uint8_t((i * 7919) >> 3));
    for (const bool progressive : {false, true}) {
        const std::string jpeg = WriteJpeg(64, 64, 3, noise, progressive);
        const std::string jcut = jpeg.substr(0, jpeg.size() / 2);
        EXPECT_EQ(FailureOf([&] { DecodeJpeg(jcut.data(), jcut.size(), 4, 8192); }),
                  "the JPEG is cut short: its data ends before the image does");
        std::string twelve = jpeg;  // a frame header of 12-bit samples
        twelve[jpeg.find(progressive ? "\xff\xc2" : "\xff\xc0") + 4] = 12;
        EXPECT_EQ(FailureOf([&] { DecodeJpeg(twelve.data(), twelve.size(), 4, 8192); }),
                  "the JPEG is corrupt (libjpeg: Unsupported JPEG data precision 12)");
        EXPECT_EQ(FailureOf([&] { DecodeJpeg(jpeg.data(), jpeg.size(), 4, 32); }),
                  "the image is 64 x 64, more than the 32 a side it may have");
    }
    const std::string tables = "\xff\xd8\xff\xd9";
    EXPECT_NE(FailureOf([&] { DecodeJpeg(tables.data(), tables.size(), 4, 8192); }).find("the JPEG is corrupt"),
              std::string::npos);
}

}  // namespace
}  // namespace image_decode_test
}  // namespace lm
