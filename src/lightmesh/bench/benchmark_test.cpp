#include "lightmesh/bench/benchmark.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "lightmesh/shadow/light_mesh_counters.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace benchmark_test {
namespace {

namespace fs = std::filesystem;
using Lmc = LightMeshCount;

fs::path WriteTemp(const std::string& name, const std::string& text) {
    const fs::path p = fs::path(::testing::TempDir()) / ("lm_bench_" + std::to_string(getpid()) + "_" + name);
    std::ofstream(p) << text;
    return p;
}

std::string ErrorOf(const std::string& json) {
    const fs::path p = WriteTemp("m.json", json);
    try {
        LoadBenchMatrix(p.string());
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

TEST(LoadBenchMatrix, ReadsEveryKey) {
    const fs::path p = WriteTemp("ok.json", R"({"scenes": ["builtin:gazebo", "x/s.json"], "sizes": [[64, 48], [32, 16]],
        "cc": [50, 100], "ki": [1.5, 3], "variants": ["grid", "inside"], "accels": ["brute"], "repeat": 2, "thin_check": "lit"})");
    const BenchMatrix m = LoadBenchMatrix(p.string());
    ASSERT_EQ(m.scenes.size(), 2u);
    EXPECT_EQ(m.scenes[0], "builtin:gazebo");
    EXPECT_EQ(fs::path(m.scenes[1]), p.parent_path() / "x/s.json");  // relative to the file
    EXPECT_EQ(m.sizes, (std::vector<std::pair<int, int>>{{64, 48}, {32, 16}}));
    EXPECT_EQ(m.cc, (std::vector<int>{50, 100}));
    EXPECT_EQ(m.ki, (std::vector<float>{1.5f, 3.0f}));
    EXPECT_EQ(m.variants, (std::vector<std::string>{"grid", "inside"}));
    EXPECT_EQ(m.accels, (std::vector<std::string>{"brute"}));
    EXPECT_EQ(m.repeat, 2);
    EXPECT_EQ(m.thinCheck, "lit");
    EXPECT_EQ(LoadBenchMatrix(WriteTemp("empty.json", "{}").string()).repeat, BenchMatrix().repeat);
}

// A matrix file times the default shadow method (soft) as `lightmesh bench` does, unless its
// "variants" leave "soft" out; "soft" is not taken for a light-mesh variant.
TEST(LoadBenchMatrix, SoftIsTimedUnlessTheVariantsLeaveItOut) {
    EXPECT_TRUE(LoadBenchMatrix(WriteTemp("d.json", "{}").string()).soft);
    const BenchMatrix both = LoadBenchMatrix(WriteTemp("s.json", R"({"variants": ["soft", "grid"]})").string());
    EXPECT_TRUE(both.soft);
    EXPECT_EQ(both.variants, (std::vector<std::string>{"grid"}));
    const BenchMatrix lmm = LoadBenchMatrix(WriteTemp("l.json", R"({"variants": ["grid"]})").string());
    EXPECT_FALSE(lmm.soft);
    EXPECT_FALSE(BenchMatrix().soft);  // built in code: the cells asked for only
}

TEST(LoadBenchMatrix, ErrorsNameTheJsonPath) {
    EXPECT_NE(ErrorOf(R"({"sizes": [[64, 48], [32]]})").find("/sizes/1: expected [width, height]"), std::string::npos);
    EXPECT_NE(ErrorOf(R"({"sizes": [[64, "a"]]})").find("/sizes/0/1: expected an integer"), std::string::npos);
    EXPECT_NE(ErrorOf(R"({"cc": [100, 0]})").find("/cc/1: must be between 1 and 4096, got 0"), std::string::npos);
    EXPECT_NE(ErrorOf(R"({"ki": [2, "3"]})").find("/ki/1: expected a number, got a string"), std::string::npos);
    EXPECT_NE(ErrorOf(R"({"variants": ["grid", "bogus"]})").find("/variants/1"), std::string::npos);
    EXPECT_NE(ErrorOf(R"({"scenes": "builtin:gazebo"})").find("/scenes: expected a list"), std::string::npos);
    EXPECT_NE(ErrorOf(R"({"scenes": []})").find("/scenes: must not be empty"), std::string::npos);
    EXPECT_NE(ErrorOf(R"({"repeat": 0})").find("/repeat: must be between 1 and 100, got 0"), std::string::npos);
    EXPECT_NE(ErrorOf(R"({"ki": [0.001]})").find("/ki/0: must be between 0.01 and 16"), std::string::npos);
    EXPECT_NE(ErrorOf(R"({"thin_check": "some"})").find("/thin_check: must be one of \"off\", \"lit\", \"all\"; got \"some\""),
              std::string::npos);
    EXPECT_NE(ErrorOf(R"({"thin_check": 1})").find("/thin_check: expected a string"), std::string::npos);
    EXPECT_NE(ErrorOf(R"({"sizez": []})").find("/sizez: unknown key; did you mean \"sizes\"?"), std::string::npos);
    // The scene files' reader: duplicate keys, and syntax errors by line and column.
    EXPECT_NE(ErrorOf(R"({"cc": [1], "cc": [2]})").find("/cc: duplicate key"), std::string::npos);
    EXPECT_NE(ErrorOf(R"([1, 2])").find("expected an object"), std::string::npos);
    EXPECT_NE(ErrorOf("{\n  \"cc\": [1,").find("m.json:2:"), std::string::npos);
    EXPECT_NE(ErrorOf("{\n  \"cc\": [1,").find(": parse error: "), std::string::npos);
    EXPECT_THROW(LoadBenchMatrix("/nonexistent/m.json"), Error);
}

// The matrix file names its values' places for later messages, and the keys it
// checks itself (an unknown back-end, an empty variant).
TEST(LoadBenchMatrix, OriginsAndChecksOfEachSetting) {
    const fs::path p = WriteTemp("origins.json", R"({"cc": [50, 100], "ki": [1.5, 3]})");
    const BenchMatrix m = LoadBenchMatrix(p.string());
    ASSERT_EQ(m.ccOrigins.size(), 2u);
    EXPECT_EQ(m.ccOrigins[1].Format(), p.string() + " /cc/1");
    ASSERT_EQ(m.kiOrigins.size(), 2u);
    EXPECT_EQ(m.kiOrigins[0].Format(), p.string() + " /ki/0");
    EXPECT_NE(ErrorOf(R"({"accels": ["grid", "embre"]})").find("/accels/1: unknown ray-query back-end \"embre\" (choose"),
              std::string::npos);
    EXPECT_NE(ErrorOf(R"({"variants": [""]})").find("/variants/0: must not be empty"), std::string::npos);
    EXPECT_NE(ErrorOf(R"({"ki": [16.000001]})").find("/ki/0: must be between 0.01 and 16, got 16.000001"),
              std::string::npos);
}

// The estimate comes before any cell, counts CC (at 256 x 192 an LMM render at CC
// 1200 takes about 9 times one at CC 20: each pixel needs nodes of its own), and a matrix
// above maxSeconds is refused, also without an estimate callback (-q); a CC too large for
// memory names where it was given.
TEST(RunBenchmark, EstimateCountsCcAndTheLimitRefuses) {
    BenchMatrix m;
    m.scenes = {"builtin:gazebo"};
    m.sizes = {{256, 192}};
    m.variants = {"templates"};
    m.repeat = 1;
    m.noShadows = false;
    auto estimateOf = [&](std::vector<int> cc) {
        BenchMatrix e = m;
        e.cc = std::move(cc);
        e.maxSeconds = 1e-9;  // refused right after the estimate: nothing runs
        double seconds = -1;
        EXPECT_THROW(RunBenchmarkReport(e, nullptr, [&](double s) { seconds = s; }), Error);
        return seconds;
    };
    const double small = estimateOf({20}), large = estimateOf({1200});
    EXPECT_GT(small, 0);
    EXPECT_GT(large, 2 * small);  // about 6 times, with RT's cell in both; margin for a busy machine
    m.sizes = {{64, 48}};
    m.cc = {20};
    m.maxSeconds = 1e-9;
    try {
        RunBenchmarkReport(m);
        ADD_FAILURE() << "no error";
    } catch (const Error& e) {
        const std::string what = e.what();
        EXPECT_EQ(what.rfind("bench: the matrix (2 cells, 2 runs each) is estimated at ", 0), 0u) << what;
        EXPECT_NE(what.find("; make it smaller, or --force runs it anyway"), std::string::npos) << what;
    }
    m.maxSeconds = 0;
    EXPECT_EQ(RunBenchmarkReport(m).results.size(), 2u);
    // A CC too large for the memory budget, named by where it came from.
    setenv("LIGHTMESH_MEMORY_LIMIT", "64M", 1);
    m.cc = {20, 3000};
    m.ccOrigins = {SourceLoc("m.json", 0, 0, "/cc/0"), SourceLoc("m.json", 0, 0, "/cc/1")};
    try {
        RunBenchmarkReport(m, nullptr, [](double) {});
        ADD_FAILURE() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()).rfind("m.json /cc/1: light mesh ", 0), 0u) << e.what();
    }
    unsetenv("LIGHTMESH_MEMORY_LIMIT");
}

