// shadow_denoiser.cpp -- N shadow rays per light and a shadow-only denoiser (see the header).
#include "lightmesh/render/shadow_denoiser.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <utility>
#include <vector>

#include "lightmesh/shadow/area_light.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/parallel.h"
#include "lightmesh/util/system.h"
#include "lightmesh/util/hash.h"

namespace lm {

namespace {

/// The weight of a light's unshadowed term (Rec. 709 luminance).
inline float Luminance(const Color& c) { return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b; }

/// One of kTurns turns per pixel and pass (SplitMix64's finaliser on image coordinates).
constexpr int kTurns = 256;
inline int TapTurn(int x, int y, int pass) {
    uint64_t z = (static_cast<uint64_t>(static_cast<uint32_t>(x)) << 32 | static_cast<uint32_t>(y)) +
                 0x9E3779B97F4A7C15ull * static_cast<uint64_t>(pass + 1);
    return static_cast<int>(Mix64(z) >> 56);
}

/// The unit-disc taps (Vogel's spiral: uniform in area), their Gaussian weights, and the
/// cosines and sines of the turns.
struct Taps {
    float x[kDenoiseTaps], y[kDenoiseTaps], weight[kDenoiseTaps];
    float cosTurn[kTurns], sinTurn[kTurns];
    Taps() {
        for (int t = 0; t < kTurns; ++t) {
            cosTurn[t] = std::cos(6.28318531f * static_cast<float>(t) / kTurns);
            sinTurn[t] = std::sin(6.28318531f * static_cast<float>(t) / kTurns);
        }
        for (int k = 0; k < kDenoiseTaps; ++k) {
            const float r = std::sqrt((static_cast<float>(k) + 0.5f) / kDenoiseTaps);
            const float angle = static_cast<float>(k) * 2.39996323f;  // the golden angle
            x[k] = r * std::cos(angle);
            y[k] = r * std::sin(angle);
            weight[k] = std::exp(-2.0f * r * r);
        }
    }
};

constexpr float kNormalStop = 0.9063078f;  // cos 25°

/// What a tap reads of a pixel besides its value, in one 32-byte record: its point, its
/// normal, and its weight (0 where the filter must not read it: no hit, or the light does
/// not reach it).
struct TapPixel {
    Vec3 p;
    float weight;
    Vec3 n;
    float footprint;
};

/// One pass over rows [y0, y1): in → out where `radius` (per pixel; < 0: keep) says so.
void FilterPass(const DenoiseFrame& f, const std::vector<TapPixel>& px, const float* in,
                const std::vector<float>& radius, float scale, int pass, int y0, int y1, float* out) {
    static const Taps taps;
    const int w = f.width, h = f.height;
    ParallelFor(tbb::blocked_range<int>(y0, y1, 4), [&](const tbb::blocked_range<int>& rows) {
        for (int y = rows.begin(); y != rows.end(); ++y)
            for (int x = 0; x < w; ++x) {
                const size_t i = f.Index(x, y);
                float* o = out + static_cast<size_t>(y - y0) * static_cast<size_t>(w) + static_cast<size_t>(x);
                const float r = radius[i] * scale;
                if (radius[i] < 0) {
                    *o = in[i];
                    continue;
                }
                const TapPixel& c = px[i];
                const Vec3 p = c.p, n = c.n;
                const float tol = 2.0f * c.footprint;
                float num = c.weight * in[i], den = c.weight;
                const int turn = TapTurn(x, y + f.y0, pass);
                const float c0 = taps.cosTurn[turn], s0 = taps.sinTurn[turn];
                for (int k = 0; k < kDenoiseTaps; ++k) {
                    const float dx = (taps.x[k] * c0 - taps.y[k] * s0) * r, dy = (taps.y[k] * c0 + taps.x[k] * s0) * r;
                    const int qx = x + static_cast<int>(std::floor(dx + 0.5f)), qy = y + static_cast<int>(std::floor(dy + 0.5f));
                    if (qx < 0 || qx >= w || qy < 0 || qy >= h) continue;
                    const size_t q = f.Index(qx, qy);
                    const TapPixel& t = px[q];
                    if (t.weight <= 0) continue;
                    if (Dot(n, t.n) < kNormalStop) continue;
                    // On the pixel's plane: |n·d| <= tol + 0.02·|d|, without the square root.
                    const Vec3 d = t.p - p;
                    const float off = std::abs(Dot(n, d)) - tol;
                    if (off > 0 && off * off > 0.0004f * LengthSquared(d)) continue;
                    const float wq = t.weight;
                    const float kw = taps.weight[k] * wq;
                    num += kw * in[q];
                    den += kw;
                }
                *o = den > 0 ? std::clamp(num / den, 0.0f, 1.0f) : in[i];
            }
    });
}

}  // namespace

void FilterShadowLayer(const DenoiseFrame& f, const DenoiseLayer& layer, int outY0, int outY1, float* out,
                       float scale) {
    const int w = f.width, h = f.height, B = kDenoiseBlock;
    if (w <= 0 || h <= 0 || outY0 >= outY1) return;
    // Blocks on the image's grid: block row of region row y is (y + y0) / B.
    const int firstBlockRow = f.y0 / B, blockRows = (f.y0 + h - 1) / B - firstBlockRow + 1;
    const int blockCols = (w + B - 1) / B;
    struct Block {
        bool lit = false, dark = false, partial = false;
        float penumbraSum = 0;
        int penumbraCount = 0;
    };
    std::vector<Block> blocks(static_cast<size_t>(blockRows) * static_cast<size_t>(blockCols));
    ParallelFor(tbb::blocked_range<int>(0, blockRows, 1), [&](const tbb::blocked_range<int>& rows) {
        for (int by = rows.begin(); by != rows.end(); ++by) {
            const int ya = std::max(0, (firstBlockRow + by) * B - f.y0), yb = std::min(h, (firstBlockRow + by + 1) * B - f.y0);
            for (int bx = 0; bx < blockCols; ++bx) {
                Block& b = blocks[static_cast<size_t>(by) * static_cast<size_t>(blockCols) + static_cast<size_t>(bx)];
                for (int y = ya; y < yb; ++y)
                    for (int x = bx * B; x < std::min(w, bx * B + B); ++x) {
                        const size_t i = f.Index(x, y);
                        if (layer.weight[i] <= 0) continue;
                        const float v = layer.visibility[i];
                        b.lit |= v == 1.0f;
                        b.dark |= v == 0.0f;
                        b.partial |= v > 0.0f && v < 1.0f;
                        if (layer.penumbra[i] >= 0) {
                            b.penumbraSum += layer.penumbra[i];
                            ++b.penumbraCount;
                        }
                    }
            }
        }
    });
    // Per pixel: the footprint's radius, or −1 to keep the pixel. Needed for the rows the
    // second pass reads: outY0 − the widest footprint .. outY1 + it.
    const int reach = static_cast<int>(kDenoiseMaxRadius) + 1;
    const int ry0 = std::max(0, outY0 - reach), ry1 = std::min(h, outY1 + reach);
    std::vector<float> radius(static_cast<size_t>(w) * static_cast<size_t>(h), -1.0f);
    ParallelFor(tbb::blocked_range<int>(ry0, ry1, 8), [&](const tbb::blocked_range<int>& rows) {
        for (int y = rows.begin(); y != rows.end(); ++y) {
            const int by = (y + f.y0) / B - firstBlockRow;
            for (int x = 0; x < w; ++x) {
                const size_t i = f.Index(x, y);
                if (layer.weight[i] <= 0 || f.footprint[i] <= 0) continue;
                const int bx = x / B;
                bool mixed = false;
                float sum = 0;
                int count = 0;
                for (int j = std::max(0, by - 1); j <= std::min(blockRows - 1, by + 1); ++j)
                    for (int k = std::max(0, bx - 1); k <= std::min(blockCols - 1, bx + 1); ++k) {
                        const Block& b = blocks[static_cast<size_t>(j) * static_cast<size_t>(blockCols) + static_cast<size_t>(k)];
                        mixed |= b.partial || (b.lit && b.dark);
                        sum += b.penumbraSum;
                        count += b.penumbraCount;
                    }
                if (!mixed || count == 0) continue;
                // The neighbourhood's mean, halfway to the pixel's own estimate where it has one
                // (contact shadows beside wide penumbrae keep more of their edge).
                float r = sum / static_cast<float>(count);
                if (layer.penumbra[i] >= 0) r = 0.5f * (r + layer.penumbra[i]);
                r = std::min(r * scale, kDenoiseMaxRadius);
                // At least min(2r, kDenoiseMinRadius): a footprint under about a pixel and a half
                // averages the pixel with hardly any neighbour (pass 2's taps, at r/2, round to
                // the pixel itself), so thin penumbrae, and the dappled shadows of leaves
                // (blockers a few metres up, penumbrae a pixel wide), kept their noise.
                r = std::max(r, std::min(2.0f * r, kDenoiseMinRadius));
                if (r >= 0.5f) radius[i] = r;
            }
        }
    });
    // The taps' records of the rows the passes read (pass 1 reads up to the widest
    // footprint beyond its rows).
    const int py0 = std::max(0, ry0 - reach), py1 = std::min(h, ry1 + reach);
    std::vector<TapPixel> px(static_cast<size_t>(w) * static_cast<size_t>(h));
    ParallelFor(tbb::blocked_range<int>(py0, py1, 16), [&](const tbb::blocked_range<int>& rows) {
        for (int y = rows.begin(); y != rows.end(); ++y)
            for (int x = 0; x < w; ++x) {
                const size_t i = f.Index(x, y);
                const bool readable = layer.weight[i] > 0 && f.footprint[i] > 0;
                px[i] = TapPixel{f.position[i], readable ? layer.weight[i] : 0.0f, f.normal[i], f.footprint[i]};
            }
    });
    // Pass 1 over the rows pass 2 reads, pass 2 over the output rows.
    std::vector<float> first(static_cast<size_t>(w) * static_cast<size_t>(h));
    std::copy(layer.visibility.begin(), layer.visibility.end(), first.begin());
    FilterPass(f, px, layer.visibility.data(), radius, 1.0f, 0, ry0, ry1,
               first.data() + static_cast<size_t>(ry0) * static_cast<size_t>(w));
    FilterPass(f, px, first.data(), radius, 0.5f, 1, outY0, outY1, out);
}

ShadowDenoiser::ShadowDenoiser(const Scene& scene, const Accelerator& accel, const WhittedRenderer& renderer,
                               const RenderOptions& options, std::vector<float> radii)
    : scene_(scene), accel_(accel), renderer_(renderer), options_(options), radii_(std::move(radii)) {
    ValidateAreaLightOptions(options.areaLight);
    if (radii_.size() != scene.lights.size())
        ThrowError("denoised shadows: %zu radii for %zu lights", radii_.size(), scene.lights.size());
    pixelAngle_ = 2.0f * std::tan(0.5f * scene.camera.fovY * Pi / 180.0f) / static_cast<float>(options.height);
}

namespace {

/// The visibility image's rows [y0, y1): 0 for every light where some camera ray of the
/// pixel hit the scene (hit: the rows' pixels), NaN elsewhere.
void ClearVisibilityRows(const uint8_t* hit, int y0, int y1, VisibilityImage* visibility) {
    const int width = visibility->width;
    for (int y = y0; y < y1; ++y)
        for (int x = 0; x < width; ++x)
            std::fill_n(visibility->At(x, y), visibility->lights,
                        hit[static_cast<size_t>(y - y0) * width + x] ? 0.0f : std::numeric_limits<float>::quiet_NaN());
}

/// Light `light`'s filtered values (of rows [y0, y1)) into the visibility image where it
/// reaches the pixel (its weight > 0); it stays 0 elsewhere, as the image leaves its term out.
void SetVisibilityRows(size_t light, const float* weight, const float* filtered, int y0, int y1,
                       VisibilityImage* visibility) {
    const int width = visibility->width;
    for (int y = y0; y < y1; ++y)
        for (int x = 0; x < width; ++x) {
            const size_t k = static_cast<size_t>(y - y0) * width + x;
            if (weight[k] > 0) visibility->At(x, y)[light] = filtered[k];
        }
}

}  // namespace

size_t ShadowDenoiser::BytesPerPixel() const {
    // The frame (point, normal, footprint), the rest of the shading, then per light its
    // unshadowed term, visibility, weight and penumbra; the filter's radius and pass
    // buffers and the output, per light in turn.
    return sizeof(Vec3) * 2 + sizeof(float) + sizeof(Color) + scene_.lights.size() * (sizeof(Color) + 3 * sizeof(float)) +
           3 * sizeof(float);
}

void ShadowDenoiser::RenderRows(int y0, int y1, Image* image, RenderCounters& counters, ProgressReporter* progress,
                                VisibilityImage* visibility) const {
    const int width = options_.width, height = options_.height, aa = options_.aa, T = WhittedRenderer::kTileSize;
    y0 = std::clamp(y0, 0, height);
    y1 = std::clamp(y1, y0, height);
    if (y0 == y1) return;
    const int ry0 = std::max(0, y0 - kDenoiseApron), ry1 = std::min(height, y1 + kDenoiseApron);
    const size_t pixels = static_cast<size_t>(width) * static_cast<size_t>(ry1 - ry0);
    const size_t lights = scene_.lights.size();
    const uint64_t need = static_cast<uint64_t>(pixels) * BytesPerPixel();
    if (need > PhysicalMemoryBytes() / 2)
        ThrowErrorAt({scene_.name},
                     "--shadows denoised: its buffers for %dx%d pixels and %zu light%s would need %s, more than half "
                     "the memory budget (%s); render a smaller image or fewer lights",
                     width, ry1 - ry0, lights, lights == 1 ? "" : "s", FormatBytes(need).c_str(),
                     FormatBytes(PhysicalMemoryBytes()).c_str());

    DenoiseFrame frame;
    frame.width = width;
    frame.height = ry1 - ry0;
    frame.y0 = ry0;
    frame.position.assign(pixels, Vec3());
    frame.normal.assign(pixels, Vec3());
    frame.footprint.assign(pixels, 0.0f);
    std::vector<Color> rest(pixels), omega(pixels * lights);
    // With a visibility image: the pixels some camera ray of which hit the scene.
    std::vector<uint8_t> hitPixel(visibility ? pixels : 0, 0);
    std::vector<DenoiseLayer> layers(lights);
    for (DenoiseLayer& l : layers) {
        l.visibility.assign(pixels, 1.0f);
        l.weight.assign(pixels, 0.0f);
        l.penumbra.assign(pixels, -1.0f);
    }

    // The noisy pass: tiles of the region (aligned with the image's: the apron is whole tiles).
    const int tilesX = (width + T - 1) / T, tilesY = (ry1 - ry0 + T - 1) / T;
    std::vector<RenderCounters> tileCounters(static_cast<size_t>(tilesX) * static_cast<size_t>(tilesY));
    const int samples = options_.areaLight.samples;
    const float inv = 1.0f / static_cast<float>(aa * aa);
    ParallelFor(tbb::blocked_range<int>(0, tilesX * tilesY, 1), [&](const tbb::blocked_range<int>& range) {
        std::vector<Ray> rays;
        std::vector<Hit> hits;
        std::vector<Ray> shadow(static_cast<size_t>(samples));
        std::vector<Hit> blockers(static_cast<size_t>(samples));
        // Per light, as long as the task: the hit's terms and its pixel's sums.
        std::vector<Color> omegaBuf(lights), omegaSum(lights);
        std::vector<uint32_t> litIds(lights);
        std::vector<float> num(lights), den(lights), penSum(lights);
        std::vector<int> penCount(lights);
        // The lights some hit of the pixel needs (each once: inPixel marks them); the sums
        // of the others stay 0, and their entries of omega and the layers keep their
        // initial values, which are what the sums would give.
        std::vector<uint32_t> pixelLights;
        std::vector<uint8_t> inPixel(lights, 0);
        for (int t = range.begin(); t != range.end(); ++t) {
            RenderCounters& c = tileCounters[static_cast<size_t>(t)];
            const int tx0 = (t % tilesX) * T, ty0 = ry0 + (t / tilesX) * T;
            const int tx1 = std::min(tx0 + T, width), ty1 = std::min(ty0 + T, ry1);
            // The camera rays of kPacketSize² pixels at a time, as RenderTile traces them.
            constexpr int P = WhittedRenderer::kPacketSize;
            for (int by = ty0; by < ty1; by += P)
                for (int bx = tx0; bx < tx1; bx += P) {
                    const int ex = std::min(bx + P, tx1), ey = std::min(by + P, ty1);
                    rays.clear();
                    for (int y = by; y < ey; ++y)
                        for (int x = bx; x < ex; ++x)
                            for (int sy = 0; sy < aa; ++sy)
                                for (int sx = 0; sx < aa; ++sx) rays.push_back(renderer_.CameraRay(x, y, sx, sy));
                    hits.resize(rays.size());
                    accel_.IntersectMany(rays.data(), rays.size(), hits.data());
                    c.cameraRays += rays.size();
                    size_t first = 0;
                    for (int y = by; y < ey; ++y)
                        for (int x = bx; x < ex; ++x, first += static_cast<size_t>(aa * aa)) {
                            const size_t i = frame.Index(x, y - ry0);
                            Color restSum;
                            // Per light the pixel's hits need: Σ V·w, Σ w, Σ penumbra and its
                            // count, and Σ omega, cleared when the light first turns up.
                            pixelLights.clear();
                            int hitCount = 0;
                            for (size_t s = first; s < first + static_cast<size_t>(aa * aa); ++s) {
                                if (hits[s].prim == UINT32_MAX) {
                                    restSum += scene_.background;
                                    continue;
                                }
                                ++hitCount;
                                Color r;
                                uint32_t litCount = 0;
                                const ShadingPoint sp = renderer_.ShadeSplit(rays[s], hits[s], omegaBuf.data(), litIds.data(), &litCount, &r, c);
                                restSum += r;
                                const float footprint = hits[s].t * pixelAngle_;
                                if (s == first) {
                                    frame.position[i] = sp.p;
                                    frame.normal[i] = sp.n;
                                    frame.footprint[i] = footprint;
                                }
                                for (uint32_t k = 0; k < litCount; ++k) {
                                    const uint32_t l = litIds[k];
                                    if (!inPixel[l]) {
                                        inPixel[l] = 1;
                                        pixelLights.push_back(l);
                                        num[l] = den[l] = penSum[l] = 0.0f;
                                        penCount[l] = 0;
                                        omegaSum[l] = Color();
                                    }
                                    float penumbra = -1;
                                    const float v = NoisyVisibility(sp, l, footprint, shadow.data(), blockers.data(), &penumbra, c);
                                    if (penumbra >= 0) {
                                        penSum[l] += penumbra;
                                        ++penCount[l];
                                    }
                                    const float wgt = Luminance(omegaBuf[k]);
                                    num[l] += v * wgt;
                                    den[l] += wgt;
                                    omegaSum[l] += omegaBuf[k];
                                }
                            }
                            rest[i] = restSum * inv;
                            if (visibility) hitPixel[i] = hitCount > 0;
                            for (const uint32_t l : pixelLights) {
                                inPixel[l] = 0;
                                omega[l * pixels + i] = omegaSum[l] * inv;
                                if (den[l] > 0) {
                                    layers[l].visibility[i] = std::clamp(num[l] / den[l], 0.0f, 1.0f);
                                    layers[l].weight[i] = den[l] * inv;
                                }
                                if (penCount[l]) layers[l].penumbra[i] = penSum[l] / static_cast<float>(penCount[l]);
                            }
                        }
                }
            if (progress && ty0 >= y0 && ty0 < y1) progress->Update(1);
        }
    });
    for (const RenderCounters& c : tileCounters) counters += c;

    // The filter, light by light; the image is the rest plus each light's term times its
    // filtered visibility, the lights added in order.
    const int oy0 = y0 - ry0, oy1 = y1 - ry0;
    // Less noise to remove, less blur: the footprint shrinks like the noise, 1/√N.
    const float footprintScale = 1.0f / std::sqrt(static_cast<float>(samples));
    const size_t outPixels = static_cast<size_t>(width) * static_cast<size_t>(y1 - y0);
    std::vector<Color> sum(rest.begin() + static_cast<ptrdiff_t>(static_cast<size_t>(oy0) * width),
                           rest.begin() + static_cast<ptrdiff_t>(static_cast<size_t>(oy1) * width));
    std::vector<float> filtered(outPixels);
    if (visibility) ClearVisibilityRows(hitPixel.data() + static_cast<size_t>(oy0) * width, y0, y1, visibility);
    for (size_t l = 0; l < lights; ++l) {
        const DenoiseLayer& layer = layers[l];
        if (std::all_of(layer.weight.begin(), layer.weight.end(), [](float w) { return w <= 0; })) continue;
        FilterShadowLayer(frame, layer, oy0, oy1, filtered.data(), footprintScale);
        const Color* om = omega.data() + l * pixels + static_cast<size_t>(oy0) * width;
        for (size_t k = 0; k < outPixels; ++k)
            if (layer.weight[static_cast<size_t>(oy0) * width + k] > 0) sum[k] += om[k] * filtered[k];
        if (visibility)
            SetVisibilityRows(l, layer.weight.data() + static_cast<size_t>(oy0) * width, filtered.data(), y0, y1, visibility);
    }
    for (int y = y0; y < y1; ++y)
        for (int x = 0; x < width; ++x) image->At(x, y) = sum[static_cast<size_t>(y - y0) * width + x];
}

float ShadowDenoiser::NoisyVisibility(const ShadingPoint& sp, size_t light, float footprint, Ray* rays, Hit* hits,
                                      float* penumbra, RenderCounters& counters) const {
    const Vec3& center = scene_.lights[light].position;
    const float R = radii_[light];
    if (R == 0) {  // a point light: rt's ray
        ++counters.shadowRays;
        return LightVisible(accel_, sp.origin, center) ? 1.0f : 0.0f;
    }
    const int samples = options_.areaLight.samples;
    const SphereLightRays sampler(sp.origin, center, R, samples, AreaLightSeed(sp, static_cast<uint32_t>(light), options_.areaLight.stream));
    if (sampler.Inside()) return 1.0f;
    for (int k = 0; k < samples; ++k) rays[k] = sampler.Get(k);
    // Closest hits, not just occlusion: the blockers' distance sizes the filter.
    accel_.IntersectMany(rays, static_cast<size_t>(samples), hits);
    counters.shadowRays += static_cast<uint64_t>(samples);
    int visible = 0, blocked = 0;
    float blockerSum = 0;
    for (int k = 0; k < samples; ++k) {
        if (hits[k].prim == UINT32_MAX) {
            ++visible;
        } else {
            ++blocked;
            blockerSum += hits[k].t * Length(rays[k].d);
        }
    }
    if (blocked && footprint > 0) {
        // The penumbra's half width on the receiver, R·b/(d − b), in pixels there.
        const float b = blockerSum / static_cast<float>(blocked);
        const float d = Length(center - sp.origin);
        *penumbra = R * b / std::max(d - b, 1e-6f * d) / footprint;
    }
    return static_cast<float>(visible) / static_cast<float>(samples);
}


}  // namespace lm
