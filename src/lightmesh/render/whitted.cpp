#include "lightmesh/render/whitted.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <vector>

#include "lightmesh/geometry/shadow_terminator.h"
#include "lightmesh/geometry/triangle.h"
#include "lightmesh/render/texturing.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/parallel.h"
#include "lightmesh/util/progress.h"

namespace lm {

WhittedRenderer::WhittedRenderer(const Scene& scene, const Accelerator& accel,
                                 const ShadowMethod& shadows, const RenderOptions& options)
    : scene_(scene), accel_(accel), shadows_(shadows), options_(options),
      camera_(scene.camera, options.width, options.height), lightLists_(scene.lights, scene.mesh.Bounds()),
      lightTerms_(scene.lights) {
    if (const float error = ResolvedLightCutError(options.lightCut, std::string(shadows.Name()), scene.lights); error > 0)
        cuts_ = std::make_unique<LightCuts>(scene.lights, lightTerms_, error);
    if (options.aa < 1 || options.aa > 16) ThrowError("--aa %d: must be 1 to 16", options.aa);
    if (options.maxDepth < 1 || options.maxDepth > 64)
        ThrowError("max depth %d: must be 1 to 64", options.maxDepth);
    spread_ = 2.0f * std::tan(0.5f * scene.camera.fovY * Pi / 180.0f) / static_cast<float>(options.height * options.aa);
}

ShadingPoint WhittedRenderer::MakeShadingPoint(const TriangleMesh& mesh, const Ray& ray, const Hit& hit,
                                               Vec3* shadingNormal) {
    // A flat triangle's vertices read in place; an instanced one's computed.
    const bool flat = hit.prim < mesh.TriangleCount();
    Vec3 placed[3];
    if (!flat) mesh.Corners(hit.prim, placed);
    const Vec3 &p0 = flat ? mesh.Vertex(hit.prim, 0) : placed[0], &p1 = flat ? mesh.Vertex(hit.prim, 1) : placed[1],
               &p2 = flat ? mesh.Vertex(hit.prim, 2) : placed[2];
    const float b0 = 1.0f - hit.b1 - hit.b2;
    ShadingPoint sp;
    sp.prim = hit.prim;
    // The point from barycentrics is accurate to a few ulps of the vertices, unlike
    // o + t·d, whose error grows with the ray's length (pbrt-v4 §6.8).
    sp.p = p0 * b0 + p1 * hit.b1 + p2 * hit.b2;
    Vec3 n = UnitTriangleNormal(p0, p1, p2);
    if (Dot(n, ray.d) > 0) n = -n;
    sp.n = n;
    // Shading normal: interpolated vertex normals when the mesh has them, on the same side
    // as the geometric normal.
    Vec3 ns = n, lifted = sp.p;
    if (Vec3 vn[3]; mesh.ShadingNormals(hit.prim, vn)) {
        const Vec3 interp = vn[0] * b0 + vn[1] * hit.b1 + vn[2] * hit.b2;
        if (LengthSquared(interp) > 0 && IsFinite(interp)) {
            ns = Normalize(interp);
            const float side = Dot(ns, n) < 0 ? -1.0f : 1.0f;
            ns = ns * side;
            // Rays leave the smooth surface the normals describe, not the facet (Hanika's
            // shadow terminator fix; geometry/shadow_terminator.h).
            const Vec3 corner[3] = {p0, p1, p2};
            const float b[3] = {b0, hit.b1, hit.b2};
            lifted = LiftToShadingPlanes(sp.p, b, corner, vn, side);
        }
    }
    if (shadingNormal) *shadingNormal = ns;
    // Push the origin off the surface so rays leaving it never hit its own triangle.
    sp.origin = lifted + n * SurfaceOffset(p0, p1, p2);
    return sp;
}

Color WhittedRenderer::Li(const Ray& ray, int depth, RenderCounters& counters) const {
    Hit hit;
    if (!accel_.Intersect(ray, &hit)) return scene_.background;
    return Shade(ray, hit, depth, counters);
}

void WhittedRenderer::PrepareShading(const Ray& ray, const Hit& hit, Lighting* lit, RenderCounters& counters) const {
    ++counters.shadingPoints;
    const TriangleMesh& mesh = scene_.mesh;
    Vec3 ns;
    const ShadingPoint sp = MakeShadingPoint(mesh, ray, hit, &ns);
    const Material& mat = scene_.materials[mesh.MaterialOf(hit.prim)];
    const Vec3 toEye = Normalize(-ray.d);

    lit->sp = sp;
    lit->ns = ns;
    lit->mat = &mat;
    lit->kd = mat.texture < 0 ? mat.kd : TexturedDiffuse(scene_, mat, ray, hit, spread_);
    // The lights' terms, several at a time (LightTerms: the scalar formula's floats), in
    // ascending light order.
    // A light counts where the shading normal faces it: a smooth-shaded facet turned away
    // from a light its normals face is lit as the smooth surface is, and its shadow rays,
    // from the lifted origin, decide (a cut on the facet's own normal would end the lit side
    // along the facets' edges). Where the mesh has no normals, ns is the facet's normal.
    const LightTermPoint point{sp.p, ns, ns, toEye, lit->kd, mat.ks, mat.phong};
    if (cuts_) {  // the lights clustered under the cut's bound (its hierarchy knows their ranges)
        lit->litCount = cuts_->Cut(point, lit->omega, lit->lit);
        counters.cutEntries += lit->litCount;
        counters.cutLargest = std::max<uint64_t>(counters.cutLargest, lit->litCount);
        return;
    }
    if (!lightLists_.Active()) {
        lit->litCount = lightTerms_.All(point, lit->omega, lit->lit);
        return;
    }
    // Lights with a range: only those of the point's cell, merged in ascending order with
    // the lights without one (the terms add in light order), into lit->lit (room for every
    // light), whose entries LightTerms then overwrites with the lit ones.
    const std::span<const uint32_t> a = lightLists_.Everywhere(), b = lightLists_.Near(sp.p);
    const uint32_t* ids = a.empty() ? b.data() : a.data();
    if (!a.empty() && !b.empty()) {
        std::merge(a.begin(), a.end(), b.begin(), b.end(), lit->lit);
        ids = lit->lit;
    }
    lit->litCount = lightTerms_.Listed(point, ids, static_cast<uint32_t>(a.size() + b.size()), lit->omega, lit->lit);
}

namespace {

// sum + Σ omega[k]·vis[k], k < count, in that order, with Color's operations. Not inlined:
// inlined into RenderTile (a large function) the sum was kept in memory, a store and a
// load per light (18 % of a render at 1,024 lights without shadows, against 9 % apart).
[[gnu::noinline]] Color AddLights(Color sum, const Color* omega, const float* vis, uint32_t count) {
    for (uint32_t k = 0; k < count; ++k) sum += omega[k] * vis[k];
    return sum;
}

}  // namespace

Color WhittedRenderer::FinishShading(const Ray& ray, const Lighting& lit, const float* vis, int depth,
                                     RenderCounters& counters) const {
    const Material& mat = *lit.mat;
    Color result = AddLights(scene_.ambient * lit.kd, lit.omega, vis, lit.litCount);

    if (!mat.mirror.IsBlack() && depth + 1 < options_.maxDepth) {
        Vec3 r = Reflect(ray.d, lit.ns);
        // A shading normal can send the mirror ray below the surface; reflect about the
        // geometric normal instead then.
        if (Dot(r, lit.sp.n) <= 0) r = Reflect(ray.d, lit.sp.n);
        ++counters.reflectionRays;
        result += mat.mirror * Li(Ray{lit.sp.origin, r, 0.0f, Infinity}, depth + 1, counters);
    }
    return result;
}

Color WhittedRenderer::Shade(const Ray& ray, const Hit& hit, int depth, RenderCounters& counters) const {
    // The lights' terms on the stack up to kLocal lights, on the heap beyond.
    constexpr size_t kLocal = 64;
    const size_t nLights = scene_.lights.size();
    Color omegaLocal[kLocal];
    uint32_t idsLocal[kLocal];
    float visLocal[kLocal];
    std::unique_ptr<Color[]> omegaHeap;
    std::unique_ptr<uint32_t[]> idsHeap;
    std::unique_ptr<float[]> visHeap;
    Lighting lit;
    lit.omega = omegaLocal, lit.lit = idsLocal;
    float* vis = visLocal;
    if (nLights > kLocal) {
        omegaHeap.reset(new Color[nLights]), idsHeap.reset(new uint32_t[nLights]), visHeap.reset(new float[nLights]);
        lit.omega = omegaHeap.get(), lit.lit = idsHeap.get(), vis = visHeap.get();
    }
    PrepareShading(ray, hit, &lit, counters);
    if (lit.litCount) shadows_.Visibility(lit.sp, lit.Lights(), vis, counters);
    return FinishShading(ray, lit, vis, depth, counters);
}

ShadingPoint WhittedRenderer::ShadeSplit(const Ray& ray, const Hit& hit, Color* omega, uint32_t* litIds,
                                         uint32_t* litCount, Color* rest, RenderCounters& counters) const {
    Lighting lit;
    lit.omega = omega, lit.lit = litIds;
    PrepareShading(ray, hit, &lit, counters);
    Lighting unlit = lit;  // the same point without the lights' terms
    unlit.litCount = 0;
    *rest = FinishShading(ray, unlit, nullptr, 0, counters);
    *litCount = lit.litCount;
    return lit.sp;
}

Color WhittedRenderer::Pixel(int x, int y, RenderCounters& counters) const {
    const int aa = options_.aa;
    Color sum;
    for (int sy = 0; sy < aa; ++sy) {
        for (int sx = 0; sx < aa; ++sx) {
            ++counters.cameraRays;
            sum += Li(camera_.Generate(SubPixel(x, sx), SubPixel(y, sy)), 0, counters);
        }
    }
    return sum * (1.0f / static_cast<float>(aa * aa));
}

void WhittedRenderer::RenderTile(int tile, Image* image, RenderCounters& counters, int originX, int originY,
                                 VisibilityImage* visibility) const {
    const int w = options_.width, h = options_.height, tilesX = TilesX(), aa = options_.aa;
    const int x0 = (tile % tilesX) * kTileSize, y0 = (tile / tilesX) * kTileSize;
    const int x1 = std::min(x0 + kTileSize, w), y1 = std::min(y0 + kTileSize, h);
    // The camera rays of kPacketSize² pixels at a time, pixel by pixel and sub-pixel by
    // sub-pixel as Pixel() makes them, go to the back-end together (a packet on the grid
    // and on Embree); each gets the hit Intersect gives it alone, so the pixels are
    // Pixel()'s bit for bit.
    // The buffers live as long as the thread: a batch holds kShadingBatch × lights terms, so
    // a fresh batch per tile zero-filled 57 KiB each time at 64 lights (3 % of an RT render
    // on the gazebo). Every entry read is written first (PrepareShading fills what Finish reads).
    // A tile started on this thread while another waits in it (a nested TBB loop
    // stealing work) takes buffers of its own.
    thread_local TileBuffers threadBuffers;
    TileBuffers nested;
    TileBuffers& buffers = threadBuffers.inUse ? nested : threadBuffers;
    buffers.inUse = true;
    struct Release {
        TileBuffers& b;
        ~Release() { b.inUse = false; }
    } release{buffers};
    const size_t nLights = scene_.lights.size();
    buffers.Reserve(nLights);
    std::vector<Ray>& rays = buffers.rays;
    std::vector<Hit>& hits = buffers.hits;
    std::vector<Color>& colors = buffers.colors;
    std::vector<Lighting>& batch = buffers.batch;
    std::vector<ShadingPoint>& points = buffers.points;
    for (int by = y0; by < y1; by += kPacketSize)
        for (int bx = x0; bx < x1; bx += kPacketSize) {
            const int ex = std::min(bx + kPacketSize, x1), ey = std::min(by + kPacketSize, y1);
            rays.clear();
            for (int y = by; y < ey; ++y)
                for (int x = bx; x < ex; ++x)
                    for (int sy = 0; sy < aa; ++sy)
                        for (int sx = 0; sx < aa; ++sx)
                            rays.push_back(camera_.Generate(SubPixel(x, sx), SubPixel(y, sy)));
            hits.resize(rays.size());
            accel_.IntersectMany(rays.data(), rays.size(), hits.data());
            // The packet's pixels of the visibility image, accumulated sample by sample.
            const int packetW = ex - bx, perPixel = aa * aa;
            if (visibility) {
                buffers.pixelHits.assign(static_cast<size_t>(packetW * (ey - by)), 0);
                for (int y = by; y < ey; ++y)
                    for (int x = bx; x < ex; ++x) std::fill_n(visibility->At(x, y), nLights, 0.0f);
            }
            // Shading, kShadingBatch hits at a time: their lights' visibility for all of
            // them at once (ShadowMethod::VisibilityMany: hard shadows trace the batch's
            // rays to one light as a packet), then each hit's colour as Shade gives it.
            colors.resize(rays.size());
            for (size_t first = 0; first < rays.size(); first += kShadingBatch) {
                const size_t end = std::min(rays.size(), first + kShadingBatch);
                size_t count = 0, shaded = 0;  // hits; hits whose lights' visibility is needed
                for (size_t k = first; k < end; ++k) {
                    if (hits[k].prim == UINT32_MAX) continue;
                    Lighting& lit = batch[count];
                    PrepareShading(rays[k], hits[k], &lit, counters);
                    if (lit.litCount) {
                        points[shaded] = lit.sp;
                        buffers.lists[shaded] = lit.Lights();
                        buffers.visOut[shaded++] = buffers.Vis(count);
                    }
                    ++count;
                }
                if (shaded) shadows_.VisibilityMany(points.data(), buffers.lists.data(), buffers.visOut.data(), shaded, counters);
                if (visibility)
                    for (size_t k = first, j = 0; k < end; ++k) {
                        if (hits[k].prim == UINT32_MAX) continue;
                        const int p = static_cast<int>(k) / perPixel;
                        AddVisibility(visibility->At(bx + p % packetW, by + p / packetW), batch[j].lit, buffers.Vis(j),
                                      batch[j].litCount);
                        ++buffers.pixelHits[static_cast<size_t>(p)];
                        ++j;
                    }
                for (size_t k = first, j = 0; k < end; ++k) {
                    if (hits[k].prim == UINT32_MAX) {
                        colors[k] = scene_.background;
                        continue;
                    }
                    colors[k] = FinishShading(rays[k], batch[j], buffers.Vis(j), 0, counters);
                    ++j;
                }
            }
            size_t k = 0;
            for (int y = by; y < ey; ++y)
                for (int x = bx; x < ex; ++x) {
                    Color sum;
                    for (int s = 0; s < aa * aa; ++s, ++k) {
                        ++counters.cameraRays;
                        sum += colors[k];
                    }
                    image->At(x - originX, y - originY) = sum * (1.0f / static_cast<float>(aa * aa));
                    if (visibility)
                        FinishVisibility(visibility->At(x, y), nLights,
                                         buffers.pixelHits[static_cast<size_t>((y - by) * packetW + (x - bx))]);
                }
        }
}

double WhittedRenderer::EstimateSeconds(int samples, double maxSeconds) const {
    const int tiles = TileCount();
    const std::vector<int64_t> picked = SpreadOverGrid(TilesX(), tiles / TilesX(), std::max(samples, 1));
    const int n = static_cast<int>(picked.size());
    // Two interleaved halves timed apart, the faster one counted: a machine shared with
    // other work (a build beside the bench) spoils one half more often than both.
    auto time = [&](int parity) {
        const auto start = std::chrono::steady_clock::now();
        const int count = (n - parity + 1) / 2;
        std::atomic<int> done{0};
        ParallelFor(tbb::blocked_range<int>(0, count, 1), [&](const tbb::blocked_range<int>& range) {
            Image scratch(kTileSize, kTileSize);
            RenderCounters counters;
            for (int i = range.begin(); i != range.end(); ++i) {
                if (maxSeconds > 0 && done.load(std::memory_order_relaxed) > 0 &&
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > 0.5 * maxSeconds)
                    return;
                const int tile = static_cast<int>(picked[static_cast<size_t>(2 * i + parity)]);
                RenderTile(tile, &scratch, counters, (tile % TilesX()) * kTileSize, (tile / TilesX()) * kTileSize);
                done.fetch_add(1, std::memory_order_relaxed);
            }
        });
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / std::max(done.load(), 1);
    };
    const double perTile = n >= 2 ? std::min(time(0), time(1)) : time(0);
    return perTile * static_cast<double>(tiles);
}

RenderResult WhittedRenderer::Render(ProgressReporter* progress, VisibilityImage* visibility) const {
    if (visibility && (visibility->width != options_.width || visibility->height != options_.height ||
                       visibility->lights != scene_.lights.size()))
        ThrowError("visibility image %dx%d of %zu lights for a %dx%d render of %zu lights", visibility->width,
                   visibility->height, visibility->lights, options_.width, options_.height, scene_.lights.size());
    RenderResult result;
    result.image = Image(options_.width, options_.height);
    std::vector<RenderCounters> tileCounters(static_cast<size_t>(TileCount()));
    // With a progress reporter, a sample of tiles spread over the image goes first, so the
    // time estimate comes from the whole image and not from its first rows; each
    // tile is rendered once, wherever it comes, so the image is the same.
    std::vector<int64_t> sample;
    std::vector<char> sampled;
    if (progress) {
        sample = SpreadOverGrid(TilesX(), TileCount() / TilesX(), kEstimateTiles);
        sampled.assign(static_cast<size_t>(TileCount()), 0);
        for (const int64_t tile : sample) sampled[static_cast<size_t>(tile)] = 1;
        progress->BeginWork(static_cast<int64_t>(sample.size()), "tiles spread over the image");
    }
    const auto start = std::chrono::steady_clock::now();
    ParallelFor(tbb::blocked_range<int>(0, static_cast<int>(sample.size()), 1), [&](const tbb::blocked_range<int>& range) {
        for (int i = range.begin(); i != range.end() && !progress->Stopped(); ++i) {
            const int tile = static_cast<int>(sample[static_cast<size_t>(i)]);
            RenderTile(tile, &result.image, tileCounters[tile], 0, 0, visibility);
            progress->Update(1);
        }
    });
    ParallelFor(tbb::blocked_range<int>(0, TileCount(), 1), [&](const tbb::blocked_range<int>& range) {
        for (int tile = range.begin(); tile != range.end(); ++tile) {
            if (!sampled.empty() && (sampled[static_cast<size_t>(tile)] || progress->Stopped())) continue;
            RenderTile(tile, &result.image, tileCounters[tile], 0, 0, visibility);
            if (progress) progress->Update(1);
        }
    });
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    for (const RenderCounters& c : tileCounters) result.counters += c;
    return result;
}

}  // namespace lm