TEST(BenchTablePreset, QuickDividesSizes) {
    EXPECT_THROW(BenchTablePreset(5, false, "/"), Error);
    EXPECT_THROW(BenchTablePreset(3, false, "/nonexistent"), Error);  // names the missing scene
#ifdef LIGHTMESH_TEST_DATA
    const std::string repo = fs::path(LIGHTMESH_TEST_DATA).parent_path().parent_path().string();
    const BenchMatrix full = BenchTablePreset(3, false, repo), quick = BenchTablePreset(3, true, repo);
    EXPECT_EQ(full.sizes, (std::vector<std::pair<int, int>>{{1024, 1024}}));
    EXPECT_EQ(quick.sizes, (std::vector<std::pair<int, int>>{{256, 256}}));
    EXPECT_EQ(quick.repeat, 1);
    EXPECT_EQ(quick.variants, (std::vector<std::string>{"none", "inside", "object", "consensus"}));
    EXPECT_EQ(BenchTablePreset(1, true, repo).sizes, (std::vector<std::pair<int, int>>{{256, 192}}));
#endif
}

// The shadow-part table: what each method adds to the render without shadows, over what
// RT adds, from the same run's medians.
TEST(BenchMarkdown, ShadowPartIsTheWorkAboveNoShadows) {
    std::vector<BenchResult> rs(3);
    for (BenchResult& r : rs) {
        r.scene = "s";
        r.width = 8;
        r.height = 8;
        r.seconds = {0};
    }
    rs[0].method = "none";
    rs[0].median = 1.0;
    rs[1].method = "rt";
    rs[1].accel = "embree";
    rs[1].median = 3.0;
    rs[2].method = "lmm";
    rs[2].variant = "consensus";
    rs[2].cc = 100;
    rs[2].ki = 2;
    rs[2].median = 1.5;
    const std::string md = BenchMarkdown(rs);
    EXPECT_NE(md.find("Shadow part, (method - no shadows) / (RT - no shadows)"), std::string::npos) << md;
    EXPECT_NE(md.find("| 100 | 2 | 0.25 |"), std::string::npos) << md;  // (1.5 - 1) / (3 - 1)
    EXPECT_NE(md.find("| 100 | 2 | 0.50 |"), std::string::npos) << md;  // consensus / RT
}

