#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <tbb/task_arena.h>
#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <vector>

#include "lightmesh/io/image.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/parallel.h"

namespace lm {
namespace image_io_test {
namespace {

std::string TempPath(const std::string& name) { return ::testing::TempDir() + "/lm_image_" + name; }

std::string ReadBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), {}};
}

Image Gradient(int w, int h) {
    Image img(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            img.At(x, y) = Color(static_cast<float>(x) / (w - 1), static_cast<float>(y) / (h - 1), 0.25f);
    return img;
}

TEST(ImageIO, SrgbEncodingRoundTripsEveryByte) {
    for (int b = 0; b < 256; ++b) EXPECT_EQ(EncodeSrgb8(DecodeSrgb8(static_cast<unsigned char>(b))), b);
    EXPECT_EQ(EncodeSrgb8(-1.0f), 0);
    EXPECT_EQ(EncodeSrgb8(7.0f), 255);
    EXPECT_EQ(EncodeSrgb8(NAN), 0);
    EXPECT_EQ(EncodeSrgb8(0.5f), 188);  // the standard curve: 0.5 linear is 188/255
}

float BitsFloat(uint32_t u) { return std::bit_cast<float>(u); }
uint32_t FloatBits(float f) { return std::bit_cast<uint32_t>(f); }

// The reference's steps, found independently of the encoder: step[k] is the smallest float
// in [0, 1] that the reference encodes to k or more (k = 1..255).
std::vector<uint32_t> ReferenceSteps() {
    std::vector<uint32_t> steps(256, 0);
    for (int k = 1; k <= 255; ++k) {
        uint32_t lo = 0, hi = FloatBits(1.0f);
        while (hi - lo > 1) {
            const uint32_t mid = lo + (hi - lo) / 2;
            (EncodeSrgb8Reference(BitsFloat(mid)) >= k ? hi : lo) = mid;
        }
        steps[k] = hi;
    }
    return steps;
}

TEST(ImageIO, FastSrgbEncodingEqualsTheReference) {
    int mismatches = 0;
    auto check = [&](float v) {
        if (EncodeSrgb8(v) != EncodeSrgb8Reference(v) && ++mismatches <= 10)
            ADD_FAILURE() << "v = " << v << " (bits 0x" << std::hex << FloatBits(v) << std::dec
                          << "): fast " << int(EncodeSrgb8(v)) << ", reference "
                          << int(EncodeSrgb8Reference(v));
    };
    // Every 2^8-th float of [0, 1], and 1 itself.
    for (uint32_t u = 0; u <= FloatBits(1.0f); u += 256) check(BitsFloat(u));
    check(1.0f);
    // Both sides of every step, a few floats deep.
    const std::vector<uint32_t> steps = ReferenceSteps();
    for (int k = 1; k <= 255; ++k) {
        EXPECT_LT(EncodeSrgb8Reference(BitsFloat(steps[k] - 1)), k);
        EXPECT_GE(EncodeSrgb8Reference(BitsFloat(steps[k])), k);
        for (int d = -3; d <= 3; ++d) check(BitsFloat(steps[k] + d));
    }
    // Random bit patterns: in [0, 1], and anywhere (negative, huge, inf, NaN).
    std::mt19937 rng(12345);
    std::uniform_int_distribution<uint32_t> unit(0, FloatBits(1.0f)), any;
    for (int i = 0; i < 1000000; ++i) check(BitsFloat(unit(rng)));
    for (int i = 0; i < 200000; ++i) check(BitsFloat(any(rng)));
    using Limits = std::numeric_limits<float>;
    for (float v : {0.0f, -0.0f, -1.0f, 1.0f, 2.0f, Limits::denorm_min(), Limits::min(),
                    Limits::max(), Limits::infinity(), -Limits::infinity(), Limits::quiet_NaN(),
                    -Limits::quiet_NaN()})
        check(v);
    EXPECT_EQ(EncodeSrgb8(Limits::infinity()), 255);
    EXPECT_EQ(EncodeSrgb8(-Limits::quiet_NaN()), 0);
    EXPECT_EQ(mismatches, 0);
}

// All 1.07e9 floats of [0, 1] (5 s on one core): run it with --gtest_also_run_disabled_tests
// --gtest_filter='*EveryFloat*' after touching either encoder.
TEST(ImageIO, DISABLED_FastSrgbEncodingEqualsTheReferenceOnEveryFloat) {
    std::atomic<uint64_t> mismatches{0};
    const uint32_t end = FloatBits(1.0f) + 1, block = 1 << 20;
    ParallelFor(uint32_t(0), (end + block - 1) / block, [&](uint32_t b) {
        uint64_t bad = 0;
        for (uint32_t u = b * block; u < std::min(end, (b + 1) * block); ++u)
            bad += EncodeSrgb8(BitsFloat(u)) != EncodeSrgb8Reference(BitsFloat(u));
        mismatches += bad;
    });
    EXPECT_EQ(mismatches.load(), 0u);
}

// Random pixels: mostly in [0, 1], some anywhere (negative, above 1, inf, NaN).
Image RandomImage(int w, int h, unsigned seed) {
    Image img(w, h);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::uniform_int_distribution<uint32_t> any;
    for (Color& c : img.pixels) {
        float* v = &c.r;
        for (int i = 0; i < 3; ++i) v[i] = rng() % 16 == 0 ? BitsFloat(any(rng)) : unit(rng);
    }
    return img;
}

// A render-like image: smooth gradients, a flat area, and a sharp edge.
Image SmoothImage(int w, int h) {
    Image img(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float u = (x + 0.5f) / w, v = (y + 0.5f) / h;
            img.At(x, y) = u + v < 0.6f ? Color(0.3f, 0.5f, 0.9f)
                                        : Color(u * u, 0.5f + 0.5f * std::sin(6 * v), 0.2f * u * v);
        }
    return img;
}

// Writes img as PNG, reads it back with stb's decoder and checks every byte is the reference's.
void ExpectPngRoundTripsToReferenceBytes(const Image& img, const std::string& name) {
    const std::string path = TempPath(name);
    WriteImage(path, img);
    const Image back = ReadImage(path);
    ASSERT_EQ(back.width, img.width);
    ASSERT_EQ(back.height, img.height);
    int mismatches = 0;
    for (size_t i = 0; i < img.pixels.size(); ++i) {
        const float* a = &img.pixels[i].r;
        const float* b = &back.pixels[i].r;
        for (int c = 0; c < 3; ++c)
            if (EncodeSrgb8(b[c]) != EncodeSrgb8Reference(a[c]) && ++mismatches <= 5)
                ADD_FAILURE() << name << " pixel " << i << " channel " << c << ": value " << a[c]
                              << " read back as " << int(EncodeSrgb8(b[c])) << ", reference "
                              << int(EncodeSrgb8Reference(a[c]));
    }
    EXPECT_EQ(mismatches, 0) << name;
}

TEST(ImageIO, PngRoundTripGivesTheReferenceBytes) {
    // The floats on both sides of every step, through the PNG writer's row encoder.
    const std::vector<uint32_t> steps = ReferenceSteps();
    Image atSteps(7, 255);
    for (int k = 1; k <= 255; ++k)
        for (int d = -10; d <= 10; ++d) (&atSteps.At(0, k - 1).r)[d + 10] = BitsFloat(steps[k] + d);
    ExpectPngRoundTripsToReferenceBytes(atSteps, "steps.png");

    ASSERT_LT(PngStripRows(300), 1000);  // so 300x1000 has several strips
    const int sizes[][2] = {{1, 1}, {3, 517}, {1031, 7}, {300, 1000}, {2, 3000}};
    for (const auto& s : sizes) {
        const std::string tag = std::to_string(s[0]) + "x" + std::to_string(s[1]);
        ExpectPngRoundTripsToReferenceBytes(RandomImage(s[0], s[1], s[0] * 7 + s[1]),
                                            "random_" + tag + ".png");
        ExpectPngRoundTripsToReferenceBytes(SmoothImage(s[0], s[1]), "smooth_" + tag + ".png");
    }
}

TEST(ImageIO, PngBytesDoNotDependOnTheThreadCount) {
    const Image img = SmoothImage(700, 1100);
    const Image noisy = RandomImage(257, 3001, 7);
    ASSERT_GT(1100 / PngStripRows(700), 2);
    auto encodeWith = [](int threads, const Image& image) {
        tbb::task_arena arena(threads);
        std::vector<unsigned char> png;
        arena.execute([&] { png = EncodePng(image); });
        return png;
    };
    for (const Image* image : {&img, &noisy}) {
        const std::vector<unsigned char> one = encodeWith(1, *image);
        EXPECT_EQ(encodeWith(2, *image), one);
        EXPECT_EQ(encodeWith(4, *image), one);
        EXPECT_EQ(EncodePng(*image), one);
    }
    // And WriteImage writes exactly those bytes.
    const std::string path = TempPath("threads.png");
    tbb::task_arena arena(2);
    arena.execute([&] { WriteImage(path, img); });
    const std::vector<unsigned char> one = encodeWith(1, img);
    EXPECT_EQ(ReadBytes(path), std::string(one.begin(), one.end()));
}

uint32_t Be32(const unsigned char* p) {
    return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3];
}

