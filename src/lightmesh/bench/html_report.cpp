// html_report.cpp -- `bench --html`: one self-contained page with the tables, SVG charts of
// seconds and of LMM/RT against kI, and the images side by side (base64), each with a
// zoomed crop of the window where the light-mesh images differ most from RT.
#include "lightmesh/bench/benchmark.h"
#include "lightmesh/bench/report_internal.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "lightmesh/io/image.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace {

std::string HtmlEscape(const std::string& s) {
    std::string o;
    for (char c : s) {
        if (c == '<') o += "&lt;";
        else if (c == '>') o += "&gt;";
        else if (c == '&') o += "&amp;";
        else if (c == '"') o += "&quot;";
        else o += c;
    }
    return o;
}

/// The subset of Markdown that BenchMarkdown and BenchQualityMarkdown write.
std::string MarkdownToHtml(const std::string& md) {
    std::string out;
    std::istringstream in(md);
    std::string line;
    bool inTable = false, header = false;
    while (std::getline(in, line)) {
        if (!line.empty() && line[0] == '|') {
            if (line.rfind("|---", 0) == 0) continue;
            if (!inTable) out += "<table>\n", inTable = true, header = true;
            std::vector<std::string> cells;
            size_t p = 1;
            while (p < line.size()) {
                const size_t q = line.find('|', p);
                if (q == std::string::npos) break;
                std::string c = line.substr(p, q - p);
                const size_t a = c.find_first_not_of(' '), b = c.find_last_not_of(' ');
                cells.push_back(a == std::string::npos ? "" : c.substr(a, b - a + 1));
                p = q + 1;
            }
            out += "<tr>";
            for (const std::string& c : cells) out += (header ? "<th>" : "<td>") + HtmlEscape(c) + (header ? "</th>" : "</td>");
            out += "</tr>\n";
            header = false;
            continue;
        }
        if (inTable) out += "</table>\n", inTable = false;
        if (line.rfind("### ", 0) == 0) out += "<h3>" + HtmlEscape(line.substr(4)) + "</h3>\n";
        else if (!line.empty()) out += "<p>" + HtmlEscape(line) + "</p>\n";
    }
    if (inTable) out += "</table>\n";
    return out;
}

std::string Base64(const std::string& bytes) {
    static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string o;
    o.reserve((bytes.size() + 2) / 3 * 4);
    for (size_t i = 0; i < bytes.size(); i += 3) {
        uint32_t v = static_cast<uint8_t>(bytes[i]) << 16;
        if (i + 1 < bytes.size()) v |= static_cast<uint8_t>(bytes[i + 1]) << 8;
        if (i + 2 < bytes.size()) v |= static_cast<uint8_t>(bytes[i + 2]);
        o += t[(v >> 18) & 63];
        o += t[(v >> 12) & 63];
        o += i + 1 < bytes.size() ? t[(v >> 6) & 63] : '=';
        o += i + 2 < bytes.size() ? t[v & 63] : '=';
    }
    return o;
}

std::string ReadBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) ThrowErrorAt({path}, "cannot read the image for the report");
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

const char* kPalette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"};

struct Series {
    std::string name;
    std::vector<std::pair<double, double>> points;
};

