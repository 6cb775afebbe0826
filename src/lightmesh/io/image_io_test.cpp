#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

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
                          << "): fast " << int(EncodeSrgb8(v)) << ", reference " << int(EncodeSrgb8Reference(v));
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
    for (float v : {0.0f, -0.0f, -1.0f, 1.0f, 2.0f, std::numeric_limits<float>::denorm_min(),
                    std::numeric_limits<float>::min(), std::numeric_limits<float>::max(),
                    std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
                    std::numeric_limits<float>::quiet_NaN(), -std::numeric_limits<float>::quiet_NaN()})
        check(v);
    EXPECT_EQ(EncodeSrgb8(std::numeric_limits<float>::infinity()), 255);
    EXPECT_EQ(EncodeSrgb8(-std::numeric_limits<float>::quiet_NaN()), 0);
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

}  // namespace
}  // namespace lm
