// texture_test.cpp -- images in memory: lookups, wrap modes, mip-maps, decoding, the cache.
#include "lightmesh/texture/texture.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>

#include "lightmesh/io/image.h"
#include "lightmesh/texture/texture_cache.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace texture_test {
namespace {

const std::string DataDir = std::string(LIGHTMESH_TEST_DATA) + "/textures";

std::string ReadBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// texels.png: red, green (top row), blue, white (bottom row).
TEST(Texture, DecodesPngAndLooksUpEachTexelInLinearColour) {
    const auto tex = DecodeTexture(ReadBytes(DataDir + "/texels.png"));
    ASSERT_EQ(tex->Width(), 2);
    ASSERT_EQ(tex->Height(), 2);
    EXPECT_EQ(tex->Levels(), 2);
    EXPECT_FALSE(tex->HasAlpha());
    // v grows upwards: the top row is at v = 0.75, the bottom row at v = 0.25.
    const Texel red = tex->Sample(0.25f, 0.75f, 0, TextureWrap::Clamp, TextureWrap::Clamp);
    const Texel green = tex->Sample(0.75f, 0.75f, 0, TextureWrap::Clamp, TextureWrap::Clamp);
    const Texel blue = tex->Sample(0.25f, 0.25f, 0, TextureWrap::Clamp, TextureWrap::Clamp);
    EXPECT_EQ(red.Rgb(), Color(1, 0, 0));
    EXPECT_EQ(green.Rgb(), Color(0, 1, 0));
    EXPECT_EQ(blue.Rgb(), Color(0, 0, 1));
    EXPECT_EQ(red.a, 1.0f);
    // Half-way between red and green: the linear mean (bilinear in linear space).
    const Texel mid = tex->Sample(0.5f, 0.75f, 0, TextureWrap::Clamp, TextureWrap::Clamp);
    EXPECT_FLOAT_EQ(mid.r, 0.5f);
    EXPECT_FLOAT_EQ(mid.g, 0.5f);
    // The last level is the mean of the four, in linear space, stored as sRGB bytes.
    const Texel mean = tex->Sample(0.3f, 0.6f, 5, TextureWrap::Repeat, TextureWrap::Repeat);
    EXPECT_NEAR(mean.r, 0.5f, 0.005f);
    EXPECT_NEAR(mean.g, 0.5f, 0.005f);
    EXPECT_NEAR(mean.b, 0.5f, 0.005f);
}

TEST(Texture, SrgbBytesAreDecodedToLinear) {
    const Texture tex(1, 1, std::vector<uint8_t>{128, 64, 255, 128});
    const Texel t = tex.Sample(0.5f, 0.5f, 0, TextureWrap::Repeat, TextureWrap::Repeat);
    EXPECT_FLOAT_EQ(t.r, DecodeSrgb8(128));
    EXPECT_FLOAT_EQ(t.g, DecodeSrgb8(64));
    EXPECT_FLOAT_EQ(t.b, 1.0f);
    EXPECT_NEAR(t.a, 128.0f / 255.0f, 1e-6f);  // alpha is linear
    EXPECT_TRUE(tex.HasAlpha());
}

TEST(Texture, WrapModesRepeatClampAndMirror) {
    // One row of four texels: 0, 1/3, 2/3, 1 in linear floats (red channel).
    std::vector<float> rgba;
    for (int x = 0; x < 4; ++x) rgba.insert(rgba.end(), {x / 3.0f, 0, 0, 1});
    const Texture tex(4, 1, rgba);
    auto red = [&](float u, TextureWrap w) { return tex.Sample(u, 0.5f, 0, w, TextureWrap::Clamp).r; };
    EXPECT_FLOAT_EQ(red(0.125f, TextureWrap::Repeat), 0.0f);
    EXPECT_FLOAT_EQ(red(1.125f, TextureWrap::Repeat), 0.0f);   // the next copy's first texel
    EXPECT_FLOAT_EQ(red(-0.875f, TextureWrap::Repeat), 0.0f);
    EXPECT_FLOAT_EQ(red(1.375f, TextureWrap::Clamp), 1.0f);    // the last texel, held
    EXPECT_FLOAT_EQ(red(-3.0f, TextureWrap::Clamp), 0.0f);
    EXPECT_FLOAT_EQ(red(1.125f, TextureWrap::Mirror), 1.0f);   // mirrored: the last texel first
    EXPECT_FLOAT_EQ(red(1.875f, TextureWrap::Mirror), 0.0f);
    // Non-finite and huge coordinates stay in the image.
    EXPECT_GE(red(std::numeric_limits<float>::quiet_NaN(), TextureWrap::Repeat), 0.0f);
    EXPECT_LE(red(std::numeric_limits<float>::infinity(), TextureWrap::Repeat), 1.0f);
    EXPECT_LE(red(3e9f, TextureWrap::Mirror), 1.0f);
}

TEST(Texture, MipLevelsAverageAndLodBlendsThem) {
    // An 8 x 8 checker of black and white: every level but the first is grey.
    std::vector<uint8_t> rgba;
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x) {
            const uint8_t c = (x + y) % 2 ? 255 : 0;
            rgba.insert(rgba.end(), {c, c, c, 255});
        }
    const Texture tex(8, 8, rgba);
    EXPECT_EQ(tex.Levels(), 4);
    const float at0 = tex.Sample(1.5f / 8, 1.5f / 8, 0, TextureWrap::Repeat, TextureWrap::Repeat).r;
    const float at1 = tex.Sample(1.5f / 8, 1.5f / 8, 1, TextureWrap::Repeat, TextureWrap::Repeat).r;
    const float atHalf = tex.SampleTrilinear(1.5f / 8, 1.5f / 8, 0.5f, TextureWrap::Repeat, TextureWrap::Repeat).r;
    EXPECT_EQ(tex.Sample(1.5f / 8, 1.5f / 8, 0.99f, TextureWrap::Repeat, TextureWrap::Repeat).r, at0);
    EXPECT_TRUE(at0 == 0.0f || at0 == 1.0f);
    EXPECT_NEAR(at1, 0.5f, 0.005f);  // the linear mean, not sRGB's 0.5 byte
    EXPECT_NEAR(atHalf, 0.5f * (at0 + at1), 1e-5f);
}