/// A line chart: x = kI, one polyline per series, an optional dashed horizontal line.
std::string SvgChart(const std::string& title, const std::string& yLabel, const std::vector<Series>& series,
                     double hline, const std::string& hlineName) {
    const double W = 520, H = 300, L = 60, R = 150, T = 30, B = 45;
    double x0 = 1e300, x1 = -1e300, y1 = hline > 0 ? hline : 0;
    for (const Series& s : series)
        for (auto [x, y] : s.points) x0 = std::min(x0, x), x1 = std::max(x1, x), y1 = std::max(y1, y);
    if (x0 > x1) return "";
    if (x1 - x0 < 1e-9) x0 -= 0.5, x1 += 0.5;
    y1 = y1 > 0 ? y1 * 1.1 : 1;
    auto X = [&](double x) { return L + (x - x0) / (x1 - x0) * (W - L - R); };
    auto Y = [&](double y) { return H - B - y / y1 * (H - T - B); };
    std::string o = StringPrintf("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%g\" height=\"%g\" viewBox=\"0 0 %g %g\">", W, H, W, H);
    o += StringPrintf("<rect width=\"%g\" height=\"%g\" fill=\"#fff\"/>", W, H);
    o += StringPrintf("<text x=\"%g\" y=\"18\" font-size=\"14\" font-weight=\"bold\">%s</text>", L, HtmlEscape(title).c_str());
    for (int i = 0; i <= 4; ++i) {  // y grid
        const double v = y1 * i / 4;
        o += StringPrintf("<line x1=\"%g\" y1=\"%.1f\" x2=\"%g\" y2=\"%.1f\" stroke=\"#ddd\"/>", L, Y(v), W - R, Y(v));
        o += StringPrintf("<text x=\"%g\" y=\"%.1f\" font-size=\"11\" text-anchor=\"end\">%.3g</text>", L - 5, Y(v) + 4, v);
    }
    std::vector<double> xs;
    for (const Series& s : series)
        for (auto p : s.points)
            if (std::find(xs.begin(), xs.end(), p.first) == xs.end()) xs.push_back(p.first);
    for (double x : xs)
        o += StringPrintf("<text x=\"%.1f\" y=\"%g\" font-size=\"11\" text-anchor=\"middle\">%g</text>", X(x), H - B + 15, x);
    o += StringPrintf("<line x1=\"%g\" y1=\"%g\" x2=\"%g\" y2=\"%g\" stroke=\"#000\"/>", L, H - B, W - R, H - B);
    o += StringPrintf("<line x1=\"%g\" y1=\"%g\" x2=\"%g\" y2=\"%g\" stroke=\"#000\"/>", L, T, L, H - B);
    o += StringPrintf("<text x=\"%g\" y=\"%g\" font-size=\"12\" text-anchor=\"middle\">kI</text>", (L + W - R) / 2, H - 8);
    o += StringPrintf("<text x=\"14\" y=\"%g\" font-size=\"12\" text-anchor=\"middle\" transform=\"rotate(-90 14 %g)\">%s</text>",
                      (T + H - B) / 2, (T + H - B) / 2, HtmlEscape(yLabel).c_str());
    if (hline > 0) {
        o += StringPrintf("<line x1=\"%g\" y1=\"%.1f\" x2=\"%g\" y2=\"%.1f\" stroke=\"#000\" stroke-dasharray=\"6 4\"/>", L, Y(hline),
                          W - R, Y(hline));
        o += StringPrintf("<text x=\"%g\" y=\"%.1f\" font-size=\"11\">%s</text>", W - R + 5, Y(hline) + 4,
                          HtmlEscape(hlineName).c_str());
    }
    for (size_t i = 0; i < series.size(); ++i) {
        const char* c = kPalette[i % 8];
        std::string pts;
        for (auto [x, y] : series[i].points) pts += StringPrintf("%.1f,%.1f ", X(x), Y(y));
        o += StringPrintf("<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"2\" points=\"%s\"/>", c, pts.c_str());
        for (auto [x, y] : series[i].points)
            o += StringPrintf("<circle cx=\"%.1f\" cy=\"%.1f\" r=\"3\" fill=\"%s\"/>", X(x), Y(y), c);
        o += StringPrintf("<rect x=\"%g\" y=\"%g\" width=\"12\" height=\"3\" fill=\"%s\"/>", W - R + 8, T + 10 + 16.0 * i, c);
        o += StringPrintf("<text x=\"%g\" y=\"%g\" font-size=\"11\">%s</text>", W - R + 24, T + 15 + 16.0 * i,
                          HtmlEscape(series[i].name).c_str());
    }
    return o + "</svg>";
}

/// The window (a quarter of each side) where the LMM images differ most from RT.
struct Window { int x = 0, y = 0, w = 0, h = 0; };
Window MostDifferent(const Image& rt, const std::vector<Image>& others) {
    const int W = rt.width, H = rt.height;
    Window win{0, 0, std::max(1, W / 4), std::max(1, H / 4)};
    // Summed-area table of the summed |luma difference|.
    std::vector<double> sat(static_cast<size_t>(W + 1) * (H + 1), 0.0);
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) {
            double d = 0;
            for (const Image& o : others)
                if (o.width == W && o.height == H) d += std::abs(Luma(o.At(x, y)) - Luma(rt.At(x, y)));
            sat[static_cast<size_t>(y + 1) * (W + 1) + x + 1] = d + sat[static_cast<size_t>(y) * (W + 1) + x + 1] +
                                                                sat[static_cast<size_t>(y + 1) * (W + 1) + x] -
                                                                sat[static_cast<size_t>(y) * (W + 1) + x];
        }
    auto S = [&](int x, int y) { return sat[static_cast<size_t>(y) * (W + 1) + x]; };
    double best = -1;
    const int step = std::max(1, std::min(W, H) / 64);
    for (int y = 0; y + win.h <= H; y += step)
        for (int x = 0; x + win.w <= W; x += step) {
            const double s = S(x + win.w, y + win.h) - S(x, y + win.h) - S(x + win.w, y) + S(x, y);
            if (s > best) best = s, win.x = x, win.y = y;
        }
    return win;
}

}  // namespace

