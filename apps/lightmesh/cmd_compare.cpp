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
        std::printf("%s vs %s: %s pixels: PSNR %s, SSIM %.5f, RMSE %.5f (linear %.5f), max diff %.4f\n",
                    cmd.a.c_str(), cmd.b.c_str(), Count(q.pixels).c_str(), psnr.c_str(), q.ssim, q.rmse,
                    q.rmseLinear, q.maxDiff);
        if (totals)
            std::printf("shadow total: A %.6g, B %.6g, B / A %s\n", totals->first, totals->second,
                        totals->first != 0 ? lm::StringPrintf("%.4f", totals->second / totals->first).c_str() : "-");
    }
    if (cmd.thresholdPsnr && q.psnr < *cmd.thresholdPsnr) {
        std::fprintf(stderr, "lightmesh: PSNR %s is below the threshold %.2f dB\n", psnr.c_str(), *cmd.thresholdPsnr);
        return 3;
    }
    return 0;
}

}  // namespace lm::cli