TEST(Texture, BadImagesAreErrorsNotCrashes) {
    EXPECT_THROW(DecodeTexture(""), Error);
    EXPECT_THROW(DecodeTexture("not an image at all"), Error);
    std::string truncated = ReadBytes(DataDir + "/texels.png");
    truncated.resize(truncated.size() / 2);
    EXPECT_THROW(DecodeTexture(truncated), Error);
    EXPECT_THROW(ReadTextureFile(DataDir + "/no_such_image.png"), Error);
}

TEST(TextureCache, ReadsEachImageOnceAndWarnsOnceForAMissingOne) {
    TextureCache cache;
    std::vector<std::shared_ptr<const Texture>> textures;
    std::vector<std::string> warnings;
    auto warn = [&](const std::string& w) { warnings.push_back(w); };
    TextureSource a;
    a.file = DataDir + "/texels.png";
    a.name = "texels.png";
    TextureSource b = a;
    b.file = DataDir + "/../textures/texels.png";  // the same file by another path
    EXPECT_EQ(cache.Get(a, "m.obj", &textures, warn), 0);
    EXPECT_EQ(cache.Get(b, "n.obj", &textures, warn), 0);
    EXPECT_EQ(textures.size(), 1u);
    TextureSource missing;
    missing.file = DataDir + "/missing.png";
    missing.name = "missing.png";
    EXPECT_EQ(cache.Get(missing, "m.obj", &textures, warn), -1);
    EXPECT_EQ(cache.Get(missing, "m.obj", &textures, warn), -1);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("m.obj: texture \"missing.png\": no such file; the material's flat colour is used"),
              std::string::npos)
        << warnings[0];
    // Embedded bytes, and raw B, G, R, A texels.
    TextureSource embedded;
    embedded.bytes = ReadBytes(DataDir + "/texels.png");
    EXPECT_EQ(cache.Get(embedded, "m.glb", &textures, warn), 1);
    TextureSource raw;
    raw.rawWidth = raw.rawHeight = 1;
    raw.bytes = std::string("\x00\x00\xff\xff", 4);  // red
    const int r = cache.Get(raw, "m.fbx", &textures, warn);
    ASSERT_EQ(r, 2);
    EXPECT_EQ(textures[2]->Sample(0.5f, 0.5f, 0, TextureWrap::Repeat, TextureWrap::Repeat).Rgb(), Color(1, 0, 0));
}