// A tiny end-to-end run: the quick sizes of the presets, on the builtin gazebo, with
// images, the quality report and the HTML.
TEST(RunBenchmark, QuickHtmlReport) {
    BenchMatrix m;
    m.scenes = {"builtin:gazebo"};
    m.sizes = {{48, 32}};
    m.ki = {2.0f, 3.0f};
    m.variants = {"none", "inside"};
    m.repeat = 1;
    m.quality = true;
    m.refSamples = 8;
    m.areaSamples = {1, 4};
    const fs::path dir = fs::path(::testing::TempDir()) / ("lm_bench_img_" + std::to_string(getpid()));
    fs::create_directories(dir);
    m.imageDir = dir.string();
    int calls = 0;
    double estimate = -1;
    const BenchReport report = RunBenchmarkReport(
        m, [&](int done, int total, const BenchResult&) { EXPECT_EQ(done, ++calls); EXPECT_EQ(total, 24); },
        [&](double s) { estimate = s; });
    EXPECT_EQ(calls, 24);
    EXPECT_GE(estimate, 0);
    // none, RT, 2 variants × 2 kI, and with --quality the penumbra mode per kI; then the
    // competitors' cells: soft, exact, the LMM default (the matrix has no consensus), area
    // N = 1, 2, 4, …, 256, denoised N = 1, 2, 4 (RT is the matrix's, on the default
    // back-end) and their reference.
    ASSERT_EQ(report.results.size(), 24u);
    int competitors = 0, references = 0;
    for (const BenchResult& r : report.results) {
        competitors += r.role == "competitor";
        references += r.role == "reference";
    }
    EXPECT_EQ(competitors, 15);
    EXPECT_EQ(references, 1);
    int penumbrae = 0;
    for (const BenchResult& r : report.results)
        if (r.method == "penumbra") {
            ++penumbrae;
            EXPECT_FLOAT_EQ(r.lightRadius, report.quality[0].radius);
            EXPECT_GT(Count(r.counters, Lmc::kPenumbraLights), 0u);
        }
    EXPECT_EQ(penumbrae, 2);
    // The penumbra cells' thin check: P's own rays check the nodes' unanimous answers
    // ("all", the default), or not at all with "off".
    for (const BenchResult& r : report.results)
        if (r.method == "penumbra") {
            EXPECT_EQ(r.thinCheck, "all");
            EXPECT_GT(Count(r.counters, Lmc::kThinChecks), 0u);
        }
    EXPECT_NE(BenchCsv(report.results).find(",all,"), std::string::npos);
    ASSERT_EQ(report.quality.size(), 1u);
    EXPECT_EQ(report.quality[0].radii.size(), 3u);
    EXPECT_EQ(report.quality[0].rows.size(), 1u + 4u + 2u + 2u);  // RT, the LMM cells, penumbrae, area N = 1, 4
    const std::string html = BenchHtml(report);
    EXPECT_NE(html.find("<table>"), std::string::npos);
    EXPECT_NE(html.find("<svg"), std::string::npos);
    EXPECT_NE(html.find("data:image/png;base64,"), std::string::npos);
    EXPECT_NE(html.find("СТ/RT"), std::string::npos);  // the ratio table
    EXPECT_NE(html.find("PSNR"), std::string::npos);   // the quality table
    EXPECT_EQ(html.find("http://"), html.find("http://www.w3.org/2000/svg"));  // no network
    EXPECT_NE(BenchQualityMarkdown(report).find("Naive soft shadows"), std::string::npos);
    EXPECT_NE(BenchQualityMarkdown(report).find("Contact-hardening penumbrae"), std::string::npos);
    EXPECT_NE(html.find("light radius"), std::string::npos);  // the penumbra image's caption
    EXPECT_NE(html.find("area-light reference, R ="), std::string::npos);  // beside the reference
    EXPECT_TRUE(fs::exists(report.quality[0].refImage));
    // The competitors' rows (RT, soft, exact, LMM, area N…, denoised N…, reference),
    // their images' captions and their reference's.
    EXPECT_EQ(report.quality[0].competitors.rows.size(), 1u + 1u + 1u + 1u + 9u + 3u + 1u);
    EXPECT_NE(html.find("competitors' soft (default)"), std::string::npos);
    EXPECT_NE(html.find("competitors' area N = 2 + shadow denoiser"), std::string::npos);
    EXPECT_NE(html.find("competitors' area N = 16"), std::string::npos);
    EXPECT_NE(html.find("competitors' reference: area N = 8"), std::string::npos);
    EXPECT_NE(html.find("The default (soft) against its competitors"), std::string::npos);
    EXPECT_NE(html.find("soft is "), std::string::npos);  // the equal-quality verdict
    // The matrix's tables leave the competitors' cells out.
    EXPECT_EQ(BenchMarkdown(report.results).find("soft"), std::string::npos);
    EXPECT_NE(BenchCsv(report.results).find(",competitor,"), std::string::npos);
    EXPECT_NE(BenchJson(report).find("\"equal_quality\""), std::string::npos);
    fs::remove_all(dir);
}

