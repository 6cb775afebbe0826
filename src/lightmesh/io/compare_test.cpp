#include "lightmesh/io/compare.h"

#include <gtest/gtest.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <vector>

#include "lightmesh/util/error.h"
#include "run_lightmesh.h"

namespace lm {
namespace compare_test {
namespace {

namespace fs = std::filesystem;

// A smooth image whose display values stay within [0.2, 0.8], so noise of a few percent
// is never clamped.
Image Gradient(int w, int h) {
    Image img(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const float u = static_cast<float>(x) / w, v = static_cast<float>(y) / h;
            img.At(x, y) = Color(SrgbDecode(0.2f + 0.6f * u), SrgbDecode(0.2f + 0.6f * v),
                                 SrgbDecode(0.5f + 0.3f * (u - v)));
        }
    return img;
}

// `img` with Gaussian noise of standard deviation sigma added to every display value.
Image WithNoise(const Image& img, float sigma, unsigned seed = 7) {
    std::mt19937 rng(seed);
    std::normal_distribution<float> noise(0.0f, sigma);
    Image out = img;
    for (Color& c : out.pixels) {
        c.r = SrgbDecode(SrgbEncode(c.r) + noise(rng));
        c.g = SrgbDecode(SrgbEncode(c.g) + noise(rng));
        c.b = SrgbDecode(SrgbEncode(c.b) + noise(rng));
    }
    return out;
}

std::string Temp(const std::string& name) {
    const fs::path dir = fs::path(::testing::TempDir()) / "lm_compare";
    fs::create_directories(dir);
    return (dir / name).string();
}

TEST(Compare, SrgbCurveRoundTrips) {
    for (float v : {0.0f, 0.001f, 0.0031308f, 0.2f, 0.5f, 1.0f})
        EXPECT_NEAR(SrgbDecode(SrgbEncode(v)), v, 1e-6f);
    EXPECT_EQ(SrgbEncode(2.0f), 1.0f);
    EXPECT_EQ(SrgbEncode(-1.0f), 0.0f);
    EXPECT_EQ(SrgbEncode(NAN), 0.0f);
    // The same curve as the 8-bit PNG encoder.
    for (int e : {0, 1, 10, 128, 200, 255})
        EXPECT_NEAR(SrgbEncode(DecodeSrgb8(static_cast<unsigned char>(e))) * 255.0f, e, 1e-3f);
}

TEST(Compare, ImageWithItselfHasInfinitePsnr) {
    const Image a = Gradient(40, 30);
    const ImageMetrics m = CompareImages(a, a);
    EXPECT_TRUE(std::isinf(m.psnr) && m.psnr > 0);
    EXPECT_EQ(m.ssim, 1.0);
    EXPECT_EQ(m.rmse, 0.0);
    EXPECT_EQ(m.rmseLinear, 0.0);
    EXPECT_EQ(m.maxDiff, 0.0);
    EXPECT_EQ(m.pixels, 1200u);
    const std::string json = ImageMetricsJson(m, "a.png", "b \"2\".png");
    EXPECT_EQ(json,
              "{\"a\":\"a.png\",\"b\":\"b \\\"2\\\".png\",\"psnr\":null,\"ssim\":1,\"rmse\":0,"
              "\"rmse_linear\":0,\"max_diff\":0,\"pixels\":1200,\"nonfinite_a\":0,\"nonfinite_b\":0,\"identical\":true}");
}

// Noise of standard deviation σ in display units gives MSE = σ², PSNR = 20·log10(1/σ).
TEST(Compare, KnownNoiseGivesExpectedPsnr) {
    const Image a = Gradient(200, 150);
    for (float sigma : {0.003f, 0.01f, 0.03f}) {
        const ImageMetrics m = CompareImages(a, WithNoise(a, sigma));
        EXPECT_NEAR(m.psnr, 20.0 * std::log10(1.0 / sigma), 0.2) << sigma;
        EXPECT_NEAR(m.rmse, sigma, 0.03 * sigma);
        EXPECT_NEAR(m.psnr, -20.0 * std::log10(m.rmse), 1e-9);
        EXPECT_LT(m.ssim, 1.0);
        EXPECT_GT(m.ssim, 0.0);
        EXPECT_GT(m.maxDiff, 3 * sigma);  // 90,000 Gaussian samples reach beyond 3σ
        EXPECT_LT(m.maxDiff, 6 * sigma);
        EXPECT_GT(m.rmseLinear, 0.0);
    }
    // More noise, lower SSIM.
    EXPECT_GT(CompareImages(a, WithNoise(a, 0.01f)).ssim, CompareImages(a, WithNoise(a, 0.05f)).ssim);
}

// Structure matters to SSIM, not just error energy: a constant offset keeps structure.
TEST(Compare, SsimPrefersAnOffsetToNoiseOfTheSameRmse) {
    const Image a = Gradient(100, 80);
    Image shifted = a;
    for (Color& c : shifted.pixels) c = Color(SrgbDecode(SrgbEncode(c.r) + 0.02f), SrgbDecode(SrgbEncode(c.g) + 0.02f),
                                              SrgbDecode(SrgbEncode(c.b) + 0.02f));
    const ImageMetrics offset = CompareImages(a, shifted), noisy = CompareImages(a, WithNoise(a, 0.02f));
    EXPECT_NEAR(offset.rmse, 0.02, 1e-4);
    EXPECT_NEAR(noisy.rmse, 0.02, 1e-3);
    EXPECT_GT(offset.ssim, 0.99);
    EXPECT_LT(noisy.ssim, offset.ssim);
}

TEST(Compare, MismatchedSizesNameBoth) {
    try {
        CompareImages(Gradient(40, 30), Gradient(30, 40));
        FAIL() << "expected an error";
    } catch (const Error& e) {
        EXPECT_STREQ(e.what(), "image sizes differ: 40x30 and 30x40");
    }
    const Image a = Gradient(8, 8);
    const Image mask(4, 4);
    EXPECT_THROW(CompareImages(a, a, &mask), Error);
    EXPECT_THROW(CompareImages(Image(), Image()), Error);
}

TEST(Compare, MaskRestrictsThePixels) {
    const Image a = Gradient(64, 48);
    Image b = a;
    Image mask(64, 48);  // black: excluded
    for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 32; ++x) mask.At(x, y) = Color(1.0f);  // left half included
    for (int y = 0; y < 48; ++y)
        for (int x = 32; x < 64; ++x) b.At(x, y) = Color(0.0f);  // the right half differs
    const ImageMetrics masked = CompareImages(a, b, &mask);
    EXPECT_EQ(masked.pixels, 32u * 48u);
    EXPECT_TRUE(std::isinf(masked.psnr));
    const ImageMetrics all = CompareImages(a, b);
    EXPECT_EQ(all.pixels, 64u * 48u);
    EXPECT_LT(all.psnr, 20);
    // A change in the masked region is seen.
    b.At(5, 5) = Color(1.0f);
    EXPECT_FALSE(std::isinf(CompareImages(a, b, &mask).psnr));
    const Image black(64, 48);
    EXPECT_THROW(CompareImages(a, b, &black), Error);
    // A mask of NaN (or negative) pixels selects nothing either (not every pixel as
    // "not black").
    Image nan(64, 48);
    for (Color& c : nan.pixels) c = Color(std::nanf(""));
    Image negative(64, 48);
    for (Color& c : negative.pixels) c = Color(-1.0f);
    for (const Image* m : {&nan, &negative}) {
        try {
            CompareImages(a, b, m);
            ADD_FAILURE() << "no error";
        } catch (const Error& e) {
            EXPECT_EQ(std::string(e.what()),
                      "the mask selects no pixel (only mask pixels with a channel above 0 are compared; black, "
                      "negative and NaN pixels are not)");
        }
        EXPECT_THROW(WriteDiffImage(Temp("nan_mask_diff.png"), a, b, 0, m), Error);
    }
}

/// A 16-bit RGB PNG of w × h pixels whose samples are value(x, y, channel).
template <typename F>
void WritePng16(const std::string& path, int w, int h, F value) {
    std::vector<unsigned char> raw;
    for (int y = 0; y < h; ++y) {
        raw.push_back(0);  // filter: none
        for (int x = 0; x < w; ++x)
            for (int c = 0; c < 3; ++c) {
                const uint16_t v = value(x, y, c);
                raw.push_back(static_cast<unsigned char>(v >> 8));
                raw.push_back(static_cast<unsigned char>(v & 0xff));
            }
    }
    uLongf size = compressBound(static_cast<uLong>(raw.size()));
    std::vector<unsigned char> z(size);
    ASSERT_EQ(compress(z.data(), &size, raw.data(), static_cast<uLong>(raw.size())), Z_OK);
    z.resize(size);
    std::string png("\x89PNG\r\n\x1a\n", 8);
    auto be32 = [](uint32_t v) {
        return std::string{static_cast<char>(v >> 24), static_cast<char>(v >> 16), static_cast<char>(v >> 8),
                           static_cast<char>(v)};
    };
    auto chunk = [&](const std::string& type, const std::string& data) {
        const std::string body = type + data;
        png += be32(static_cast<uint32_t>(data.size())) + body +
               be32(static_cast<uint32_t>(crc32(0, reinterpret_cast<const Bytef*>(body.data()), static_cast<uInt>(body.size()))));
    };
    chunk("IHDR", be32(static_cast<uint32_t>(w)) + be32(static_cast<uint32_t>(h)) + std::string("\x10\x02\0\0\0", 5));
    chunk("IDAT", std::string(z.begin(), z.end()));
    chunk("IEND", "");
    std::ofstream(path, std::ios::binary) << png;
}

// Two 16-bit PNGs that differ in every sample's low byte are read at their depth, so they
// do not compare as identical (as they would if read at 8 bits).
TEST(Compare, SixteenBitPngsAreComparedAtSixteenBits) {
    const std::string a = Temp("a16.png"), b = Temp("b16.png");
    auto base = [](int x, int y, int c) { return static_cast<uint16_t>((x * 2000 + y * 700 + c * 5000) & 0xff00); };
    WritePng16(a, 16, 8, base);
    WritePng16(b, 16, 8, [&](int x, int y, int c) { return static_cast<uint16_t>(base(x, y, c) | 0x80); });
    const Image ia = ReadImage(a), ib = ReadImage(b);
    const ImageMetrics m = CompareImages(ia, ib);
    EXPECT_FALSE(std::isinf(m.psnr));
    EXPECT_NEAR(m.maxDiff, 128.0 / 65535, 1e-5);
    EXPECT_TRUE(std::isinf(CompareImages(ia, ReadImage(a)).psnr));
    // The 16-bit values decode as sRGB at their own precision.
    EXPECT_NEAR(SrgbEncode(ib.At(0, 0).r), 0x80 / 65535.0f, 1e-6f);
}

/// An EXR of w × h float pixels with the channels given, each filled by value(x, y, channel index).
template <typename F>
void WriteExrChannels(const std::string& path, int w, int h, const std::vector<std::string>& names, F value) {
    Imf::Header header(w, h);
    for (const std::string& n : names) header.channels().insert(n, Imf::Channel(Imf::FLOAT));
    std::vector<std::vector<float>> planes(names.size(), std::vector<float>(static_cast<size_t>(w) * h));
    Imf::FrameBuffer fb;
    for (size_t c = 0; c < names.size(); ++c) {
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) planes[c][static_cast<size_t>(y) * w + x] = value(x, y, static_cast<int>(c));
        fb.insert(names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(planes[c].data()), sizeof(float),
                                       sizeof(float) * w));
    }
    Imf::OutputFile file(path.c_str(), header);
    file.setFrameBuffer(fb);
    file.writePixels(h);
}

