#include "lightmesh/shadow/sphere_templates.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include <unistd.h>

#include "lightmesh/util/error.h"

namespace lm {
namespace sphere_templates_test {
namespace {

namespace fs = std::filesystem;
using Offset = std::array<int8_t, 3>;

std::set<Offset> Entries(const SphereTemplates& t, int s, bool boundaryOnly = false) {
    const uint32_t end = boundaryOnly ? t.begin[s] + t.boundaryCount[s] : t.begin[s + 1];
    return {t.offsets.begin() + t.begin[s], t.offsets.begin() + end};
}

// For P exactly on a sub-position, the template is the set the cube loop finds with exact
// distances. With h = 1 and ns a power of two every coordinate and squared distance below
// is exact in float, as is kI² for these kI, so the sets must match exactly.
TEST(SphereTemplates, MatchTheCubeLoopAtSubPositions) {
    for (float ki : {1.5f, 2.0f, 3.0f}) {
        for (int ns : {1, 4, 8}) {
            const SphereTemplates t = SphereTemplates::Build(ns, ki);
            for (int c = 0; c <= ns; ++c)
                for (int b = 0; b <= ns; ++b)
                    for (int a = 0; a <= ns; ++a) {
                        const float px = static_cast<float>(a) / ns, py = static_cast<float>(b) / ns,
                                    pz = static_cast<float>(c) / ns;
                        std::set<Offset> cube;
                        for (int k = -5; k <= 5; ++k)
                            for (int j = -5; j <= 5; ++j)
                                for (int i = -5; i <= 5; ++i) {
                                    const float dx = i - px, dy = j - py, dz = k - pz;
                                    if (dx * dx + dy * dy + dz * dz <= ki * ki)
                                        cube.insert({static_cast<int8_t>(i), static_cast<int8_t>(j), static_cast<int8_t>(k)});
                                }
                        ASSERT_EQ(Entries(t, t.SubPosition(a, b, c)), cube)
                            << "kI " << ki << " ns " << ns << " sub-position " << a << "," << b << "," << c;
                    }
        }
    }
}

// The boundary nodes are listed first and are exactly those with a lattice neighbour
// outside the set; no entry repeats.
TEST(SphereTemplates, BoundaryIsTheOuterShell) {
    const SphereTemplates t = SphereTemplates::Build(4, 2.5f);
    for (int s = 0; s < t.SubPositionCount(); ++s) {
        const std::set<Offset> all = Entries(t, s), boundary = Entries(t, s, true);
        ASSERT_EQ(all.size(), t.begin[s + 1] - t.begin[s]) << "duplicates";
        for (const Offset& o : all) {
            int outside = 0;
            for (int axis = 0; axis < 3; ++axis)
                for (int step : {-1, 1}) {
                    Offset n = o;
                    n[axis] = static_cast<int8_t>(n[axis] + step);
                    outside += !all.count(n);
                }
            EXPECT_EQ(boundary.count(o) == 1, outside > 0);
        }
        EXPECT_GT(boundary.size(), 0u);
        EXPECT_LT(boundary.size(), all.size());
    }
}

// The build goes row by row of the lattice (an interval of di per row) instead of
// testing every node of the cube and its six neighbours; the lists, their order and their
// boundaries are those of the cube loop, for odd ns and kI that are not dyadic too.
TEST(SphereTemplates, RowBuildIsTheCubeLoopsEntryForEntry) {
    for (float ki : {0.01f, 0.5f, 1.0f, 1.7f, 2.0f, 3.3f, 5.0f}) {
        for (int ns : {1, 3, 5, 8}) {
            const SphereTemplates t = SphereTemplates::Build(ns, ki);
            const double limit2 = static_cast<double>(ki) * ns * static_cast<double>(ki) * ns;
            const int reach = static_cast<int>(std::ceil(ki)) + 1;
            auto inside = [&](int a, int b, int c, int di, int dj, int dk) {
                const double x = di * ns - a, y = dj * ns - b, z = dk * ns - c;
                return x * x + y * y + z * z <= limit2;
            };
            std::vector<Offset> expected;
            std::vector<uint32_t> begin, boundaryCount;
            for (int c = 0; c <= ns; ++c)
                for (int b = 0; b <= ns; ++b)
                    for (int a = 0; a <= ns; ++a) {
                        std::vector<Offset> boundary, inner;
                        for (int dk = -reach; dk <= reach; ++dk)
                            for (int dj = -reach; dj <= reach; ++dj)
                                for (int di = -reach; di <= reach; ++di) {
                                    if (!inside(a, b, c, di, dj, dk)) continue;
                                    const bool shell = !inside(a, b, c, di - 1, dj, dk) || !inside(a, b, c, di + 1, dj, dk) ||
                                                       !inside(a, b, c, di, dj - 1, dk) || !inside(a, b, c, di, dj + 1, dk) ||
                                                       !inside(a, b, c, di, dj, dk - 1) || !inside(a, b, c, di, dj, dk + 1);
                                    (shell ? boundary : inner)
                                        .push_back({static_cast<int8_t>(di), static_cast<int8_t>(dj), static_cast<int8_t>(dk)});
                                }
                        begin.push_back(static_cast<uint32_t>(expected.size()));
                        boundaryCount.push_back(static_cast<uint32_t>(boundary.size()));
                        expected.insert(expected.end(), boundary.begin(), boundary.end());
                        expected.insert(expected.end(), inner.begin(), inner.end());
                    }
            begin.push_back(static_cast<uint32_t>(expected.size()));
            ASSERT_EQ(t.offsets, expected) << "ns " << ns << " kI " << ki;
            ASSERT_EQ(t.begin, begin);
            ASSERT_EQ(t.boundaryCount, boundaryCount);
        }
    }
}

// The size is estimated first (within a few per cent), and what does not fit the memory
// budget or the 32-bit index is refused at once, saying what would fit (`templates --ns 64
// --ki 16` would otherwise run for minutes and take 5 GB before saying anything).
TEST(SphereTemplates, SizeIsEstimatedAndRefusedBeforeBuilding) {
    for (const auto& [ns, ki] : std::vector<std::pair<int, float>>{{8, 2.0f}, {3, 0.7f}, {16, 4.5f}, {1, 16.0f}}) {
        const TemplateEstimate e = EstimateSphereTemplates(ns, ki);
        const double built = static_cast<double>(SphereTemplates::Build(ns, ki).offsets.size());
        EXPECT_NEAR(static_cast<double>(e.entries), built, 0.03 * built) << "ns " << ns << " kI " << ki;
        EXPECT_EQ(e.subPositions, static_cast<uint64_t>((ns + 1) * (ns + 1) * (ns + 1)));
    }
    const auto start = std::chrono::steady_clock::now();
    try {
        CheckSphereTemplateBudget(64, 16.0f);
        FAIL() << "no error";
    } catch (const Error& e) {
        const std::string m = e.what();
        EXPECT_EQ(m.rfind("templates ns 64, kI 16: about 4,", 0), 0u) << m;
        EXPECT_NE(m.find("more than the 4,294,967,295 their 32-bit index holds"), std::string::npos) << m;
        EXPECT_NE(m.find("with kI 16, ns up to 6"), std::string::npos) << m;
    }
    // A budget of 64 MiB (half of LIGHTMESH_MEMORY_LIMIT's 128 MiB): ns 8, kI 2 (82 K
    // entries) fits, ns 32, kI 16 (616 M) does not, and neither do its suggestions' next steps.
    setenv("LIGHTMESH_MEMORY_LIMIT", "128M", 1);
    EXPECT_NO_THROW(CheckSphereTemplateBudget(8, 2.0f));
    try {
        CheckSphereTemplateBudget(32, 16.0f);
        FAIL() << "no error";
    } catch (const Error& e) {
        const std::string m = e.what();
        EXPECT_EQ(m.rfind("templates ns 32, kI 16 would need about 1.7 GiB (6", 0), 0u) << m;
        // 64 MiB / 3 bytes = 22 M entries: (9 + 1)³ spheres of 17,136 nodes at kI 16; at
        // ns 32, 622 nodes per sphere, kI 5.29.
        EXPECT_NE(m.find("more than half of this machine's 128.0 MiB (LIGHTMESH_MEMORY_LIMIT); with kI 16, ns up to 9 "
                         "fits; with ns 32, kI up to 5.2"),
                  std::string::npos)
            << m;
    }
    EXPECT_NO_THROW(CheckSphereTemplateBudget(9, 16.0f));
    EXPECT_THROW(CheckSphereTemplateBudget(10, 16.0f), Error);
    EXPECT_NO_THROW(CheckSphereTemplateBudget(32, 5.2f));
    EXPECT_THROW(LoadOrBuildSphereTemplates(32, 16.0f, ""), Error);
    unsetenv("LIGHTMESH_MEMORY_LIMIT");
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 2.0);
}

TEST(SphereTemplates, BadParametersAreErrors) {
    EXPECT_THROW(SphereTemplates::Build(0, 2.0f), Error);
    EXPECT_THROW(SphereTemplates::Build(65, 2.0f), Error);
    EXPECT_THROW(SphereTemplates::Build(8, 0.0f), Error);
    EXPECT_THROW(SphereTemplates::Build(8, 17.0f), Error);
}

class TemplateFiles : public ::testing::Test {
  protected:
    void SetUp() override {
        dir_ = fs::path(::testing::TempDir()) / ("lm_templates_" + std::to_string(getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    std::string Path() const { return TemplateFileName(dir_.string(), 4, 2.0f); }
    std::string Bytes() const {
        std::ifstream in(Path(), std::ios::binary);
        return {std::istreambuf_iterator<char>(in), {}};
    }
    void Overwrite(const std::string& bytes) const {
        std::ofstream(Path(), std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    }
    fs::path dir_;
};

TEST_F(TemplateFiles, WrittenAndReadBackIdentical) {
    const SphereTemplates t = SphereTemplates::Build(4, 2.0f);
    WriteSphereTemplates(Path(), t);
    EXPECT_EQ(ReadSphereTemplates(Path(), 4, 2.0f), t);
    // The cache: first built and written, then loaded.
    const TemplateLoad first = LoadOrBuildSphereTemplates(4, 2.0f, (dir_ / "cache").string());
    EXPECT_FALSE(first.loaded);
    EXPECT_TRUE(first.written);
    EXPECT_TRUE(first.note.empty()) << first.note;
    const TemplateLoad second = LoadOrBuildSphereTemplates(4, 2.0f, (dir_ / "cache").string());
    EXPECT_TRUE(second.loaded);
    EXPECT_EQ(second.templates, t);
}

TEST_F(TemplateFiles, DamagedFilesAreDetectedRebuiltAndReplaced) {
    const SphereTemplates fresh = SphereTemplates::Build(4, 2.0f);
    WriteSphereTemplates(Path(), fresh);
    const std::string good = Bytes();
    struct Damage {
        const char* name;
        std::string bytes;
        const char* reason;
    };
    std::string flipped = good;
    flipped[flipped.size() / 2] ^= 0x10;
    std::string version = good;
    version[8] = 7;  // the format version follows the 8-byte magic
    std::string foreign = good;
    foreign[0] = 'X';
    const Damage cases[] = {
        {"truncated", good.substr(0, good.size() / 2), "expected"},
        {"empty", "", "truncated"},
        {"bit flip", flipped, "checksum"},
        {"wrong version", version, "format version 7"},
        {"foreign", foreign, "not a lightmesh template file"},
    };
    for (const Damage& d : cases) {
        Overwrite(d.bytes);
        try {
            ReadSphereTemplates(Path(), 4, 2.0f);
            ADD_FAILURE() << d.name << ": no error";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find(d.reason), std::string::npos) << d.name << ": " << e.what();
        }
        const TemplateLoad load = LoadOrBuildSphereTemplates(4, 2.0f, dir_.string());
        EXPECT_FALSE(load.loaded) << d.name;
        EXPECT_TRUE(load.written) << d.name;
        EXPECT_NE(load.note.find("rebuilding"), std::string::npos) << d.name << ": " << load.note;
        EXPECT_EQ(load.templates, fresh) << d.name;
        EXPECT_EQ(Bytes(), good) << d.name << ": the file was not replaced";
    }
    // Templates for other parameters are foreign too.
    WriteSphereTemplates(Path(), SphereTemplates::Build(4, 2.5f));
    EXPECT_THROW(ReadSphereTemplates(Path(), 4, 2.0f), Error);
}

// A forged file whose checksum was recomputed (WriteSphereTemplates writes any
// templates with a valid checksum) is refused for each invariant the light mesh relies on,
// and rebuilt.
TEST_F(TemplateFiles, ForgedFilesWithAValidChecksumAreRefused) {
    const SphereTemplates fresh = SphereTemplates::Build(4, 2.0f);
    const int s = fresh.SubPosition(1, 2, 3);
    const uint32_t first = fresh.begin[s], inner = first + fresh.boundaryCount[s];
    struct Forgery {
        const char* name;
        SphereTemplates t;
        const char* reason;
    };
    std::vector<Forgery> cases;
    {
        SphereTemplates t = fresh;  // a node outside the sphere, still within the cube's reach
        t.offsets[first] = {3, 3, 3};
        cases.push_back({"outside the sphere", t, "outside the interpolation sphere"});
    }
    {
        SphereTemplates t = fresh;  // two boundary nodes swapped
        std::swap(t.offsets[first], t.offsets[first + 1]);
        cases.push_back({"unsorted", t, "out of order or repeated"});
    }
    {
        SphereTemplates t = fresh;  // a node listed twice, its neighbour missing
        t.offsets[first + 1] = t.offsets[first];
        cases.push_back({"repeated", t, "out of order or repeated"});
    }
    {
        SphereTemplates t = fresh;  // an inner node counted as boundary
        t.boundaryCount[s] += 1;
        cases.push_back({"boundary not the shell", t, "not the sphere's shell"});
    }
    {
        SphereTemplates t = fresh;  // the last inner node dropped (indices kept consistent)
        t.offsets.erase(t.offsets.begin() + (fresh.begin[s + 1] - 1));
        for (size_t k = static_cast<size_t>(s) + 1; k < t.begin.size(); ++k) --t.begin[k];
        cases.push_back({"a node missing", t, "whose sphere holds"});
    }
    ASSERT_LT(first + 1, inner);
    for (const Forgery& f : cases) {
        WriteSphereTemplates(Path(), f.t);
        try {
            ReadSphereTemplates(Path(), 4, 2.0f);
            ADD_FAILURE() << f.name << ": no error";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find(f.reason), std::string::npos) << f.name << ": " << e.what();
        }
        const TemplateLoad load = LoadOrBuildSphereTemplates(4, 2.0f, dir_.string());
        EXPECT_FALSE(load.loaded) << f.name;
        EXPECT_EQ(load.templates, fresh) << f.name;
    }
}

TEST_F(TemplateFiles, UnwritableCacheStillGivesTemplates) {
    const TemplateLoad load = LoadOrBuildSphereTemplates(4, 2.0f, "/proc/no-such-folder/lightmesh");
    EXPECT_FALSE(load.written);
    EXPECT_NE(load.note.find("cannot cache templates"), std::string::npos) << load.note;
    EXPECT_EQ(load.templates, SphereTemplates::Build(4, 2.0f));
}

// `templates --measure`'s study, which chose the default ns (README: 4.4 % of a sphere's
// nodes change at ns 8, kI 2; 8.9 % at ns 4; 2.3 % at ns 16).
TEST(SphereTemplates, SnappingErrorFallsWithNsAsTheReadmeSays) {
    const TemplateSnapError e4 = MeasureTemplateSnapping(4, 2.0f, 4000), e8 = MeasureTemplateSnapping(8, 2.0f, 4000),
                            e16 = MeasureTemplateSnapping(16, 2.0f, 4000);
    EXPECT_NEAR(e8.mismatchedShare, 0.044, 0.006);
    EXPECT_NEAR(e4.mismatchedShare, 0.089, 0.01);
    EXPECT_NEAR(e16.mismatchedShare, 0.023, 0.005);
    EXPECT_GT(e16.entries, e8.entries);
    EXPECT_EQ(e8.entries, SphereTemplates::Build(8, 2.0f).offsets.size());
}

}  // namespace
}  // namespace sphere_templates_test
}  // namespace lm
