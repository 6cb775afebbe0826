#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "lightmesh/io/image.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

// stb's implementation lives in this one translation unit, with internal linkage.
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wunused-function"
#include <stb_image.h>
#include <stb_image_write.h>
#pragma GCC diagnostic pop

namespace lm {

ImageFormat ImageFormatFor(const std::string& path) {
    std::string ext;
    const size_t dot = path.find_last_of('.');
    const size_t slash = path.find_last_of('/');
    if (dot != std::string::npos && (slash == std::string::npos || dot > slash))
        ext = path.substr(dot);
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (ext == ".png") return ImageFormat::Png;
    if (ext == ".exr") return ImageFormat::Exr;
    ThrowError("%s: unknown image extension \"%s\" (use .png or .exr)", path.c_str(), ext.c_str());
}

unsigned char EncodeSrgb8(float v) {
    if (!(v > 0)) return 0;  // also maps NaN to 0
    if (v >= 1) return 255;
    const float s = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
    return static_cast<unsigned char>(std::lround(s * 255.0f));
}

float DecodeSrgb8(unsigned char e) {
    const float s = static_cast<float>(e) / 255.0f;
    return s <= 0.04045f ? s / 12.92f : std::pow((s + 0.055f) / 1.055f, 2.4f);
}

namespace {

void WritePng(const std::string& tmp, const Image& image) {
    std::vector<unsigned char> rgb(static_cast<size_t>(image.width) * image.height * 3);
    for (size_t i = 0; i < image.pixels.size(); ++i) {
        rgb[3 * i + 0] = EncodeSrgb8(image.pixels[i].r);
        rgb[3 * i + 1] = EncodeSrgb8(image.pixels[i].g);
        rgb[3 * i + 2] = EncodeSrgb8(image.pixels[i].b);
    }
    std::vector<unsigned char> bytes;
    auto append = [](void* ctx, void* data, int size) {
        auto* out = static_cast<std::vector<unsigned char>*>(ctx);
        out->insert(out->end(), static_cast<unsigned char*>(data),
                    static_cast<unsigned char*>(data) + size);
    };
    if (!stbi_write_png_to_func(append, &bytes, image.width, image.height, 3, rgb.data(),
                                image.width * 3))
        ThrowError("%s: PNG encoding failed", tmp.c_str());
    std::ofstream out(tmp, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) ThrowError("%s: write failed: %s", tmp.c_str(), std::strerror(errno));
}

void WriteExr(const std::string& tmp, const Image& image) {
    Imf::Header header(image.width, image.height);
    header.channels().insert("R", Imf::Channel(Imf::FLOAT));
    header.channels().insert("G", Imf::Channel(Imf::FLOAT));
    header.channels().insert("B", Imf::Channel(Imf::FLOAT));
    Imf::OutputFile file(tmp.c_str(), header);
    Imf::FrameBuffer fb;
    char* base = reinterpret_cast<char*>(const_cast<Color*>(image.pixels.data()));
    const size_t xs = sizeof(Color), ys = sizeof(Color) * image.width;
    fb.insert("R", Imf::Slice(Imf::FLOAT, base + offsetof(Color, r), xs, ys));
    fb.insert("G", Imf::Slice(Imf::FLOAT, base + offsetof(Color, g), xs, ys));
    fb.insert("B", Imf::Slice(Imf::FLOAT, base + offsetof(Color, b), xs, ys));
    file.setFrameBuffer(fb);
    file.writePixels(image.height);
}

Image ReadPng(const std::string& path) {
    int w = 0, h = 0, n = 0;
    unsigned char* data = stbi_load(path.c_str(), &w, &h, &n, 3);
    if (!data) ThrowError("%s: cannot read PNG: %s", path.c_str(), stbi_failure_reason());
    Image image(w, h);
    for (size_t i = 0; i < image.pixels.size(); ++i)
        image.pixels[i] = Color(DecodeSrgb8(data[3 * i]), DecodeSrgb8(data[3 * i + 1]),
                                DecodeSrgb8(data[3 * i + 2]));
    stbi_image_free(data);
    return image;
}

Image ReadExr(const std::string& path) {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i dw = file.header().dataWindow();
    const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
    if (w <= 0 || h <= 0 || static_cast<int64_t>(w) * h > (int64_t(1) << 28))
        ThrowError("%s: unsupported EXR size %dx%d", path.c_str(), w, h);
    Image image(w, h);
    Imf::FrameBuffer fb;
    char* base = reinterpret_cast<char*>(image.pixels.data()) -
                 (static_cast<ptrdiff_t>(dw.min.x) + static_cast<ptrdiff_t>(dw.min.y) * w) *
                     static_cast<ptrdiff_t>(sizeof(Color));
    const size_t xs = sizeof(Color), ys = sizeof(Color) * w;
    fb.insert("R", Imf::Slice(Imf::FLOAT, base + offsetof(Color, r), xs, ys));
    fb.insert("G", Imf::Slice(Imf::FLOAT, base + offsetof(Color, g), xs, ys));
    fb.insert("B", Imf::Slice(Imf::FLOAT, base + offsetof(Color, b), xs, ys));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    return image;
}

}  // namespace

void WriteImage(const std::string& path, const Image& image) {
    const ImageFormat format = ImageFormatFor(path);
    if (image.width <= 0 || image.height <= 0) ThrowError("%s: empty image", path.c_str());
    WriteFileAtomically(path, [&](const std::string& tmp) {
        try {
            if (format == ImageFormat::Png) WritePng(tmp, image);
            else WriteExr(tmp, image);
        } catch (const Error&) {
            throw;
        } catch (const std::exception& e) {
            ThrowError("%s: cannot write: %s", path.c_str(), e.what());
        }
    });
}

Image ReadImage(const std::string& path) {
    const ImageFormat format = ImageFormatFor(path);
    CheckRegularFile(path, "image");  // never blocks on a FIFO
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) ThrowError("%s: cannot open: %s", path.c_str(), std::strerror(errno));
    std::fclose(f);
    try {
        return format == ImageFormat::Png ? ReadPng(path) : ReadExr(path);
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        ThrowError("%s: cannot read EXR: %s", path.c_str(), e.what());
    }
}

}  // namespace lm
