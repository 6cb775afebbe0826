#include "lightmesh/io/compare.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {

Color TurboColormap(float x) {
    // Polynomial approximation by Ruofei Du of Anton Mikhailov's Turbo map (Google, 2019,
    // Apache-2.0): https://research.google/blog/turbo-an-improved-rainbow-colormap-for-visualization/
    x = std::clamp(std::isnan(x) ? 0.0f : x, 0.0f, 1.0f);
    auto poly = [x](float c0, float c1, float c2, float c3, float c4, float c5) {
        return std::clamp(c0 + x * (c1 + x * (c2 + x * (c3 + x * (c4 + x * c5)))), 0.0f, 1.0f);
    };
    return {poly(0.13572138f, 4.61539260f, -42.66032258f, 132.13108234f, -152.94239396f, 59.28637943f),
            poly(0.09140261f, 2.19418839f, 4.84296658f, -14.18503333f, 4.27729857f, 2.82956604f),
            poly(0.10667330f, 12.64194608f, -60.58204836f, 110.36276771f, -89.90310912f, 27.34824973f)};
}

namespace {

void CheckSizes(const Image& a, const Image& b, const Image* mask) {
    if (a.width <= 0 || a.height <= 0 || b.width <= 0 || b.height <= 0)
        ThrowError("cannot compare an empty image (%dx%d and %dx%d)", a.width, a.height, b.width, b.height);
    if (a.width != b.width || a.height != b.height)
        ThrowError("image sizes differ: %dx%d and %dx%d", a.width, a.height, b.width, b.height);
    if (mask && (mask->width != a.width || mask->height != a.height))
        ThrowError("mask size %dx%d differs from the images' %dx%d", mask->width, mask->height, a.width,
                   a.height);
}

/// A mask pixel selects when one of its channels is above 0: black, negative and NaN
/// pixels do not (so an all-NaN mask selects nothing, not every pixel as "not black").
bool Included(const Image* mask, size_t i) {
    if (!mask) return true;
    const Color& c = mask->pixels[i];
    return c.r > 0 || c.g > 0 || c.b > 0;
}

/// Whether every channel of `c` is a number (not NaN, not infinite).
bool Finite(const Color& c) { return std::isfinite(c.r) && std::isfinite(c.g) && std::isfinite(c.b); }

struct Display {
    double r, g, b;
};
Display Encode(const Color& c) { return {SrgbEncode(c.r), SrgbEncode(c.g), SrgbEncode(c.b)}; }
double Luma(const Display& d) { return 0.2126 * d.r + 0.7152 * d.g + 0.0722 * d.b; }

/// Gaussian blur with an 11-tap kernel (σ = 1.5), the kernel cut at the border and
/// renormalised; separable, so renormalising each pass is exact for the 2-D window.
std::vector<double> Blur(const std::vector<double>& in, int w, int h) {
    constexpr int Radius = 5;
    constexpr double Sigma = 1.5;
    double k[2 * Radius + 1];
    for (int i = -Radius; i <= Radius; ++i) k[i + Radius] = std::exp(-(i * i) / (2 * Sigma * Sigma));
    std::vector<double> tmp(in.size()), out(in.size());
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double sum = 0, wsum = 0;
            for (int i = std::max(-Radius, -x); i <= std::min(Radius, w - 1 - x); ++i) {
                sum += k[i + Radius] * in[static_cast<size_t>(y) * w + x + i];
                wsum += k[i + Radius];
            }
            tmp[static_cast<size_t>(y) * w + x] = sum / wsum;
        }
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double sum = 0, wsum = 0;
            for (int i = std::max(-Radius, -y); i <= std::min(Radius, h - 1 - y); ++i) {
                sum += k[i + Radius] * tmp[static_cast<size_t>(y + i) * w + x];
                wsum += k[i + Radius];
            }
            out[static_cast<size_t>(y) * w + x] = sum / wsum;
        }
    return out;
}

}  // namespace