std::string BenchHtml(const BenchReport& report, const std::string& title) {
    const std::vector<BenchResult>& rs = report.results;
    std::string o = "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" + HtmlEscape(title) +
                    "</title>\n<style>\n"
                    "body{font-family:system-ui,sans-serif;margin:20px;color:#222;max-width:1400px}\n"
                    "table{border-collapse:collapse;margin:8px 0 16px}td,th{border:1px solid #bbb;padding:3px 8px;"
                    "text-align:right;font-size:13px}th{background:#eef}td:first-child{text-align:left}\n"
                    "h2{border-bottom:2px solid #99c;margin-top:32px}.charts{display:flex;flex-wrap:wrap;gap:12px}\n"
                    ".charts svg{border:1px solid #ccc}.imgs{display:flex;flex-wrap:wrap;gap:10px}\n"
                    "figure{margin:0;width:240px;font-size:12px}.full{position:relative;width:240px;"
                    "background-size:100% 100%;image-rendering:pixelated}\n"
                    ".crop{width:240px;border:1px solid #555;margin-top:4px;image-rendering:pixelated}\n"
                    ".win{position:absolute;border:2px solid #f0f;box-sizing:border-box}\n"
                    "</style></head><body>\n<h1>" + HtmlEscape(title) + "</h1>\n";
    o += StringPrintf("<p>Seconds are the median of %d timed run(s) after a warm-up. Charts: render time and the LMM/RT "
                      "ratio against kI per variant (dashed: RT). Images: every cell, with a zoomed crop (magenta "
                      "window) where the LMM and soft images differ most from RT; with --quality also the default "
                      "(soft) against its competitors, captioned \"competitors'\", and their reference.</p>\n",
                      report.repeat);
    const std::vector<const BenchResult*> groups = SceneSizeGroups(rs);
    for (const BenchResult* g : groups) {
        std::vector<BenchResult> group;
        for (const BenchResult& r : rs)
            if (r.scene == g->scene && r.width == g->width && r.height == g->height) group.push_back(r);
        o += StringPrintf("<h2>%s, %d×%d</h2>\n", HtmlEscape(g->scene).c_str(), g->width, g->height);
        std::string md = BenchMarkdown(group);
        if (md.rfind("### ", 0) == 0) md = md.substr(md.find('\n') + 1);  // the h2 says it
        o += MarkdownToHtml(md);
        // Charts.
        const BenchResult* rt = nullptr;
        for (const BenchResult& r : group)
            if (r.method == "rt" && !rt && r.role.empty()) rt = &r;
        std::vector<Series> secs, ratios;
        std::set<int> ccs;
        for (const BenchResult& r : group)
            if (r.method == "lmm" && r.role.empty()) ccs.insert(r.cc);
        for (const BenchResult& r : group) {
            if (r.method != "lmm" || !r.role.empty()) continue;  // the matrix's cells only
            const std::string name = r.paperName + " " + r.variant + (ccs.size() > 1 ? StringPrintf(" CC%d", r.cc) : "");
            auto it = std::find_if(secs.begin(), secs.end(), [&](const Series& s) { return s.name == name; });
            if (it == secs.end()) secs.push_back({name, {}}), ratios.push_back({name, {}}), it = secs.end() - 1;
            const size_t i = static_cast<size_t>(it - secs.begin());
            secs[i].points.push_back({r.ki, r.median});
            if (rt && rt->median > 0) ratios[i].points.push_back({r.ki, r.median / rt->median});
        }
        if (!secs.empty()) {
            o += "<div class=\"charts\">" + SvgChart("Render time", "seconds", secs, rt ? rt->median : 0, "RT");
            o += SvgChart("LMM / RT", "ratio", ratios, 1.0, "RT = 1") + "</div>\n";
        }
        // Images.
        bool haveImages = rt && !rt->image.empty();
        if (haveImages) {
            const Image rtImage = ReadImage(rt->image);
            std::vector<Image> lmm;
            for (const BenchResult& r : group)
                if ((r.method == "lmm" || r.method == "penumbra" || r.method == "soft") && !r.image.empty())
                    lmm.push_back(ReadImage(r.image));
            const Window win = MostDifferent(rtImage, lmm);
            const double fullH = 240.0 * g->height / g->width;
            const double zoom = 240.0 / win.w;  // crop width 240 px
            o += "<h3>Images</h3>\n<div class=\"imgs\">\n";
            int n = 0;
            // One image with its crop of the window.
            auto figure = [&](const std::string& path, const std::string& caption) {
                const std::string cls = StringPrintf("i%zu_%d", static_cast<size_t>(g - rs.data()), n++);
                o += "<style>." + cls + "{background-image:url(data:image/png;base64," + Base64(ReadBytes(path)) +
                     ")}</style>\n";
                o += StringPrintf("<figure><div class=\"full %s\" style=\"height:%.0fpx\"><div class=\"win\" style=\"left:%.1fpx;"
                                  "top:%.1fpx;width:%.1fpx;height:%.1fpx\"></div></div>",
                                  cls.c_str(), fullH, 240.0 * win.x / g->width, 240.0 * win.y / g->width,
                                  240.0 * win.w / g->width, 240.0 * win.h / g->width);
                o += StringPrintf("<div class=\"crop %s\" style=\"height:%.0fpx;background-size:%.1fpx %.1fpx;"
                                  "background-position:%.1fpx %.1fpx\"></div>",
                                  cls.c_str(), win.h * zoom, g->width * zoom, g->height * zoom, -win.x * zoom, -win.y * zoom);
                o += "<figcaption>" + HtmlEscape(caption) + "</figcaption></figure>\n";
            };
            for (const BenchQuality& q : report.quality)
                if (q.scene == g->scene && q.width == g->width && q.height == g->height && !q.refImage.empty())
                    figure(q.refImage, StringPrintf("area-light reference, R = %.3g, N = %d, %.2f s", q.radii[q.mainRadius],
                                                    q.refSamples, q.refSeconds[q.mainRadius]));
            auto radiiText = [&](const std::string& scene, int width, int height) {
                for (const BenchQuality& q : report.quality)
                    if (q.scene == scene && q.width == width && q.height == height) return RadiiText(q.competitors);
                return std::string("the lights' own radii");
            };
            for (const BenchResult& r : group) {
                if (r.image.empty()) continue;
                // The competitors' cells say so; the reference is the competitors' (the
                // lights' own radii, or --light-radius).
                const std::string competitor = r.role == "competitor" ? "competitors' " : "";
                const std::string caption =
                    r.role == "reference" ? StringPrintf("competitors' reference: area N = %d, %s, %.2f s", r.samples,
                                                         radiiText(g->scene, g->width, g->height).c_str(), r.median)
                    : r.method == "soft"  ? StringPrintf("soft (default), %s, %s, %.3f s", r.accel.c_str(),
                                                        radiiText(g->scene, g->width, g->height).c_str(), r.median)
                    : r.method == "area"  ? StringPrintf("area N = %d, %s, %s, %.3f s", r.samples, r.accel.c_str(),
                                                        radiiText(g->scene, g->width, g->height).c_str(), r.median)
                    : r.method == "denoised"
                        ? StringPrintf("area N = %d + shadow denoiser, %s, %s, %.3f s", r.samples, r.accel.c_str(),
                                       radiiText(g->scene, g->width, g->height).c_str(), r.median)
                    : r.method == "penumbra"
                        ? StringPrintf("%s (%s) CC %d kI %g, light radius %.3g, %.3f s", r.paperName.c_str(),
                                       r.variant.c_str(), r.cc, r.ki, r.lightRadius, r.median)
                    : r.method == "lmm" ? StringPrintf("%s (%s) CC %d kI %g, %.3f s", r.paperName.c_str(), r.variant.c_str(), r.cc,
                                                     r.ki, r.median)
                                      : StringPrintf("%s (%s), %.3f s", r.method == "rt" ? "RT" : "no shadows",
                                                     r.accel.c_str(), r.median);
                figure(r.image, competitor + caption);
            }
            o += "</div>\n";
        }
        // Quality of this group.
        for (const BenchQuality& q : report.quality)
            if (q.scene == g->scene && q.width == g->width && q.height == g->height) {
                BenchReport one;
                one.quality.push_back(q);
                o += MarkdownToHtml(BenchQualityMarkdown(one));
            }
    }
    return o + "</body></html>\n";
}

}  // namespace lm
