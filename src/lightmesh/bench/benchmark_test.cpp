#include "lightmesh/bench/benchmark.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "lightmesh/shadow/light_mesh_counters.h"
#include "lightmesh/util/error.h"

namespace lm {
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
        m, [&](int done, int total, const BenchResult&) { EXPECT_EQ(done, ++calls); EXPECT_EQ(total, 8); },
        [&](double s) { estimate = s; });
    EXPECT_EQ(calls, 8);
    EXPECT_GE(estimate, 0);
    // none, RT, 2 variants × 2 kI, and with --quality the penumbra mode per kI.
    ASSERT_EQ(report.results.size(), 8u);
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
    fs::remove_all(dir);
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
}  // namespace lm