TEST(TextureCache, ADecoderCrashCostsItsImageOnly) {
    // The decoders run in a child process: one that crashes on an image (here on purpose)
    // leaves that image with the flat colour and a warning; the next child decodes the rest.
    TextureCache cache([](const TextureSource& s) {
        if (s.name == "crash.png") std::abort();
        return DecodeSource(s);
    });
    std::vector<std::shared_ptr<const Texture>> textures;
    std::vector<std::string> warnings;
    TextureSource good, crash, other;
    good.file = DataDir + "/texels.png";
    good.name = "texels.png";
    crash.bytes = "crash";
    crash.name = "crash.png";
    other.rawWidth = other.rawHeight = 1;
    other.bytes = std::string("\x00\xff\x00\xff", 4);  // green
    other.name = "raw";
    const std::vector<int> got = cache.GetAll({good, crash, other, good}, "m.gltf", &textures,
                                              [&](const std::string& w) { warnings.push_back(w); });
    EXPECT_EQ(got, (std::vector<int>{0, -1, 1, 0}));
    ASSERT_EQ(textures.size(), 2u);
    EXPECT_EQ(textures[0]->Width(), 2);
    EXPECT_EQ(textures[1]->Sample(0.5f, 0.5f, 0, TextureWrap::Repeat, TextureWrap::Repeat).Rgb(), Color(0, 1, 0));
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("m.gltf: texture \"crash.png\": the image decoder crashed on it (signal 6, SIGABRT); "
                               "the material's flat colour is used"),
              std::string::npos)
        << warnings[0];
}

TEST(TextureCache, AnImageTooLargeToDecodeIsAWarning) {
    // A PNG header claiming 8192 x 8192 texels with nothing behind it: refused or failed in
    // the child, never decoded into gigabytes here.
    std::string png = ReadBytes(DataDir + "/texels.png");
    TextureCache cache;
    std::vector<std::shared_ptr<const Texture>> textures;
    std::vector<std::string> warnings;
    TextureSource s;
    s.bytes = png.substr(0, 33);  // signature and IHDR only
    s.name = "cut.png";
    EXPECT_EQ(cache.Get(s, "m.glb", &textures, [&](const std::string& w) { warnings.push_back(w); }), -1);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("m.glb: texture \"cut.png\": cannot decode the image"), std::string::npos)
        << warnings[0];
    EXPECT_TRUE(textures.empty());
}

}  // namespace
}  // namespace texture_test
}  // namespace lm