// The default against its competitors on the builtin gazebo (its lights' own radii,
// penumbrae a few pixels wide at 96×72): every row, the reference's shadow total is its
// own, area's PSNR rises with N, and the equal-quality point is filled in.
TEST(RunBenchmark, DefaultAgainstCompetitors) {
    BenchMatrix m;
    m.scenes = {"builtin:gazebo"};
    m.sizes = {{96, 72}};
    m.variants = {"consensus"};
    m.noShadows = false;
    m.penumbrae = false;
    m.repeat = 1;
    m.quality = true;
    m.refSamples = 64;
    m.areaSamples = {1};
    m.competitorSamples = {1, 2, 4, 8, 16, 64};
    const BenchReport report = RunBenchmarkReport(m, nullptr, nullptr);
    ASSERT_EQ(report.quality.size(), 1u);
    const BenchCompetitors& c = report.quality[0].competitors;
    EXPECT_EQ(c.accel, kDefaultAccelerator);
    EXPECT_FALSE(c.radiusOverride);
    ASSERT_EQ(c.lightRadii.size(), 2u);
    EXPECT_GT(c.lightRadii[0], 0.0f);  // the lights' own radii, not R = kI·h
    EXPECT_NE(c.lightRadii[0], report.quality[0].radius);
    // RT and the LMM default are the matrix's own cells (same back-end): not run twice.
    int rt = 0, lmm = 0;
    for (const BenchResult& r : report.results) {
        rt += r.method == "rt";
        lmm += r.method == "lmm";
    }
    EXPECT_EQ(rt, 1);
    EXPECT_EQ(lmm, 1);
    ASSERT_EQ(c.rows.size(), 14u);
    const std::vector<std::string> methods{"rt",   "soft", "exact", "lmm",      "area",     "area",     "area",
                                           "area", "area", "area",  "denoised", "denoised", "denoised", "area"};
    const std::vector<int> samples{0, 0, 0, 0, 1, 2, 4, 8, 16, 64, 1, 2, 4, 64};
    for (size_t i = 0; i < c.rows.size(); ++i) {
        const CompetitorRow& row = c.rows[i];
        EXPECT_EQ(row.method, methods[i]) << i;
        EXPECT_EQ(row.samples, samples[i]) << i;
        EXPECT_EQ(row.reference, i + 1 == c.rows.size()) << i;
        EXPECT_GT(row.seconds, 0) << row.label;
        EXPECT_TRUE(std::isfinite(row.shadowRatio)) << row.label;
        EXPECT_GT(row.psnr, 20) << row.label;
    }
    const CompetitorRow& ref = c.rows.back();
    EXPECT_DOUBLE_EQ(ref.shadowRatio, 1.0);
    EXPECT_EQ(ref.psnr, 99.0);  // equal to itself
    // Area sampling converges: more rays per light, a higher PSNR (strictly, on a scene
    // with penumbrae; the noise halves its power with each doubling, about +3 dB or more).
    for (size_t i = 5; i < 10; ++i) EXPECT_GT(c.rows[i].psnr, c.rows[i - 1].psnr) << c.rows[i].label;
    // Area with the reference's own N is another estimate, not the reference itself: the
    // reference draws its rotations from a stream of its own.
    EXPECT_LT(c.rows[9].psnr, 99.0);
    EXPECT_GT(c.rows[9].psnr, c.rows[8].psnr);
    // The shadow totals of soft, exact and area are near the reference's, RT's too (a hard
    // shadow takes about the light a soft one does).
    for (size_t i : {0, 1, 2, 4, 8, 9, 10, 11, 12}) EXPECT_NEAR(c.rows[i].shadowRatio, 1.0, 0.05) << c.rows[i].label;
    // The denoiser beats its own noisy input: denoised N above area N for N = 1 and 2 (at
    // N = 4 this small image's footprints, shrunk by 1/√N, are under half a pixel, so it is
    // area's image but for the order of the sums).
    for (size_t i = 0; i < 2; ++i) EXPECT_GT(c.rows[10 + i].psnr, c.rows[4 + i].psnr) << c.rows[10 + i].label;
    EXPECT_GE(c.rows[12].psnr, c.rows[6].psnr - 0.01) << c.rows[12].label;
    const EqualQuality& e = c.equal;
    EXPECT_TRUE(e.valid);
    EXPECT_DOUBLE_EQ(e.targetPsnr, c.rows[1].psnr);
    EXPECT_TRUE(std::isfinite(e.samples));
    EXPECT_GE(e.samples, 1.0);
    EXPECT_TRUE(std::isfinite(e.areaSeconds));
    EXPECT_GT(e.areaSeconds, 0);
    EXPECT_DOUBLE_EQ(e.softSeconds, c.rows[1].seconds);
    EXPECT_TRUE(std::isfinite(e.speedup));
    EXPECT_GT(e.speedup, 0);
    EXPECT_DOUBLE_EQ(e.speedup, e.areaSeconds / e.softSeconds);
    // The table, its reference row and the verdict; the CSV's and JSON's figures.
    const std::string md = BenchQualityMarkdown(report);
    EXPECT_NE(md.find("the lights' own radii"), std::string::npos) << md;
    EXPECT_NE(md.find("| reference: area N=64 |"), std::string::npos) << md;
    EXPECT_NE(md.find("| soft (default) |"), std::string::npos) << md;
    EXPECT_NE(md.find("| area N=16 |"), std::string::npos) << md;
    EXPECT_NE(md.find("| area N=1 + denoiser |"), std::string::npos) << md;
    EXPECT_NE(md.find("than area sampling at equal PSNR"), std::string::npos) << md;
    EXPECT_NE(md.find("every light of radius R = kI·h"), std::string::npos) << md;  // the old tables say theirs
    const std::string csv = BenchCsv(report.results);
    EXPECT_NE(csv.find("samples,role,ref_psnr,ref_ssim,shadow_total_ratio"), std::string::npos);
    EXPECT_NE(csv.find(",64,reference,99.000,1.00000,1.0000"), std::string::npos) << csv;
    const std::string json = BenchJson(report);
    EXPECT_NE(json.find("\"speedup\""), std::string::npos);
    EXPECT_NE(json.find("\"shadow_total_ratio\": 1.0"), std::string::npos) << json;

    // --light-radius: every row and the reference at that radius.
    m.lightRadius = 0.3f;
    m.competitorSamples = {1, 4};
    const BenchReport over = RunBenchmarkReport(m, nullptr, nullptr);
    const BenchCompetitors& o = over.quality[0].competitors;
    EXPECT_TRUE(o.radiusOverride);
    EXPECT_EQ(o.lightRadii, (std::vector<float>{0.3f, 0.3f}));
    EXPECT_EQ(o.rows.size(), 10u);
    EXPECT_NE(BenchQualityMarkdown(over).find("every light of radius 0.3 (--light-radius)"), std::string::npos);
}

