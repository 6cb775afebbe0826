#include "lightmesh/io/compare.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "lightmesh/util/error.h"
#include "run_lightmesh.h"

namespace lm {
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
              "\"rmse_linear\":0,\"max_diff\":0,\"pixels\":1200,\"identical\":true}");
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
                            "\"pixels\":2400,\"identical\":true}\n");

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
    EXPECT_NE(r.output.find("image sizes differ: 60x40 and 30x20"), std::string::npos) << r.output;

    r = Lightmesh("compare " + pa + " " + Temp("missing.png"));
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_NE(r.output.find("missing.png"), std::string::npos) << r.output;

    Image m(60, 40);
    for (int x = 0; x < 10; ++x) m.At(x, 0) = Color(1.0f);
    WriteImage(mask, m);
    r = Lightmesh("compare --json --mask " + mask + " " + pa + " " + pb);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("\"pixels\":10,"), std::string::npos) << r.output;
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
}  // namespace lm
