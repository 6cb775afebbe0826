// image.h -- a linear RGB float image, and reading/writing PNG and EXR files.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "lightmesh/math/vec.h"
#include "lightmesh/util/huge_pages.h"

namespace lm {

/// Linear RGB pixels, row-major from the top-left corner. (On huge pages from 256 KiB up,
/// 150×150 and larger: the first touch of each 4 KiB page would cost a page fault.)
struct Image {
    int width = 0, height = 0;
    std::vector<Color, HugePageAllocator<Color>> pixels;

    Image() = default;
    Image(int w, int h) : width(w), height(h), pixels(static_cast<size_t>(w) * h) {}
    Color& At(int x, int y) { return pixels[static_cast<size_t>(y) * width + x]; }
    const Color& At(int x, int y) const { return pixels[static_cast<size_t>(y) * width + x]; }
};

/// The image formats we read and write, chosen by file extension.
enum class ImageFormat { Png, Exr };

/// The format for `path`'s extension (.png or .exr, any case); throws Error otherwise.
ImageFormat ImageFormatFor(const std::string& path);

/// Writes PNG (8-bit, sRGB-encoded, clamped) or EXR (32-bit float, linear) by extension,
/// atomically: a failure or an interruption leaves an existing file untouched.
void WriteImage(const std::string& path, const Image& image);

/// An image file's width and height from its head alone (a PNG's IHDR, an EXR's
/// dataWindow), before anything is decoded: what reading it will cost can be judged first.
/// Throws Error naming the file when the head is not one of these formats' or is cut short.
struct ImageSize {
    int width = 0, height = 0;
};
ImageSize ReadImageSize(const std::string& path);

/// What ReadImage takes for an image of this size: its float pixels and the decoder's
/// samples (18 B a pixel).
uint64_t ImageReadBytes(const ImageSize& size);
/// Reads a PNG (libpng, decoded from sRGB to linear) or an EXR. Its size is read from its
/// head first (ReadImageSize): one whose reading would take more than half the memory
/// budget (ImageReadBytes), or with more than 2^28 pixels, is refused before it is decoded.
/// Throws Error naming the file.
Image ReadImage(const std::string& path);
/// ReadImage in a child process (util/isolated_child.h), for images a user hands over
/// (`compare`): a decoder's crash, allocation bomb or endless loop is an Error naming the
/// file, not the end of this process. LIGHTMESH_IMPORT_IN_PROCESS reads in this process.
Image ReadImageIsolated(const std::string& path);

/// The display value of a linear channel: clamped to [0, 1], exact sRGB curve (the one
/// place it is written: the PNG bytes, their decoding and the comparison's metrics use it).
float SrgbEncode(float linear);
/// The inverse: the linear value of a display value in [0, 1].
float SrgbDecode(float encoded);
/// The 8-bit sRGB bytes of a linear value (clamped to [0, 1], rounded to nearest; NaN is 0).
/// A table lookup, exactly EncodeSrgb8Reference's result for every float.
unsigned char EncodeSrgb8(float linear);
/// The same by the formula (std::pow), slow: the definition EncodeSrgb8 is tested against.
unsigned char EncodeSrgb8Reference(float linear);
/// The linear value of an 8-bit sRGB byte.
float DecodeSrgb8(unsigned char encoded);

/// The PNG file WriteImage writes: 8-bit sRGB RGB, deflated by zlib in strips of
/// PngStripRows(width) rows, in parallel; the same bytes whatever the thread count.
std::vector<unsigned char> EncodePng(const Image& image);
/// The rows per deflate strip of a PNG of this width (about 256 KiB of filtered bytes).
int PngStripRows(int width);

}  // namespace lm