// Checks the file's structure without stb: signature, chunk CRCs, IHDR, and that zlib's own
// inflate accepts the IDATs' stream (header, every block, Adler-32) with the right length.
TEST(ImageIO, PngChunksAndZlibStreamAreValid) {
    for (const Image& img : {SmoothImage(640, 900), RandomImage(5, 3, 1), SmoothImage(1, 1)}) {
        const std::vector<unsigned char> png = EncodePng(img);
        ASSERT_GT(png.size(), 8u + 25 + 12);
        const unsigned char signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
        ASSERT_EQ(std::memcmp(png.data(), signature, 8), 0);
        std::vector<std::string> types;
        std::vector<unsigned char> zdata;
        size_t p = 8;
        while (p + 12 <= png.size()) {
            const uint32_t n = Be32(&png[p]);
            ASSERT_LE(p + 12 + n, png.size());
            const std::string type(reinterpret_cast<const char*>(&png[p + 4]), 4);
            EXPECT_EQ(crc32(0, &png[p + 4], 4 + n), Be32(&png[p + 8 + n])) << type << " CRC";
            if (type == "IHDR") {
                ASSERT_EQ(n, 13u);
                EXPECT_EQ(Be32(&png[p + 8]), uint32_t(img.width));
                EXPECT_EQ(Be32(&png[p + 12]), uint32_t(img.height));
                EXPECT_EQ(png[p + 16], 8);  // bit depth
                EXPECT_EQ(png[p + 17], 2);  // RGB
            }
            if (type == "IDAT") zdata.insert(zdata.end(), &png[p + 8], &png[p + 8 + n]);
            types.push_back(type);
            p += 12 + n;
        }
        EXPECT_EQ(p, png.size());
        ASSERT_GE(types.size(), 3u);
        EXPECT_EQ(types.front(), "IHDR");
        EXPECT_EQ(types.back(), "IEND");
        const int strips = (img.height + PngStripRows(img.width) - 1) / PngStripRows(img.width);
        EXPECT_EQ(std::count(types.begin(), types.end(), "IDAT"), strips);  // one per strip
        const size_t expected = static_cast<size_t>(img.height) * (1 + 3 * img.width);
        std::vector<unsigned char> raw(expected + 1);
        uLongf rawSize = raw.size();
        ASSERT_EQ(uncompress(raw.data(), &rawSize, zdata.data(), zdata.size()), Z_OK);
        EXPECT_EQ(rawSize, expected);
        for (int y = 0; y < img.height; ++y)
            EXPECT_EQ(raw[y * (1 + 3 * size_t(img.width))], 4) << "row " << y << ": Paeth";
    }
}