ImageMetrics CompareImages(const Image& a, const Image& b, const Image* mask) {
    CheckSizes(a, b, mask);
    const int w = a.width, h = a.height;
    const size_t n = a.pixels.size();
    ImageMetrics m;
    m.width = w;
    m.height = h;

    double sq = 0, sqLinear = 0, maxDiff = 0;
    size_t count = 0, selected = 0;
    std::vector<double> ya(n), yb(n);
    for (size_t i = 0; i < n; ++i) {
        const Display da = Encode(a.pixels[i]), db = Encode(b.pixels[i]);
        ya[i] = Luma(da);
        yb[i] = Luma(db);
        if (!Included(mask, i)) continue;
        ++selected;
        const bool finiteA = Finite(a.pixels[i]), finiteB = Finite(b.pixels[i]);
        m.nonFiniteA += !finiteA;
        m.nonFiniteB += !finiteB;
        m.nonFiniteOnlyInB += finiteA && !finiteB;
        if (!finiteA || !finiteB) continue;
        ++count;
        for (const double d : {da.r - db.r, da.g - db.g, da.b - db.b}) {
            sq += d * d;
            maxDiff = std::max(maxDiff, std::abs(d));
        }
        const Color &ca = a.pixels[i], &cb = b.pixels[i];
        for (const double d : {double(ca.r) - cb.r, double(ca.g) - cb.g, double(ca.b) - cb.b}) sqLinear += d * d;
    }
    if (selected == 0)
        ThrowError("the mask selects no pixel (only mask pixels with a channel above 0 are compared; black, "
                   "negative and NaN pixels are not)");
    if (count == 0)
        ThrowError("no pixel%s is finite in both images: %s of A's and %s of B's have a NaN or infinite channel",
                   mask ? " the mask selects" : "", FormatCount(m.nonFiniteA).c_str(), FormatCount(m.nonFiniteB).c_str());
    const double mse = sq / (3.0 * static_cast<double>(count));
    m.pixels = count;
    m.rmse = std::sqrt(mse);
    m.rmseLinear = std::sqrt(sqLinear / (3.0 * static_cast<double>(count)));
    m.maxDiff = maxDiff;
    m.psnr = mse > 0 ? 10.0 * std::log10(1.0 / mse) : std::numeric_limits<double>::infinity();

    // SSIM (Wang, Bovik, Sheikh & Simoncelli 2004, eq. 13) with Gaussian-weighted local
    // statistics; dynamic range L = 1.
    // Pixels non-finite in either image are left out of the windows too: their weight is
    // 0 and each window's weights are renormalised (a blur of the values over a blur of
    // the weights; with no such pixel the weights' blur is exactly 1 and is skipped).
    constexpr double C1 = 0.01 * 0.01, C2 = 0.03 * 0.03;
    std::vector<double> weight;
    if (m.nonFiniteA + m.nonFiniteB > 0) {
        weight.assign(n, 1.0);
        for (size_t i = 0; i < n; ++i)
            if (!Finite(a.pixels[i]) || !Finite(b.pixels[i])) weight[i] = ya[i] = yb[i] = 0;
        if (std::find(weight.begin(), weight.end(), 0.0) == weight.end()) weight.clear();
    }
    std::vector<double> aa(n), bb(n), ab(n);
    for (size_t i = 0; i < n; ++i) {
        aa[i] = ya[i] * ya[i];
        bb[i] = yb[i] * yb[i];
        ab[i] = ya[i] * yb[i];
    }
    std::vector<double> muA = Blur(ya, w, h), muB = Blur(yb, w, h);
    aa = Blur(aa, w, h);
    bb = Blur(bb, w, h);
    ab = Blur(ab, w, h);
    if (!weight.empty()) {
        const std::vector<double> sum = Blur(weight, w, h);
        for (std::vector<double>* plane : {&muA, &muB, &aa, &bb, &ab})
            for (size_t i = 0; i < n; ++i) (*plane)[i] = sum[i] > 0 ? (*plane)[i] / sum[i] : 0.0;
    }
    double ssimSum = 0;
    for (size_t i = 0; i < n; ++i) {
        if (!Included(mask, i) || !Finite(a.pixels[i]) || !Finite(b.pixels[i])) continue;
        const double varA = aa[i] - muA[i] * muA[i], varB = bb[i] - muB[i] * muB[i];
        const double cov = ab[i] - muA[i] * muB[i];
        ssimSum += ((2 * muA[i] * muB[i] + C1) * (2 * cov + C2)) /
                   ((muA[i] * muA[i] + muB[i] * muB[i] + C1) * (varA + varB + C2));
    }
    m.ssim = ssimSum / static_cast<double>(count);
    return m;
}