// An EXR with only Y, or with channels r, g, b, is not read as black: Y is read as grey,
// lower-case r, g, b as colour, anything else is refused naming the channels.
TEST(Compare, ExrLayoutsAreReadOrRefusedByName) {
    auto v = [](int x, int y, int c) { return 0.1f * static_cast<float>(x) + 0.01f * static_cast<float>(y) + 0.3f * c; };
    const std::string y = Temp("y.exr"), lower = Temp("lower.exr"), upper = Temp("upper.exr");
    WriteExrChannels(y, 8, 4, {"Y"}, v);
    WriteExrChannels(lower, 8, 4, {"r", "g", "b"}, v);
    Image expected(8, 4);
    for (int yy = 0; yy < 4; ++yy)
        for (int x = 0; x < 8; ++x) expected.At(x, yy) = Color(v(x, yy, 0), v(x, yy, 1), v(x, yy, 2));
    WriteImage(upper, expected);
    const Image grey = ReadImage(y), rgb = ReadImage(lower);
    EXPECT_EQ(grey.At(3, 2).r, v(3, 2, 0));
    EXPECT_EQ(grey.At(3, 2).g, v(3, 2, 0));
    EXPECT_EQ(grey.At(3, 2).b, v(3, 2, 0));
    EXPECT_TRUE(std::isinf(CompareImages(rgb, ReadImage(upper)).psnr));
    EXPECT_GT(CompareImages(rgb, Image(8, 4)).maxDiff, 0.5);  // not black
    struct Bad {
        std::vector<std::string> channels;
        std::string message;
    };
    for (const Bad& bad : std::vector<Bad>{
             {{"A", "Z"}, "EXR has no R, G, B (or r, g, b) and no Y channel to read (its channels: A, Z)"},
             {{"R", "G"}, "EXR has only some of the channels R, G, B (its channels: G, R)"},
             {{"diffuse.R", "diffuse.G", "diffuse.B"},
              "EXR has no R, G, B (or r, g, b) and no Y channel to read (its channels: diffuse.B, diffuse.G, diffuse.R)"},
             {{"Y", "RY", "BY"}, "EXR is luminance-chroma (Y, RY, BY), which compare does not read; convert it to R, G, "
                                 "B (its channels: BY, RY, Y)"}}) {
        const std::string path = Temp("bad.exr");
        WriteExrChannels(path, 8, 4, bad.channels, v);
        try {
            ReadImage(path);
            ADD_FAILURE() << "no error for " << bad.message;
        } catch (const Error& e) {
            EXPECT_EQ(std::string(e.what()), path + ": " + bad.message);
        }
    }
}