TEST(ImageIO, PngRoundTripWithinOneStep) {
    const Image img = Gradient(37, 19);
    const std::string path = TempPath("rt.png");
    WriteImage(path, img);
    const Image back = ReadImage(path);
    ASSERT_EQ(back.width, 37);
    ASSERT_EQ(back.height, 19);
    for (size_t i = 0; i < img.pixels.size(); ++i) {
        EXPECT_EQ(EncodeSrgb8(back.pixels[i].r), EncodeSrgb8(img.pixels[i].r));
        EXPECT_EQ(EncodeSrgb8(back.pixels[i].g), EncodeSrgb8(img.pixels[i].g));
    }
}

TEST(ImageIO, ExrRoundTripIsExact) {
    Image img = Gradient(16, 9);
    img.At(3, 4) = Color(123.5f, 1e-6f, 0.0f);  // HDR values survive
    const std::string path = TempPath("rt.exr");
    WriteImage(path, img);
    const Image back = ReadImage(path);
    ASSERT_EQ(back.width, 16);
    ASSERT_EQ(back.height, 9);
    EXPECT_EQ(back.pixels, img.pixels);
}

TEST(ImageIO, UnknownExtensionAndMissingFolderAreErrorsAndWriteNothing) {
    const Image img = Gradient(4, 4);
    EXPECT_THROW(WriteImage(TempPath("x.jpg"), img), Error);
    EXPECT_FALSE(std::filesystem::exists(TempPath("x.jpg")));
    try {
        WriteImage(TempPath("no/such/folder/x.png"), img);
        FAIL() << "expected an error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
    }
    EXPECT_THROW(ReadImage(TempPath("missing.png")), Error);
}

