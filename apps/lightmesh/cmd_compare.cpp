// cmd_compare.cpp -- `lightmesh compare`.
#include "commands.h"

#include <cmath>
#include <optional>
#include <utility>

#include "lightmesh/io/compare.h"
#include "lightmesh/io/image.h"
#include "lightmesh/util/log.h"

namespace lm::cli {

int RunCompare(const CompareCommand& cmd) {
    if (cmd.thresholdPsnr && !std::isfinite(*cmd.thresholdPsnr))
        lm::ThrowError("--threshold-psnr: must be a finite number of dB, got %g", *cmd.thresholdPsnr);
    if (!(cmd.diffScale >= 0) || !std::isfinite(cmd.diffScale))
        lm::ThrowError("--diff-scale: must be a finite number >= 0, got %g", double(cmd.diffScale));
    if (cmd.diffScaleGiven && cmd.diff.empty()) lm::LogWarning("--diff-scale is used only with --diff; ignored");
    // What the comparison will take, from the images' heads, before anything is decoded
    // (decoding two 16384² PNGs first reaches the OOM killer at 24 GB).
    const lm::ImageSize sa = lm::ReadImageSize(cmd.a), sb = lm::ReadImageSize(cmd.b);
    if (sa.width != sb.width || sa.height != sb.height)
        lm::ThrowError("%s is %dx%d and %s is %dx%d: images of different sizes cannot be compared",
                       cmd.a.c_str(), sa.width, sa.height, cmd.b.c_str(), sb.width, sb.height);
    if (!cmd.mask.empty()) {
        const lm::ImageSize sm = lm::ReadImageSize(cmd.mask);
        if (sm.width != sa.width || sm.height != sa.height)
            lm::ThrowError("--mask %s is %dx%d and the images are %dx%d: the mask needs their size", cmd.mask.c_str(),
                           sm.width, sm.height, sa.width, sa.height);
    }
    if (!cmd.none.empty()) {
        const lm::ImageSize sn = lm::ReadImageSize(cmd.none);
        if (sn.width != sa.width || sn.height != sa.height)
            lm::ThrowError("--no-shadows %s is %dx%d and the images are %dx%d: the shadow totals need one size",
                           cmd.none.c_str(), sn.width, sn.height, sa.width, sa.height);
    }
    const uint64_t pixels = static_cast<uint64_t>(sa.width) * static_cast<uint64_t>(sa.height);
    const int images = 2 + (cmd.mask.empty() ? 0 : 1) + (cmd.none.empty() ? 0 : 1);
    const uint64_t need = lm::CompareBytes(pixels, images), budget = lm::PhysicalMemoryBytes();
    if (budget && need > budget / 2)
        lm::ThrowError("%s and %s are %dx%d (%s pixels): comparing them takes about %s (%s a pixel), more than half "
                       "of the %s this process may use (LIGHTMESH_MEMORY_LIMIT)",
                       cmd.a.c_str(), cmd.b.c_str(), sa.width, sa.height, Count(pixels).c_str(),
                       lm::FormatBytes(need).c_str(), lm::FormatBytes(need / std::max<uint64_t>(pixels, 1)).c_str(),
                       lm::FormatBytes(budget).c_str());
    // The user's images are read in a child process (a malformed EXR must not crash us).
    const lm::Image a = lm::ReadImageIsolated(cmd.a), b = lm::ReadImageIsolated(cmd.b);
    std::optional<lm::Image> mask;
    if (!cmd.mask.empty()) mask = lm::ReadImageIsolated(cmd.mask);
    const lm::Image* m = mask ? &*mask : nullptr;
    const lm::ImageMetrics q = lm::CompareImages(a, b, m);
    // The shadow totals over the whole images (the mask does not apply to them).
    std::optional<std::pair<double, double>> totals;
    if (!cmd.none.empty()) {
        const lm::Image none = lm::ReadImageIsolated(cmd.none);
        totals = {lm::ShadowTotal(none, a), lm::ShadowTotal(none, b)};
    }
    if (!cmd.diff.empty()) lm::WriteDiffImage(cmd.diff, a, b, cmd.diffScale, m);
    const std::string psnr = std::isinf(q.psnr) ? "inf" : lm::StringPrintf("%.2f dB", q.psnr);
    if (cmd.json) {
        std::string line = lm::ImageMetricsJson(q, cmd.a, cmd.b);
        if (totals) {
            line.pop_back();
            line += lm::StringPrintf(",\"shadow_total_a\":%.9g,\"shadow_total_b\":%.9g}", totals->first, totals->second);
        }
        std::printf("%s\n", line.c_str());
    } else {
        std::printf("%s vs %s: %s pixels: PSNR %s, SSIM %.5f, RMSE %.5f (linear %.5f), max diff %.4f%s\n",
                    cmd.a.c_str(), cmd.b.c_str(), Count(q.pixels).c_str(), psnr.c_str(), q.ssim, q.rmse,
                    q.rmseLinear, q.maxDiff,
                    q.nonFiniteA || q.nonFiniteB
                        ? lm::StringPrintf("; left out: %s pixels NaN or infinite in A, %s in B",
                                           Count(q.nonFiniteA).c_str(), Count(q.nonFiniteB).c_str())
                              .c_str()
                        : "");
        if (totals)
            std::printf("shadow total: A %.6g, B %.6g, B / A %s\n", totals->first, totals->second,
                        totals->first != 0 ? lm::StringPrintf("%.4f", totals->second / totals->first).c_str() : "-");
    }
    if (cmd.thresholdPsnr && q.psnr < *cmd.thresholdPsnr) {
        std::fprintf(stderr, "lightmesh: PSNR %s is below the threshold %.2f dB\n", psnr.c_str(), *cmd.thresholdPsnr);
        return 3;
    }
    // A judged image with NaN or infinite pixels where the reference has numbers fails.
    if (cmd.thresholdPsnr && q.nonFiniteOnlyInB > 0) {
        std::fprintf(stderr, "lightmesh: %s has %s NaN or infinite pixels where %s has numbers: below any threshold\n",
                     cmd.b.c_str(), Count(q.nonFiniteOnlyInB).c_str(), cmd.a.c_str());
        return 3;
    }
    return 0;
}

}  // namespace lm::cli