TEST(Compare, PngAndExrOfOneImageCompareAlike) {
    const Image a = Gradient(50, 40), b = WithNoise(a, 0.02f);
    const std::string pa = Temp("a.exr"), pb = Temp("b.exr"), qa = Temp("a.png"), qb = Temp("b.png");
    WriteImage(pa, a);
    WriteImage(pb, b);
    WriteImage(qa, a);
    WriteImage(qb, b);
    const ImageMetrics exr = CompareImages(ReadImage(pa), ReadImage(pb));
    const ImageMetrics png = CompareImages(ReadImage(qa), ReadImage(qb));
    EXPECT_NEAR(exr.psnr, CompareImages(a, b).psnr, 1e-9);
    EXPECT_NEAR(png.psnr, exr.psnr, 0.3);  // 8-bit rounding only
}

TEST(Compare, DiffImageIsWrittenAndReadable) {
    const Image a = Gradient(32, 24);
    Image b = a;
    b.At(3, 4) = Color(1.0f, 0.0f, 0.0f);
    const std::string path = Temp("diff.png");
    fs::remove(path);
    WriteDiffImage(path, a, b);
    const Image d = ReadImage(path);
    ASSERT_EQ(d.width, 32);
    ASSERT_EQ(d.height, 24);
    // Equal pixels get the map's low end (near black), the largest difference its high
    // end (dark red).
    const Color low = TurboColormap(0), high = TurboColormap(1);
    EXPECT_LT(low.MaxComponent(), 0.15f);
    EXPECT_GT(high.r, 3 * high.b);
    for (const auto& [got, want] : {std::pair{d.At(0, 0), low}, std::pair{d.At(3, 4), high}}) {
        EXPECT_NEAR(SrgbEncode(got.r), want.r, 1.0f / 255);
        EXPECT_NEAR(SrgbEncode(got.g), want.g, 1.0f / 255);
        EXPECT_NEAR(SrgbEncode(got.b), want.b, 1.0f / 255);
    }
    // A mask blacks out the excluded pixels; a fixed scale is honoured.
    Image mask(32, 24);
    mask.At(3, 4) = Color(1.0f);
    WriteDiffImage(path, a, b, 4.0f, &mask);
    const Image m = ReadImage(path);
    EXPECT_TRUE(m.At(0, 0).IsBlack());
    const Color& c = a.At(3, 4);
    const float largest = std::max({1.0f - SrgbEncode(c.r), SrgbEncode(c.g), SrgbEncode(c.b)});
    EXPECT_NEAR(SrgbEncode(m.At(3, 4).g), TurboColormap(largest / 4.0f).g, 1.0f / 255);
    EXPECT_THROW(WriteDiffImage(path, a, Gradient(10, 10)), Error);
}

