// cmd_compare.cpp -- `lightmesh compare`.
#include "commands.h"

#include <cmath>

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
    if (!cmd.diff.empty()) lm::WriteDiffImage(cmd.diff, a, b, cmd.diffScale, m);
    const std::string psnr = std::isinf(q.psnr) ? "inf" : lm::StringPrintf("%.2f dB", q.psnr);
    if (cmd.json)
        std::printf("%s\n", lm::ImageMetricsJson(q, cmd.a, cmd.b).c_str());
    else
        std::printf("%s vs %s: %s pixels: PSNR %s, SSIM %.5f, RMSE %.5f (linear %.5f), max diff %.4f\n",
                    cmd.a.c_str(), cmd.b.c_str(), Count(q.pixels).c_str(), psnr.c_str(), q.ssim, q.rmse,
                    q.rmseLinear, q.maxDiff);
    if (cmd.thresholdPsnr && q.psnr < *cmd.thresholdPsnr) {
        std::fprintf(stderr, "lightmesh: PSNR %s is below the threshold %.2f dB\n", psnr.c_str(), *cmd.thresholdPsnr);
        return 3;
    }
    return 0;
}

}  // namespace lm::cli
