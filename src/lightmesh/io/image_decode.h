// image_decode.h -- PNG and JPEG files decoded by the field's maintained libraries
// (libpng, libjpeg-turbo), their errors as one line of ours: the textures' decoder
// (texture/texture.cpp) and compare's PNG reader (image_io.cpp) share them. Neither library
// may print or exit: their errors and warnings are caught and worded here.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace lm {

/// A file's kind by its first bytes (the PNG signature, a JPEG's SOI marker).
enum class CodedImageKind { Png, Jpeg, Other };
CodedImageKind CodedImageKindOf(const void* data, size_t size);

/// The width and height a PNG's or JPEG's head tells (a PNG's IHDR; a JPEG's frame header,
/// found by walking the segments before it): false when `size` bytes do not reach it, or the
/// head is not one.
bool CodedImageHeadSize(const void* data, size_t size, int* width, int* height);

/// Decoded pixels, row 0 at the top: `channels` samples a pixel (3: RGB, 4: RGBA), 8 bits
/// (`rgba8`) or 16 bits (`rgba16`, host order; 16-bit PNGs only). Grey is replicated into
/// RGB, a palette expanded, a tRNS chunk made alpha, samples of 1, 2 or 4 bits scaled to 8;
/// no gamma is applied (as stb_image read them). Alpha is 255 (65535) where the file has none.
struct DecodedPixels {
    int width = 0, height = 0, channels = 4, bits = 8;
    std::vector<uint8_t> rgba8;
    std::vector<uint16_t> rgba16;
};

/// A PNG in memory, by libpng. `channels` 3 drops the alpha. An image wider or taller than
/// `maxSide` is refused from its header, before its pixels are decoded. Throws Error with
/// the reason ("the PNG is corrupt (libpng: IDAT: CRC error)", "the PNG is cut short").
DecodedPixels DecodePng(const void* data, size_t size, int channels, int maxSide);
/// A JPEG in memory, by libjpeg-turbo (grey, YCbCr, RGB, CMYK or YCCK; baseline,
/// progressive or arithmetic-coded; 8-bit). Always 8 bits. The same refusals; a JPEG whose
/// data ends early is refused, not filled with grey; one of more than 1,000 scans too.
DecodedPixels DecodeJpeg(const void* data, size_t size, int channels, int maxSide);

}  // namespace lm