// The executable: exit codes, the --json line, --diff, --threshold-psnr.
using CliRun = lm::testing::CliResult;

CliRun Lightmesh(const std::string& args) { return lm::testing::RunLightmesh(args); }

TEST(CompareCli, ExitCodesJsonAndDiff) {
    const Image a = Gradient(60, 40);
    const std::string pa = Temp("cli_a.png"), pb = Temp("cli_b.exr"), pc = Temp("cli_c.png");
    const std::string diff = Temp("cli_diff.png"), mask = Temp("cli_mask.png");
    WriteImage(pa, a);
    WriteImage(pb, WithNoise(a, 0.01f));
    WriteImage(pc, Gradient(30, 20));

    CliRun r = Lightmesh("compare " + pa + " " + pa);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("PSNR inf"), std::string::npos) << r.output;

    r = Lightmesh("compare --json " + pa + " " + pa);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_EQ(r.output, "{\"a\":\"" + pa + "\",\"b\":\"" + pa +
                            "\",\"psnr\":null,\"ssim\":1,\"rmse\":0,\"rmse_linear\":0,\"max_diff\":0,"
                            "\"pixels\":2400,\"nonfinite_a\":0,\"nonfinite_b\":0,\"identical\":true}\n");

    fs::remove(diff);
    r = Lightmesh("compare " + pa + " " + pb + " --json --diff " + diff + " --threshold-psnr 30");
    EXPECT_EQ(r.exitCode, 0) << r.output;
    const size_t at = r.output.find("\"psnr\":");
    ASSERT_NE(at, std::string::npos) << r.output;
    EXPECT_NEAR(std::stod(r.output.substr(at + 7)), 40.0, 0.3) << r.output;  // σ = 0.01, plus 8-bit rounding
    EXPECT_NE(r.output.find("\"identical\":false"), std::string::npos) << r.output;
    EXPECT_EQ(ReadImage(diff).width, 60);

    r = Lightmesh("compare " + pa + " " + pb + " --threshold-psnr 45");
    EXPECT_EQ(r.exitCode, 3) << r.output;
    EXPECT_NE(r.output.find("below the threshold"), std::string::npos) << r.output;

    r = Lightmesh("compare " + pa + " " + pc);
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_NE(r.output.find("lightmesh: error: " + pa + " is 60x40 and " + pc +
                            " is 30x20: images of different sizes cannot be compared\n"),
              std::string::npos)
        << r.output;

    r = Lightmesh("compare " + pa + " " + Temp("missing.png"));
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_NE(r.output.find("missing.png"), std::string::npos) << r.output;

    // NaN in the judged image: counted, left out, and below any threshold.
    const std::string pn = Temp("cli_nan.exr");
    Image withNan = a;
    withNan.At(5, 5) = Color(std::numeric_limits<float>::quiet_NaN());
    WriteImage(pn, withNan);
    r = Lightmesh("compare " + pa + " " + pn + " --json --threshold-psnr 10");
    EXPECT_EQ(r.exitCode, 3) << r.output;
    EXPECT_NE(r.output.find("\"pixels\":2399,\"nonfinite_a\":0,\"nonfinite_b\":1,\"identical\":false"),
              std::string::npos)
        << r.output;
    EXPECT_EQ(r.output.find("null"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("has 1 NaN or infinite pixels where " + pa + " has numbers: below any threshold"),
              std::string::npos)
        << r.output;
    r = Lightmesh("compare " + pa + " " + pn);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("; left out: 0 pixels NaN or infinite in A, 1 in B\n"), std::string::npos) << r.output;

    Image m(60, 40);
    for (int x = 0; x < 10; ++x) m.At(x, 0) = Color(1.0f);
    WriteImage(mask, m);
    r = Lightmesh("compare --json --mask " + mask + " " + pa + " " + pb);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("\"pixels\":10,"), std::string::npos) << r.output;
}