TEST(ImageIO, FailedWriteLeavesThePreviousFileUntouched) {
    const std::string path = TempPath("keep.exr");
    WriteImage(path, Gradient(8, 8));
    const std::string before = ReadBytes(path);
    // An empty image cannot be written: the old file must stay as it was.
    EXPECT_THROW(WriteImage(path, Image()), Error);
    EXPECT_EQ(ReadBytes(path), before);
    // A read-only folder: the write fails before touching anything.
    const std::string dir = TempPath("ro");
    std::filesystem::create_directories(dir);
    WriteImage(dir + "/a.png", Gradient(4, 4));
    const std::string png = ReadBytes(dir + "/a.png");
    chmod(dir.c_str(), 0555);
    if (access(dir.c_str(), W_OK) == 0) {
        chmod(dir.c_str(), 0755);
        GTEST_SKIP() << "running as a user who can write anywhere (root)";
    }
    EXPECT_THROW(WriteImage(dir + "/a.png", Gradient(5, 5)), Error);
    EXPECT_EQ(ReadBytes(dir + "/a.png"), png);
    chmod(dir.c_str(), 0755);
}

TEST(ImageIO, GarbageFilesAreErrorsNotCrashes) {
    const std::string png = TempPath("garbage.png"), exr = TempPath("garbage.exr");
    std::ofstream(png) << "not a png at all";
    std::ofstream(exr) << "not an exr either";
    EXPECT_THROW(ReadImage(png), Error);
    EXPECT_THROW(ReadImage(exr), Error);
}

// An EXR's size is read from its header's dataWindow, and what reading it takes judged
// against the budget, before OpenEXR sees the file, which would decode one of 2^28 pixels
// into 3 GiB first (its only check is that count).
TEST(ImageIO, AnExrPastTheBudgetIsRefusedFromItsHeader) {
    const std::string exr = TempPath("huge.exr");
    WriteImage(exr, Gradient(4, 4));
    std::string bytes = ReadBytes(exr);
    const size_t at = bytes.find(std::string("dataWindow\0box2i\0", 17));
    ASSERT_NE(at, std::string::npos);
    const int32_t box[4] = {0, 0, 16383, 16383};
    std::memcpy(bytes.data() + at + 17 + 4, box, sizeof box);
    std::ofstream(exr, std::ios::binary) << bytes;
    setenv("LIGHTMESH_MEMORY_LIMIT", "1G", 1);
    try {
        ReadImage(exr);
        ADD_FAILURE() << "read";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()), exr + ": an EXR of 16384x16384 pixels: reading it takes about 4.5 GiB (18 B a "
                                               "pixel), more than half of the 1.0 GiB this process may use "
                                               "(LIGHTMESH_MEMORY_LIMIT)");
    }
    unsetenv("LIGHTMESH_MEMORY_LIMIT");
    std::remove(exr.c_str());
}

}  // namespace
}  // namespace image_io_test
}  // namespace lm
