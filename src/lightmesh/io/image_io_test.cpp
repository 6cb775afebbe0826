#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "lightmesh/io/image.h"
#include "lightmesh/util/error.h"

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