// NaN and infinite pixels are counted and left out of every figure (compared as 0, an
// all-NaN image would be judged as black, and --json would say "rmse_linear": null).
TEST(Compare, NonFinitePixelsAreCountedAndLeftOut) {
    const Image a = Gradient(40, 30), b = WithNoise(a, 0.02f);
    Image bad = b, refA = a, refB = b;
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    bad.At(3, 4).g = nan;
    bad.At(20, 10).r = inf;
    bad.At(39, 29) = Color(nan);
    // The same figures as comparing the finite pixels alone (through a mask leaving them out).
    Image finite(40, 30);
    for (Color& c : finite.pixels) c = Color(1.0f);
    for (auto [x, y] : {std::pair{3, 4}, {20, 10}, {39, 29}}) finite.At(x, y) = Color(0.0f);
    const ImageMetrics q = CompareImages(a, bad), want = CompareImages(a, b, &finite);
    EXPECT_EQ(q.pixels, 40u * 30u - 3u);
    EXPECT_EQ(q.nonFiniteA, 0u);
    EXPECT_EQ(q.nonFiniteB, 3u);
    EXPECT_EQ(q.nonFiniteOnlyInB, 3u);
    EXPECT_TRUE(std::isfinite(q.rmseLinear));
    EXPECT_DOUBLE_EQ(q.rmseLinear, want.rmseLinear);
    EXPECT_DOUBLE_EQ(q.rmse, want.rmse);
    EXPECT_DOUBLE_EQ(q.maxDiff, want.maxDiff);
    EXPECT_NEAR(q.ssim, want.ssim, 2e-3);  // (the neighbours' windows leave the bad pixels out too)
    EXPECT_FALSE(q.Identical());
    EXPECT_NE(ImageMetricsJson(q, "a", "b").find("\"nonfinite_a\":0,\"nonfinite_b\":3,\"identical\":false"),
              std::string::npos);
    // The same NaN in both: not counted against B, and not identical either.
    Image badA = a;
    badA.At(39, 29) = Color(nan);
    const ImageMetrics both = CompareImages(badA, badA);
    EXPECT_EQ(both.nonFiniteOnlyInB, 0u);
    EXPECT_EQ(both.rmse, 0.0);
    EXPECT_FALSE(both.Identical());
    // An all-NaN image is not black: there is nothing to compare.
    Image allNan(40, 30);
    for (Color& c : allNan.pixels) c = Color(nan);
    try {
        CompareImages(a, allNan);
        ADD_FAILURE() << "an all-NaN image was compared";
    } catch (const Error& e) {
        EXPECT_STREQ(e.what(), "no pixel is finite in both images: 0 of A's and 1,200 of B's have a NaN or infinite "
                               "channel");
    }
}

// End to end: area shadows give the same image for 1 and 3 threads, and `compare` says so.
TEST(CompareCli, AreaShadowsAreTheSameForAnyThreadCount) {
    const std::string a = Temp("area_t1.png"), b = Temp("area_t3.png");
    const std::string common =
        "render builtin:gazebo --width 80 --height 60 -q --shadows area --light-radius 0.5 --samples 8";
    ASSERT_EQ(Lightmesh(common + " --threads 1 -o " + a).exitCode, 0);
    ASSERT_EQ(Lightmesh(common + " --threads 3 -o " + b).exitCode, 0);
    const CliRun r = Lightmesh("compare --json --threshold-psnr 99 " + a + " " + b);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("\"identical\":true"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace compare_test
}  // namespace lm