// The equal-quality point: interpolated in log2 N, extrapolated past the largest N (time
// linear in N), at most the smallest N, or none when PSNR stops rising.
TEST(BenchEqualQuality, InterpolatesInLog2N) {
    const std::vector<AreaPoint> area{{1, 30, 1.0}, {2, 33, 2.0}, {4, 36, 4.0}, {16, 42, 16.0}};
    // Between N = 2 and 4, a third of the way in PSNR: N = 2^(1 + 1/3), time 2 + 2/3.
    EqualQuality e = EqualQualityFrom(area, 34, 0.5);
    EXPECT_TRUE(e.valid);
    EXPECT_FALSE(e.extrapolated);
    EXPECT_NEAR(e.samples, std::exp2(1.0 + 1.0 / 3), 1e-9);
    EXPECT_NEAR(e.areaSeconds, 2.0 + 2.0 / 3, 1e-9);
    EXPECT_NEAR(e.speedup, (2.0 + 2.0 / 3) / 0.5, 1e-9);
    // Exactly at a measured N.
    e = EqualQualityFrom(area, 36, 1.0);
    EXPECT_NEAR(e.samples, 4, 1e-9);
    EXPECT_NEAR(e.areaSeconds, 4, 1e-9);
    // Past N = 16: 3.0103 dB per doubling of N (10·log10 2, the error's variance halves), so
    // one doubling above 42 dB is N = 32; time linear in N through (4, 4 s) and (16, 16 s): 32 s.
    e = EqualQualityFrom(area, 42 + 10 * std::log10(2.0), 2.0);
    EXPECT_TRUE(e.valid);
    EXPECT_TRUE(e.extrapolated);
    EXPECT_NEAR(e.samples, 32, 1e-9);
    EXPECT_NEAR(e.areaSeconds, 32, 1e-9);
    EXPECT_NEAR(e.speedup, 16, 1e-9);
    // Already at N = 1.
    e = EqualQualityFrom(area, 25, 0.5);
    EXPECT_TRUE(e.valid);
    EXPECT_TRUE(e.atMost);
    EXPECT_EQ(e.samples, 1);
    EXPECT_EQ(e.areaSeconds, 1.0);
    // PSNR falling at the end: the slope is the variance's, not the last rows' (which would
    // never reach 40 dB): from N = 4 at 32 dB, 8 dB more is 2^(8 / 3.0103) times the rays.
    e = EqualQualityFrom({{1, 30, 1.0}, {2, 33, 2.0}, {4, 32, 4.0}}, 40, 1.0);
    EXPECT_TRUE(e.valid);
    EXPECT_TRUE(e.extrapolated);
    EXPECT_NEAR(e.samples, 4 * std::exp2(8 / (10 * std::log10(2.0))), 1e-3);
    // A single row has no time slope to extrapolate along.
    e = EqualQualityFrom({{4, 32, 4.0}}, 40, 1.0);
    EXPECT_FALSE(e.valid);
    EXPECT_TRUE(e.extrapolated);
    // The order of the points does not matter.
    e = EqualQualityFrom({{16, 42, 16.0}, {1, 30, 1.0}, {4, 36, 4.0}, {2, 33, 2.0}}, 34, 0.5);
    EXPECT_NEAR(e.samples, std::exp2(1.0 + 1.0 / 3), 1e-9);
}

// --thin-check off: the penumbra cells trace no checking rays (the default's do, above).
TEST(RunBenchmark, ThinCheckOffReachesThePenumbraCells) {
    BenchMatrix m;
    m.scenes = {"builtin:gazebo"};
    m.sizes = {{48, 32}};
    m.variants = {"consensus"};
    m.noShadows = false;
    m.repeat = 1;
    m.quality = true;
    m.refSamples = 4;
    m.areaSamples = {1};
    m.thinCheck = "off";
    const BenchReport report = RunBenchmarkReport(m, nullptr, nullptr);
    int penumbrae = 0;
    for (const BenchResult& r : report.results)
        if (r.method == "penumbra") {
            ++penumbrae;
            EXPECT_EQ(r.thinCheck, "off");
            EXPECT_GT(Count(r.counters, Lmc::kPenumbraLights), 0u);
            EXPECT_EQ(Count(r.counters, Lmc::kThinChecks), 0u);
        }
    EXPECT_EQ(penumbrae, 1);
    EXPECT_NE(BenchQualityMarkdown(report).find("thin check off"), std::string::npos);
}

}  // namespace
}  // namespace benchmark_test
}  // namespace lm
