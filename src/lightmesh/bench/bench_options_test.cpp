// bench_options_test.cpp -- `bench`'s options into its matrix, as the CLI and the Python
// module give them: presets, --quick, the checks and how they name the option, and the
// keywords lightmesh.bench() takes against the CLI's options.
#include "lightmesh/bench/bench_options.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <limits>
#include <regex>
#include <set>

#include "lightmesh/util/error.h"
#include "run_lightmesh.h"

namespace lm {
namespace bench_options_test {
namespace {

std::string Message(const BenchOptions& o) {
    try {
        MakeBenchMatrix(o);
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

TEST(BenchOptions, QuickAndNoNoneAndTheLimit) {
    BenchOptions o;
    o.sizes = {"400x300", "64X48"};
    o.quick = true;
    o.noNone = true;
    BenchMatrix m = MakeBenchMatrix(o);
    EXPECT_EQ(m.sizes, (std::vector<std::pair<int, int>>{{100, 75}, {16, 12}}));
    EXPECT_EQ(m.repeat, 1);
    EXPECT_FALSE(m.noShadows);
    EXPECT_EQ(m.maxSeconds, kBenchLimitSeconds);
    o.matrix.repeat = 5;
    o.given = {"repeat"};
    o.force = true;
    m = MakeBenchMatrix(o);
    EXPECT_EQ(m.repeat, 5);  // given: --quick leaves it
    EXPECT_EQ(m.maxSeconds, 0);
}

TEST(BenchOptions, ChecksNameTheOptionAsTheFrontEndSpellsIt) {
    BenchOptions o;
    o.matrix.cc = {100, 0};
    EXPECT_EQ(Message(o), "--cc: must be between 1 and 4096, got 0");
    o.keywords = true;
    EXPECT_EQ(Message(o), "cc=: must be between 1 and 4096, got 0");
    o.matrix.cc = {100};
    o.sizes = {"12x"};
    EXPECT_EQ(Message(o), "size= 12x: expected WIDTHxHEIGHT, e.g. 1024x768");
    o.sizes = {"12x12abc"};
    EXPECT_NE(Message(o), "");
    o.sizes = {};
    o.matrix.cellSummaries = "sometimes";
    EXPECT_EQ(Message(o), "cell_summaries=: \"sometimes\" is not one of auto, on, off");
    o.matrix.cellSummaries = "auto";
    o.matrix.ki = {std::numeric_limits<float>::quiet_NaN()};
    EXPECT_EQ(Message(o), "ki=: must be between 0.01 and 16, got nan");
    o.matrix.ki = {2};
    o.keywords = false;
    o.given = {"scene", "table"};
    o.table = 1;
    EXPECT_EQ(Message(o), "--scene cannot be combined with --table");
    o.given = {"variants"};
    o.table = 0;
    o.matrix.variants = {"grid", ""};
    EXPECT_EQ(Message(o).rfind("--variants: an empty name in the list", 0), 0u) << Message(o);
}

TEST(BenchOptions, TablePresetKeepsTheOptionsThatStillApply) {
#ifdef LIGHTMESH_TEST_DATA
    BenchOptions o;
    o.repoDir = std::filesystem::path(LIGHTMESH_TEST_DATA).parent_path().parent_path().string();
    o.table = 3;
    o.quick = true;
    o.given = {"table"};
    o.matrix.quality = true;
    o.matrix.refSamples = 32;
    const BenchMatrix m = MakeBenchMatrix(o);
    EXPECT_EQ(m.sizes, (std::vector<std::pair<int, int>>{{256, 256}}));
    EXPECT_EQ(m.accels, std::vector<std::string>{"grid"});  // the paper's back-end
    EXPECT_TRUE(m.quality);
    EXPECT_EQ(m.refSamples, 32);
    ASSERT_FALSE(m.ccOrigins.empty());
    EXPECT_EQ(m.ccOrigins[0].Format(), "bench --table 3");
#endif
}

// Every option of `lightmesh bench --help` that shapes the matrix is a keyword of
// lightmesh.bench(), and no keyword is missing from the CLI (the outputs and -q are the
// CLI's own; threads is a call keyword).
TEST(BenchOptions, KeywordsAreTheClisOptions) {
    const testing::CliResult r = testing::RunLightmesh("bench --help");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    std::set<std::string> cli;
    const std::regex flag("--([a-z][a-z-]*)");
    for (auto it = std::sregex_iterator(r.output.begin(), r.output.end(), flag); it != std::sregex_iterator(); ++it) {
        std::string key = (*it)[1];
        std::replace(key.begin(), key.end(), '-', '_');
        cli.insert(key);
    }
    for (const char* own : {"help", "csv", "markdown", "html", "json", "quiet", "verbose", "threads"}) cli.erase(own);
    std::set<std::string> keywords;
    for (const BenchOptionInfo& info : BenchOptionTable()) keywords.insert(info.key);
    EXPECT_EQ(keywords, cli);
}

}  // namespace
}  // namespace bench_options_test
}  // namespace lm
