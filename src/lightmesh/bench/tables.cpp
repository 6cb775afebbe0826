// tables.cpp -- the bench's Markdown and CSV: timing tables laid out like the paper's, the
// --quality tables (PSNR/SSIM, radius sweep, naive soft shadows, penumbra mode).
#include "lightmesh/bench/benchmark.h"
#include "lightmesh/bench/report_internal.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lightmesh/shadow/light_mesh.h"
#include "lightmesh/shadow/light_mesh_counters.h"
#include "lightmesh/util/error.h"

namespace lm {

namespace {

const BenchResult* Find(const std::vector<BenchResult>& rs, const BenchResult& like, const std::string& variant,
                        int cc, float ki) {
    for (const BenchResult& r : rs)
        if (r.scene == like.scene && r.width == like.width && r.height == like.height && r.method == "lmm" &&
            r.variant == variant && r.cc == cc && r.ki == ki && r.role.empty())
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
            if (!r.role.empty()) continue;  // the competitors' cells: their own table (--quality)
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
        out += rtLine;
        for (const BenchResult& r : rs)
            if (r.method == "soft" && r.role.empty() && r.scene == g->scene && r.width == g->width &&
                r.height == g->height)
                out += StringPrintf("; soft shadows (the default) %.3f s%s", r.median,
                                    rt && rt->median > 0 ? StringPrintf(", %.2f× RT", r.median / rt->median).c_str() : "");
        out += StringPrintf(" (median of %zu runs after a warm-up).\n\n", g->seconds.size());
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
        if (variants.empty()) {  // no light mesh cell (--variants soft): the line above is all
            out += "\n";
            continue;
        }
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
        "thin_found,samples,role,ref_psnr,ref_ssim,shadow_total_ratio\n";
    // The competitors table's figures (NaN: not a row of it) as empty fields.
    const auto figure = [](double v, const char* format) { return std::isnan(v) ? std::string() : StringPrintf(format, v); };
    for (const BenchResult& r : rs) {
        std::string runs;
        for (double s : r.seconds) runs += StringPrintf("%s%.4f", runs.empty() ? "" : " ", s);
        const RenderCounters& c = r.counters;
        // The light mesh's counts: c.method holds them in its runs ("lmm", and "penumbra": lmm
        // with a light radius) only; 0 for the other methods.
        const bool lightMesh = r.method == "lmm" || r.method == "penumbra";
        const auto lmm = [&](LightMeshCount k) -> unsigned long long { return lightMesh ? Count(c, k) : 0; };
        const uint64_t interpolations = lmm(LightMeshCount::kInterpolations);
        out += StringPrintf("%s,%d,%d,%s,%s,%s,%s,%d,%g,%.4f,%s,%.4f,%llu,%llu,%llu,%llu,%llu,%.2f,%llu,%llu,%llu,%s,%llu,%llu,%g,%llu,%llu,%s,%llu,%llu",
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
        out += StringPrintf(",%d,%s,%s,%s,%s\n", r.samples, r.role.c_str(), figure(r.refPsnr, "%.3f").c_str(),
                            figure(r.refSsim, "%.5f").c_str(), figure(r.shadowRatio, "%.4f").c_str());
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

std::string RadiiText(const BenchCompetitors& c) {
    if (c.lightRadii.empty()) return "no lights";
    const auto [lo, hi] = std::minmax_element(c.lightRadii.begin(), c.lightRadii.end());
    if (c.radiusOverride) return StringPrintf("every light of radius %.4g (--light-radius)", *lo);
    std::string s = c.lightRadii.size() == 1 ? "the light's own radius " : "the lights' own radii ";
    if (c.lightRadii.size() <= 6) {
        for (size_t i = 0; i < c.lightRadii.size(); ++i) s += StringPrintf("%s%.4g", i ? ", " : "", c.lightRadii[i]);
    } else {
        s += StringPrintf("%.4g–%.4g (%zu lights)", *lo, *hi, c.lightRadii.size());
    }
    return s;
}

std::string BenchCompetitorsMarkdown(const BenchQuality& q) {
    const BenchCompetitors& c = q.competitors;
    if (c.rows.empty()) return "";
    const CompetitorRow* soft = nullptr;
    for (const CompetitorRow& row : c.rows)
        if (row.method == "soft") soft = &row;
    std::string out = StringPrintf("### The default (soft) against its competitors, %s: %s, %dx%d\n\n",
                                   RadiiText(c).c_str(), q.scene.c_str(), q.width, q.height);
    out += StringPrintf(
        "Every row on %s with the same light radii; seconds: render phase, median of %d interleaved run(s) after a "
        "warm-up, in the same run (the reference: one run). Reference: \"area\" with %d rays per light at these radii. "
        "Shadow total: Σ over the image of (no shadows − image) in linear luminance, over the reference's (1.00 is "
        "right; below 1 too little shadow).\n\n",
        c.accel.c_str(), c.repeat, c.refSamples);
    out += "| Method | s | × soft | PSNR dB | SSIM | shadow total / ref |\n|---|---|---|---|---|---|\n";
    for (const CompetitorRow& row : c.rows)
        out += StringPrintf("| %s | %.3f%s | %s | %s | %.4f | %s |\n", row.label.c_str(), row.seconds,
                            row.reference ? " (1 run)" : "",
                            soft && soft->seconds > 0 ? StringPrintf("%.2f", row.seconds / soft->seconds).c_str() : "–",
                            Psnr(row.psnr).c_str(), row.ssim,
                            std::isnan(row.shadowRatio) ? "–" : StringPrintf("%.3f", row.shadowRatio).c_str());
    if (soft && soft->setupSeconds > 0) out += StringPrintf("\nsoft's set-up (not in its time): %.3g s.\n", soft->setupSeconds);
    const EqualQuality& e = c.equal;
    // The measured N around the equal-quality point, for the sentence.
    std::vector<int> ns;
    for (const CompetitorRow& row : c.rows)
        if (row.method == "area" && !row.reference) ns.push_back(row.samples);
    std::sort(ns.begin(), ns.end());
    if (ns.empty()) return out + "\nNo area rows: no equal-quality comparison.\n\n";
    out += StringPrintf("\nEqual quality (area's PSNR linear in log2 N between the measured N = %d…%d, 3.01 dB per "
                        "doubling of N past N = %d): ",
                        ns.front(), ns.back(), ns.back());
    if (!e.valid) {
        out += StringPrintf("area sampling does not reach soft's %s dB at the N tried and its PSNR does not rise "
                            "between the last two N, so there is no line to extrapolate.\n\n",
                            Psnr(e.targetPsnr).c_str());
        return out;
    }
    // "soft is 2.50× faster", or "soft is 1.75× slower (0.57×)" when area is the faster.
    const std::string verdict =
        e.speedup >= 1 ? StringPrintf("soft is %s%.2f× faster than area sampling at equal PSNR", e.atMost ? "at most " : "",
                                      e.speedup)
                       : StringPrintf("soft is %s%.2f× slower than area sampling at equal PSNR (speed-up %.2f×)",
                                      e.atMost ? "at least " : "", 1 / e.speedup, e.speedup);
    if (e.atMost)
        out += StringPrintf("area sampling with N = %d already reaches soft's %s dB; at N = %d area takes %.3f s, "
                            "soft %.3f s: %s.\n\n",
                            ns.front(), Psnr(e.targetPsnr).c_str(), ns.front(), e.areaSeconds, e.softSeconds,
                            verdict.c_str());
    else
        out += StringPrintf("area sampling reaches soft's %s dB at N ≈ %.1f%s, where it takes %.3f s (%s) against "
                            "soft's %.3f s: %s%s.\n\n",
                            Psnr(e.targetPsnr).c_str(), e.samples,
                            e.extrapolated ? StringPrintf(" (extrapolated from N = %d, 3.01 dB per doubling)", ns.back()).c_str()
                                           : " (measured)",
                            e.areaSeconds,
                            e.extrapolated ? "extrapolated linearly in N" : "interpolated in log2 N", e.softSeconds,
                            verdict.c_str(), e.extrapolated ? " (extrapolated)" : "");
    const EqualTime& d = c.denoised;
    if (d.valid) {
        const double ahead = d.softPsnr - d.psnr;
        out += StringPrintf(
            "Equal time against the denoiser: %s %s dB at soft's %.3f s%s; soft's %s dB is %s by %.2f dB.\n\n",
            d.atLeast ? "its fastest row (N = 1) takes longer and reaches" : "it reaches", Psnr(d.psnr).c_str(), d.seconds,
            d.atLeast ? "" : d.extrapolated ? " (extrapolated, 3.01 dB per doubling of time)" : " (interpolated in log2 time)",
            Psnr(d.softPsnr).c_str(), ahead >= 0 ? "ahead" : "behind", std::abs(ahead));
    }
    return out;
}

std::string BenchQualityMarkdown(const BenchReport& report) {
    std::string out;
    for (const BenchQuality& q : report.quality) {
        const size_t mr = q.mainRadius;
        out += BenchCompetitorsMarkdown(q);
        out += StringPrintf("### Quality of the paper's variants, every light of radius R = kI·h = %.4g: %s, %dx%d\n\n",
                            q.radius, q.scene.c_str(), q.width, q.height);
        out += StringPrintf(
            "Against the area-light reference (\"area\", %d samples) of radius R = r = kI·h = %.4g for every light "
            "(h = %.4g; %.1f px at the look-at distance), not the lights' own radii. Leaks: pixels deeper than r "
            "inside RT's shadow that the method lights (approximate, see BenchQuality).\n\n",
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

std::string BenchJson(const BenchReport& report) {
    using nlohmann::json;
    // NaN and infinities become null (nlohmann writes them so); a PSNR of 99 (equal images) too.
    const auto num = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
    const auto psnr = [&](double v) { return v >= 99 ? json(nullptr) : num(v); };
    json cells = json::array();
    for (const BenchResult& r : report.results) {
        json c = {{"scene", r.scene},   {"width", r.width},         {"height", r.height},  {"method", r.method},
                  {"variant", r.variant}, {"paper_name", r.paperName}, {"accel", r.accel},  {"cc", r.cc},
                  {"ki", r.ki},           {"samples", r.samples},      {"role", r.role},    {"median_s", r.median},
                  {"runs_s", r.seconds},  {"setup_s", r.setupSeconds}, {"image", r.image},
                  {"camera_rays", r.counters.cameraRays}, {"shadow_rays", r.counters.shadowRays},
                  {"peak_memory_bytes", r.peakMemoryBytes}};
        if (r.method == "penumbra") c["light_radius"] = r.lightRadius, c["thin_check"] = r.thinCheck;
        if (!std::isnan(r.refPsnr)) {
            c["ref_psnr"] = psnr(r.refPsnr);
            c["ref_ssim"] = num(r.refSsim);
            c["shadow_total_ratio"] = num(r.shadowRatio);
        }
        cells.push_back(std::move(c));
    }
    json quality = json::array();
    for (const BenchQuality& q : report.quality) {
        const BenchCompetitors& comp = q.competitors;
        json rows = json::array();
        for (const CompetitorRow& row : comp.rows)
            rows.push_back({{"label", row.label},
                            {"method", row.method},
                            {"samples", row.samples},
                            {"reference", row.reference},
                            {"seconds", row.seconds},
                            {"runs", row.runs},
                            {"setup_s", row.setupSeconds},
                            {"psnr", psnr(row.psnr)},
                            {"ssim", num(row.ssim)},
                            {"shadow_total_ratio", num(row.shadowRatio)},
                            {"image", row.image}});
        const EqualQuality& e = comp.equal;
        json equal = {{"valid", e.valid},
                      {"target_psnr", psnr(e.targetPsnr)},
                      {"samples", e.valid ? num(e.samples) : json(nullptr)},
                      {"extrapolated", e.extrapolated},
                      {"at_most", e.atMost},
                      {"area_seconds", e.valid ? num(e.areaSeconds) : json(nullptr)},
                      {"soft_seconds", num(e.softSeconds)},
                      {"speedup", e.valid ? num(e.speedup) : json(nullptr)}};
        json old = json::array();
        for (const QualityRow& row : q.rows) {
            json p = json::array(), s = json::array();
            for (double v : row.psnr) p.push_back(psnr(v));
            for (double v : row.ssim) s.push_back(num(v));
            old.push_back({{"label", row.label}, {"method", row.method}, {"variant", row.variant}, {"cc", row.cc},
                           {"ki", row.ki}, {"samples", row.samples}, {"seconds", row.seconds}, {"psnr", p},
                           {"ssim", s}, {"leaks", row.leaks < 0 ? json(nullptr) : json(row.leaks)}});
        }
        quality.push_back({{"scene", q.scene},
                           {"width", q.width},
                           {"height", q.height},
                           {"mesh_step", q.meshStep},
                           {"radius", q.radius},
                           {"ref_samples", q.refSamples},
                           {"radii", q.radii},
                           {"ref_seconds", q.refSeconds},
                           {"main_radius", q.mainRadius},
                           {"rows", old},
                           {"competitors",
                            {{"accel", comp.accel},
                             {"light_radii", comp.lightRadii},
                             {"radius_override", comp.radiusOverride},
                             {"ref_samples", comp.refSamples},
                             {"repeat", comp.repeat},
                             {"rows", rows},
                             {"equal_quality", equal}}}});
    }
    json doc = {{"repeat", report.repeat}, {"cells", cells}, {"quality", quality}};
    return doc.dump(2) + "\n";
}

}  // namespace lm
