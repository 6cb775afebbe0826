// tables.cpp -- the bench's Markdown and CSV: timing tables laid out like the paper's, the
// --quality tables (PSNR/SSIM, radius sweep, naive soft shadows, penumbra mode).
#include "lightmesh/bench/benchmark.h"
#include "lightmesh/bench/report_internal.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "lightmesh/shadow/light_mesh.h"
#include "lightmesh/shadow/light_mesh_counters.h"
#include "lightmesh/util/error.h"

namespace lm {

namespace {

const BenchResult* Find(const std::vector<BenchResult>& rs, const BenchResult& like, const std::string& variant,
                        int cc, float ki) {
    for (const BenchResult& r : rs)
        if (r.scene == like.scene && r.width == like.width && r.height == like.height && r.method == "lmm" &&
            r.variant == variant && r.cc == cc && r.ki == ki)
            return &r;
    return nullptr;
}

std::string Ratio(const BenchResult* a, const BenchResult* b) {
    if (!a || !b || !(b->median > 0)) return "–";
    return StringPrintf("%.2f", a->median / b->median);
}

}  // namespace

std::vector<const BenchResult*> SceneSizeGroups(const std::vector<BenchResult>& rs) {
    std::vector<const BenchResult*> groups;
    for (const BenchResult& r : rs) {
        bool seen = false;
        for (const BenchResult* g : groups) seen |= g->scene == r.scene && g->width == r.width && g->height == r.height;
        if (!seen) groups.push_back(&r);
    }
    return groups;
}

std::string BenchMarkdown(const std::vector<BenchResult>& rs) {
    std::string out;
    const std::vector<const BenchResult*> groups = SceneSizeGroups(rs);
    for (const BenchResult* g : groups) {
        std::vector<std::string> variants;
        std::vector<std::pair<int, float>> rows;
        const BenchResult *none = nullptr, *rt = nullptr;
        std::string rtLine;
        for (const BenchResult& r : rs) {
            if (r.scene != g->scene || r.width != g->width || r.height != g->height) continue;
            if (r.method == "none") none = &r;
            if (r.method == "rt") {
                if (!rt) rt = &r;
                rtLine += StringPrintf("%sRT (%s) %.3f s", rtLine.empty() ? "" : ", ", r.accel.c_str(), r.median);
            }
            if (r.method != "lmm") continue;
            if (std::find(variants.begin(), variants.end(), r.variant) == variants.end()) variants.push_back(r.variant);
            if (std::find(rows.begin(), rows.end(), std::pair{r.cc, r.ki}) == rows.end()) rows.push_back({r.cc, r.ki});
        }
        out += StringPrintf("### %s, %dx%d\n\n", g->scene.c_str(), g->width, g->height);
        if (none) out += StringPrintf("No shadows %.3f s; ", none->median);
        out += rtLine + StringPrintf(" (median of %zu runs after a warm-up).\n\n", g->seconds.size());
        for (const BenchResult& r : rs)
            if (r.method == "penumbra" && r.scene == g->scene && r.width == g->width && r.height == g->height)
                out += StringPrintf("Contact-hardening penumbrae (%s, light radius %.3g, thin check %s), CC %d kI %g: %.3f s%s.\n\n",
                                    r.variant.c_str(), r.lightRadius, r.thinCheck.c_str(), r.cc, r.ki, r.median,
                                    rt && rt->median > 0 ? StringPrintf(", %.2f× RT", r.median / rt->median).c_str() : "");
        // A (CC, kI) × variant table of one figure per cell.
        auto variantTable = [&](bool longNames, const char* format, auto&& value) {
            out += "| CC | kI |";
            for (const std::string& v : variants)
                out += " " + ParseLightMeshVariant(v).paperName + (longNames ? " (" + v + ")" : "") + " |";
            out += "\n|---|---|";
            for (size_t i = 0; i < variants.size(); ++i) out += "---|";
            out += "\n";
            for (auto [cc, ki] : rows) {
                out += StringPrintf("| %d | %g |", cc, ki);
                for (const std::string& v : variants) {
                    const BenchResult* r = Find(rs, *g, v, cc, ki);
                    out += r ? StringPrintf(format, value(*r)) : " – |";
                }
                out += "\n";
            }
        };
        // Seconds.
        variantTable(true, " %.3f |", [](const BenchResult& r) { return r.median; });
        // Ratios.
        out += "\nRatios (same run):\n\n| CC | kI |";
        for (const std::string& v : variants) out += " " + ParseLightMeshVariant(v).paperName + "/RT |";
        out += " Ш/Grid | У/Ш | СТ/ОТ | СТ/Нет |\n|---|---|";
        for (size_t i = 0; i < variants.size() + 4; ++i) out += "---|";
        out += "\n";
        for (auto [cc, ki] : rows) {
            out += StringPrintf("| %d | %g |", cc, ki);
            for (const std::string& v : variants) out += " " + Ratio(Find(rs, *g, v, cc, ki), rt) + " |";
            out += " " + Ratio(Find(rs, *g, "templates", cc, ki), Find(rs, *g, "grid", cc, ki)) + " |";
            out += " " + Ratio(Find(rs, *g, "reduced", cc, ki), Find(rs, *g, "templates", cc, ki)) + " |";
            out += " " + Ratio(Find(rs, *g, "inside", cc, ki), Find(rs, *g, "object", cc, ki)) + " |";
            out += " " + Ratio(Find(rs, *g, "inside", cc, ki), Find(rs, *g, "none", cc, ki)) + " |";
            out += "\n";
        }
        // The shadow work alone: what each method adds to the render without shadows.
        if (none && rt && rt->median > none->median) {
            out += "\nShadow part, (method - no shadows) / (RT - no shadows), same run:\n\n";
            variantTable(false, " %.2f |", [&](const BenchResult& r) {
                return (r.median - none->median) / (rt->median - none->median);
            });
        }
        out += "\n";
    }
    return out;
}

std::string BenchCsv(const std::vector<BenchResult>& rs) {
    std::string out =
        "scene,width,height,method,variant,paper_name,accel,cc,ki,median_s,runs_s,setup_s,camera_rays,shadow_rays,"
        "reflection_rays,local_segments,interpolations,mean_m,fallbacks,nodes_evaluated,peak_memory_bytes,image,"
        "uniform_cell_points,culled_segments,light_radius,penumbra_lights,patch_segments,thin_check,thin_checks,"
        "thin_found\n";
    for (const BenchResult& r : rs) {
        std::string runs;
        for (double s : r.seconds) runs += StringPrintf("%s%.4f", runs.empty() ? "" : " ", s);
        const RenderCounters& c = r.counters;
        // The light mesh's counts: c.method holds them in its runs ("lmm", and "penumbra": lmm
        // with a light radius) only; 0 for the other methods.
        const bool lightMesh = r.method == "lmm" || r.method == "penumbra";
        const auto lmm = [&](LightMeshCount k) -> unsigned long long { return lightMesh ? Count(c, k) : 0; };
        const uint64_t interpolations = lmm(LightMeshCount::kInterpolations);
        out += StringPrintf("%s,%d,%d,%s,%s,%s,%s,%d,%g,%.4f,%s,%.4f,%llu,%llu,%llu,%llu,%llu,%.2f,%llu,%llu,%llu,%s,%llu,%llu,%g,%llu,%llu,%s,%llu,%llu\n",
                            r.scene.c_str(), r.width, r.height, r.method.c_str(), r.variant.c_str(),
                            r.paperName.c_str(), r.accel.c_str(), r.cc, r.ki, r.median, runs.c_str(), r.setupSeconds,
                            static_cast<unsigned long long>(c.cameraRays), static_cast<unsigned long long>(c.shadowRays),
                            static_cast<unsigned long long>(c.reflectionRays), lmm(LightMeshCount::kLocalSegments),
                            lmm(LightMeshCount::kInterpolations),
                            interpolations ? static_cast<double>(lmm(LightMeshCount::kNodesUsed)) /
                                                 static_cast<double>(interpolations)
                                           : 0.0,
                            lmm(LightMeshCount::kFallbacks), static_cast<unsigned long long>(r.nodesEvaluated),
                            static_cast<unsigned long long>(r.peakMemoryBytes), r.image.c_str(),
                            lmm(LightMeshCount::kUniformCellPoints), lmm(LightMeshCount::kCulledSegments),
                            r.lightRadius,
                            lmm(LightMeshCount::kPenumbraLights), lmm(LightMeshCount::kPatchSegments),
                            r.thinCheck.c_str(), lmm(LightMeshCount::kThinChecks), lmm(LightMeshCount::kThinFound));
    }
    return out;
}

namespace {

std::string Psnr(double v) { return v >= 99 ? "∞" : StringPrintf("%.2f", v); }

}  // namespace

namespace {

/// Naive soft shadows at `seconds`: their PSNR (against the main reference) read off the
/// area rows' time–PSNR curve by linear interpolation; outside the times measured, on which
/// side, with the nearest end's figures.
std::string AreaPsnrAt(const BenchQuality& q, double seconds) {
    struct Point {
        double seconds, psnr;
        int samples;
    };
    std::vector<Point> curve;
    for (const QualityRow& row : q.rows)
        if (row.method == "area") curve.push_back({row.seconds, row.psnr[q.mainRadius], row.samples});
    if (curve.empty()) return "–";
    std::sort(curve.begin(), curve.end(), [](const Point& a, const Point& b) { return a.seconds < b.seconds; });
    const Point &fastest = curve.front(), &slowest = curve.back();
    if (seconds < fastest.seconds)
        return StringPrintf("faster than N=%d (%.3f s, %s dB)", fastest.samples, fastest.seconds, Psnr(fastest.psnr).c_str());
    if (seconds > slowest.seconds)
        return StringPrintf("slower than N=%d (%.3f s, %s dB)", slowest.samples, slowest.seconds, Psnr(slowest.psnr).c_str());
    for (size_t i = 1; i < curve.size(); ++i) {
        const Point &a = curve[i - 1], &b = curve[i];
        if (seconds <= b.seconds)
            return Psnr(b.seconds > a.seconds ? a.psnr + (b.psnr - a.psnr) * (seconds - a.seconds) / (b.seconds - a.seconds)
                                              : b.psnr);
    }
    return Psnr(fastest.psnr);  // one area row, at exactly this time
}

/// The contact-hardening rows against RT, the same (CC, kI) without a light radius and
/// naive soft shadows at equal time: the targets of the penumbra mode, as ratios and dB
/// differences from one run.
std::string PenumbraQualityMarkdown(const BenchQuality& q) {
    const size_t mr = q.mainRadius;
    const QualityRow* rt = nullptr;
    for (const QualityRow& row : q.rows)
        if (row.method == "rt" && !rt) rt = &row;
    std::string out;
    for (const QualityRow& row : q.rows) {
        if (row.method != "penumbra") continue;
        if (out.empty())
            out = StringPrintf(
                "\n\nContact-hardening penumbrae (light radius = the main reference's R = %.4g) against RT, the "
                "same light mesh with its fixed radius, and naive soft shadows at equal time (interpolated on "
                "their time–PSNR curve):\n\n| Method | s | × RT | PSNR dB | SSIM | − RT dB | − fixed radius dB | "
                "area at equal time dB |\n|---|---|---|---|---|---|---|---|\n",
                q.radii[mr]);
        const QualityRow* fixed = nullptr;
        for (const QualityRow& other : q.rows)
            if (other.method == "lmm" && other.variant == row.variant && other.cc == row.cc && other.ki == row.ki)
                fixed = &other;
        out += StringPrintf("| %s | %.3f | %s | %s | %.4f | %s | %s | %s |\n", row.label.c_str(), row.seconds,
                            rt && rt->seconds > 0 ? StringPrintf("%.2f", row.seconds / rt->seconds).c_str() : "–",
                            Psnr(row.psnr[mr]).c_str(), row.ssim[mr],
                            rt ? StringPrintf("%+.1f", row.psnr[mr] - rt->psnr[mr]).c_str() : "–",
                            fixed ? StringPrintf("%+.1f", row.psnr[mr] - fixed->psnr[mr]).c_str() : "–",
                            AreaPsnrAt(q, row.seconds).c_str());
    }
    return out;
}

}  // namespace

std::string BenchQualityMarkdown(const BenchReport& report) {
    std::string out;
    for (const BenchQuality& q : report.quality) {
        const size_t mr = q.mainRadius;
        out += StringPrintf("### Quality: %s, %dx%d\n\n", q.scene.c_str(), q.width, q.height);
        out += StringPrintf(
            "Against the area-light reference (\"area\", %d samples) of radius R = r = kI·h = %.4g (h = %.4g; "
            "%.1f px at the look-at distance). Leaks: pixels deeper than r inside RT's shadow that the method "
            "lights (approximate, see BenchQuality).\n\n",
            q.refSamples, q.radius, q.meshStep, q.radiusPixels);
        out += "| Method | s | PSNR dB | SSIM | leaks px |\n|---|---|---|---|---|\n";
        for (const QualityRow& row : q.rows)
            out += StringPrintf("| %s | %.3f | %s | %.4f | %s |\n", row.label.c_str(), row.seconds,
                                Psnr(row.psnr[mr]).c_str(), row.ssim[mr],
                                row.leaks < 0 ? "–" : std::to_string(row.leaks).c_str());
        // Radius sweep: mean PSNR of the LMM rows of each kI against each reference.
        std::vector<float> kis;
        for (const QualityRow& row : q.rows)
            if (row.method == "lmm" && std::find(kis.begin(), kis.end(), row.ki) == kis.end()) kis.push_back(row.ki);
        out += "\nReference radius sweep (mean PSNR dB of the LMM variants):\n\n| kI |";
        for (size_t i = 0; i < q.radii.size(); ++i) out += StringPrintf(" R=%.4g |", q.radii[i]);
        out += " best R |\n|---|";
        for (size_t i = 0; i <= q.radii.size(); ++i) out += "---|";
        out += "\n";
        for (float ki : kis) {
            out += StringPrintf("| %g |", ki);
            size_t best = 0;
            double bestV = -1e9;
            for (size_t i = 0; i < q.radii.size(); ++i) {
                double sum = 0;
                int n = 0;
                for (const QualityRow& row : q.rows)
                    if (row.method == "lmm" && row.ki == ki) sum += row.psnr[i], ++n;
                const double mean = n ? sum / n : 0;
                if (mean > bestV) bestV = mean, best = i;
                out += " " + Psnr(mean) + " |";
            }
            out += StringPrintf(" %.4g (%.2g·kI·h) |\n", q.radii[best], q.radii[best] / (ki * q.meshStep));
        }
        out += StringPrintf("\nReference render times:");
        for (size_t i = 0; i < q.radii.size(); ++i) out += StringPrintf(" R=%.4g %.2f s;", q.radii[i], q.refSeconds[i]);
        // Naive soft shadows against the best LMM row of the first kI.
        const QualityRow* lmm = nullptr;
        for (const QualityRow& row : q.rows)
            if (row.method == "lmm" && row.ki == (kis.empty() ? 0 : kis.front()) &&
                (!lmm || row.psnr[mr] > lmm->psnr[mr]))
                lmm = &row;
        if (lmm) {
            out += StringPrintf("\n\nNaive soft shadows (area, R = r) against the best LMM at kI %g, %s (%.2f dB, %.3f s):\n\n",
                                lmm->ki, lmm->label.c_str(), lmm->psnr[mr], lmm->seconds);
            out += "| N | s | × LMM time | PSNR dB | SSIM |\n|---|---|---|---|---|\n";
            const QualityRow* reach = nullptr;
            for (const QualityRow& row : q.rows) {
                if (row.method != "area") continue;
                out += StringPrintf("| %d | %.3f | %.2f | %s | %.4f |\n", row.samples, row.seconds,
                                    lmm->seconds > 0 ? row.seconds / lmm->seconds : 0.0, Psnr(row.psnr[mr]).c_str(),
                                    row.ssim[mr]);
                if (!reach && row.psnr[mr] >= lmm->psnr[mr]) reach = &row;
            }
            if (reach)
                out += StringPrintf("\nNaive soft shadows reach LMM's PSNR at N = %d, %.1f× LMM's time.\n", reach->samples,
                                    lmm->seconds > 0 ? reach->seconds / lmm->seconds : 0.0);
            else
                out += "\nNaive soft shadows do not reach LMM's PSNR at the N tried.\n";
        }
        out += PenumbraQualityMarkdown(q);
        out += "\n";
    }
    return out;
}

}  // namespace lm