void WriteDiffImage(const std::string& path, const Image& a, const Image& b, float scale, const Image* mask) {
    CheckSizes(a, b, mask);
    if (mask) {
        bool any = false;
        for (size_t i = 0; i < a.pixels.size() && !any; ++i) any = Included(mask, i);
        if (!any)
            ThrowError("the mask selects no pixel (only mask pixels with a channel above 0 are compared; black, "
                       "negative and NaN pixels are not)");
    }
    const size_t n = a.pixels.size();
    std::vector<float> diff(n, 0.0f);
    float largest = 0;
    for (size_t i = 0; i < n; ++i) {
        if (!Included(mask, i)) continue;
        const Color &ca = a.pixels[i], &cb = b.pixels[i];
        diff[i] = std::max({std::abs(SrgbEncode(ca.r) - SrgbEncode(cb.r)), std::abs(SrgbEncode(ca.g) - SrgbEncode(cb.g)),
                            std::abs(SrgbEncode(ca.b) - SrgbEncode(cb.b))});
        largest = std::max(largest, diff[i]);
    }
    const float s = scale > 0 ? scale : largest;
    Image out(a.width, a.height);
    for (size_t i = 0; i < n; ++i) {
        if (!Included(mask, i)) continue;  // stays black
        const Color c = TurboColormap(s > 0 ? diff[i] / s : 0.0f);
        // Store linear values so the PNG writer's sRGB encoding gives the map's colours back.
        out.pixels[i] = Color(SrgbDecode(c.r), SrgbDecode(c.g), SrgbDecode(c.b));
    }
    WriteImage(path, out);
}

namespace {

std::string JsonString(const std::string& s) {
    std::string out = "\"";
    for (const char ch : s) {
        const auto c = static_cast<unsigned char>(ch);
        if (c == '"' || c == '\\') {
            out += '\\';
            out += ch;
        } else if (c < 0x20) {
            out += StringPrintf("\\u%04x", c);
        } else {
            out += ch;
        }
    }
    return out + "\"";
}

std::string JsonNumber(double v) { return std::isfinite(v) ? StringPrintf("%.8g", v) : "null"; }

}  // namespace

double ShadowTotal(const Image& none, const Image& img) {
    if (none.width != img.width || none.height != img.height)
        ThrowError("shadow total: the image without shadows is %dx%d, the image %dx%d", none.width, none.height,
                   img.width, img.height);
    double sum = 0;
    for (size_t i = 0; i < img.pixels.size(); ++i) {
        const Color &n = none.pixels[i], &c = img.pixels[i];
        const double d = static_cast<double>(0.2126f * n.r + 0.7152f * n.g + 0.0722f * n.b) -
                         static_cast<double>(0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b);
        if (std::isfinite(d)) sum += d;  // NaN and infinite pixels are left out, as in CompareImages
    }
    return sum;
}

std::string ImageMetricsJson(const ImageMetrics& m, const std::string& a, const std::string& b) {
    return "{\"a\":" + JsonString(a) + ",\"b\":" + JsonString(b) + ",\"psnr\":" + JsonNumber(m.psnr) +
           ",\"ssim\":" + JsonNumber(m.ssim) + ",\"rmse\":" + JsonNumber(m.rmse) +
           ",\"rmse_linear\":" + JsonNumber(m.rmseLinear) + ",\"max_diff\":" + JsonNumber(m.maxDiff) +
           ",\"pixels\":" + std::to_string(m.pixels) + ",\"nonfinite_a\":" + std::to_string(m.nonFiniteA) +
           ",\"nonfinite_b\":" + std::to_string(m.nonFiniteB) + ",\"identical\":" + (m.Identical() ? "true" : "false") +
           "}";
}

}  // namespace lm