namespace lm {
namespace texture_test {
namespace {

/// The warnings a fresh cache gives reading `files` (each named by its path) for model m.obj.
std::vector<std::string> WarningsFor(const std::vector<std::string>& files) {
    TextureCache cache;
    std::vector<std::shared_ptr<const Texture>> textures;
    std::vector<std::string> warnings;
    std::vector<TextureSource> sources(files.size());
    for (size_t i = 0; i < files.size(); ++i) sources[i].file = sources[i].name = files[i];
    for (const int got : cache.GetAll(sources, "m.obj", &textures, [&](const std::string& w) { warnings.push_back(w); }))
        EXPECT_EQ(got, -1);
    return warnings;
}

// A texture file is judged by its head before it is read whole. A 2 GB sparse
// file named .png, and a true PNG head (16 x 16 texels) followed by 2 GB of holes, are each
// a warning in well under a second, through the cache as a scene reads them.
TEST(TextureCache, AHugeFileIsJudgedByItsHeadBeforeItIsRead) {
    const std::string dir = ::testing::TempDir() + "lm_huge_textures_" + std::to_string(getpid());
    std::filesystem::create_directories(dir);
    const std::string zeros = dir + "/zeros.png", headed = dir + "/headed.png";
    {
        std::ofstream(zeros, std::ios::binary).put('\0');
        std::ofstream(headed, std::ios::binary) << ReadBytes(DataDir + "/texels.png").substr(0, 33);
    }
    constexpr off_t kTwoGB = off_t(2) << 30;
    ASSERT_EQ(truncate(zeros.c_str(), kTwoGB), 0);
    ASSERT_EQ(truncate(headed.c_str(), kTwoGB), 0);
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<std::string> warnings = WarningsFor({zeros, headed});
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_LT(seconds, 1.0);
    ASSERT_EQ(warnings.size(), 2u);
    EXPECT_NE(warnings[0].find("zeros.png\": its first 4096 bytes are all zero (NUL): not an image (a zeroed or "
                               "sparse file?); not read; the material's flat colour is used"),
              std::string::npos)
        << warnings[0];
    EXPECT_NE(warnings[1].find("headed.png\": the file is 2.0 GiB, more than a 2 x 2 image takes (at most 16.0 "
                               "MiB); not read"),
              std::string::npos)
        << warnings[1];
    std::filesystem::remove_all(dir);
}

// A head that tells no size (a JPEG's can follow more than a MiB of metadata) is read whole
// up to 64 MiB, for the decoder to judge; past that it is refused at once. An EXR is judged
// by its header's dataWindow before it is decoded.
TEST(TextureCache, AHeadThatTellsNoSizeAndAnExrPastTheLimit) {
    const std::string dir = ::testing::TempDir() + "lm_texture_heads_" + std::to_string(getpid());
    std::filesystem::create_directories(dir);
    const std::string small = dir + "/small.jpg", big = dir + "/big.jpg", exr = dir + "/huge.exr";
    std::ofstream(small, std::ios::binary) << std::string(2 << 20, 'x');
    std::ofstream(big, std::ios::binary) << std::string(4096, 'x');
    ASSERT_EQ(truncate(big.c_str(), off_t(100) << 20), 0);
    std::string head("\x76\x2f\x31\x01\x02\0\0\0dataWindow\0box2i\0\x10\0\0\0", 29);
    for (const int32_t v : {0, 0, 16383, 16383}) head.append(reinterpret_cast<const char*>(&v), 4);
    std::ofstream(exr, std::ios::binary) << head << '\0';
    const std::vector<std::string> warnings = WarningsFor({small, big, exr});
    ASSERT_EQ(warnings.size(), 3u);
    EXPECT_NE(warnings[0].find("small.jpg\": cannot decode the image"), std::string::npos) << warnings[0];
    EXPECT_NE(warnings[1].find("big.jpg\": its first 1.0 MiB (of 100.0 MiB) are not the head of a PNG, JPEG, TGA "
                               "or BMP image"),
              std::string::npos)
        << warnings[1];
    EXPECT_NE(warnings[2].find("huge.exr\": the image is 16384 x 16384, beyond the 8192 x 8192 textures may have; "
                               "not read"),
              std::string::npos)
        << warnings[2];
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace texture_test
}  // namespace lm

namespace lm {
namespace texture_test {
namespace {

// PNG and JPEG are decoded by libpng and libjpeg-turbo. A file cut short or
// corrupt is a warning naming the decoder's reason and the flat colour, decoded in the
// child as a scene reads it; valid ones give their texels (the 16-bit PNG as linear floats).
TEST(TextureCache, BrokenPngAndJpegAreAWarningAndTheFlatColour) {
    const std::string dir = ::testing::TempDir() + "lm_broken_textures_" + std::to_string(getpid());
    std::filesystem::create_directories(dir);
    const std::string png = ReadBytes(DataDir + "/texels.png");
    // A 2 x 2 baseline JPEG of grey 128, written by libjpeg.
    const std::string jpeg(
        "\xff\xd8\xff\xdb\x00\x43\x00\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01"
        "\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01"
        "\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\x01\xff\xc0\x00\x0b"
        "\x08\x00\x02\x00\x02\x01\x01\x11\x00\xff\xc4\x00\x14\x00\x01\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
        "\x00\x00\x00\x00\x00\x00\xff\xc4\x00\x14\x10\x01\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00\x00"
        "\x00\x00\x00\xff\xda\x00\x08\x01\x01\x00\x00\x3f\x00\x3f\xff\xd9",
        141);
    const std::vector<std::pair<std::string, std::string>> files = {
        {"good.png", png},
        {"good.jpg", jpeg},
        {"cut.png", png.substr(0, png.size() - 20)},
        {"bad.png", png.substr(0, 45) + char(png[45] ^ 1) + png.substr(46)},
        {"cut.jpg", jpeg.substr(0, 100)},
    };
    std::vector<TextureSource> sources;
    for (const auto& [name, bytes] : files) {
        std::ofstream(dir + "/" + name, std::ios::binary) << bytes;
        TextureSource s;
        s.file = dir + "/" + name;
        s.name = name;
        sources.push_back(s);
    }
    TextureCache cache;
    std::vector<std::shared_ptr<const Texture>> textures;
    std::vector<std::string> warnings;
    const std::vector<int> got =
        cache.GetAll(sources, "m.obj", &textures, [&](const std::string& w) { warnings.push_back(w); });
    EXPECT_EQ(got, (std::vector<int>{0, 1, -1, -1, -1}));
    ASSERT_EQ(textures.size(), 2u);
    EXPECT_EQ(textures[0]->Sample(0.25f, 0.75f, 0, TextureWrap::Clamp, TextureWrap::Clamp).Rgb(), Color(1, 0, 0));
    EXPECT_EQ(textures[1]->Width(), 2);
    EXPECT_NEAR(textures[1]->Sample(0.5f, 0.5f, 0, TextureWrap::Clamp, TextureWrap::Clamp).r, DecodeSrgb8(128), 0.01f);
    ASSERT_EQ(warnings.size(), 3u);
    EXPECT_EQ(warnings[0], "m.obj: texture \"cut.png\": cannot decode the image (the PNG is cut short: its data ends "
                           "before the image does); the material's flat colour is used");
    EXPECT_EQ(warnings[1], "m.obj: texture \"bad.png\": cannot decode the image (the PNG is corrupt (libpng: IDAT: "
                           "incorrect data check)); the material's flat colour is used");
    EXPECT_EQ(warnings[2], "m.obj: texture \"cut.jpg\": cannot decode the image (the JPEG is cut short: its data ends "
                           "before the image does); the material's flat colour is used");
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace texture_test
}  // namespace lm
