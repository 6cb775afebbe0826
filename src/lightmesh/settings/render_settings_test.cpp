#include "lightmesh/settings/render_settings.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <set>
#include <stdexcept>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/settings/options.h"
#include "lightmesh/shadow/shadow.h"

namespace lm {
namespace render_settings_test {
namespace {

TEST(RenderSettings, ChoicesAreTheOnesTheFactoriesAccept) {
    EXPECT_EQ(RenderSettingFor("shadows").choices, ShadowMethodNames());
    EXPECT_EQ(RenderSettingFor("accel").choices, AcceleratorNames());
    EXPECT_NE(RenderSettingFor("accel").help.find(std::string("default ") + kDefaultAccelerator), std::string::npos);
    EXPECT_THROW(RenderSettingFor("no_such_knob"), std::logic_error);
}

TEST(RenderSettings, RowsAreWellFormed) {
    std::set<std::string> keys, flags;
    for (const RenderSetting& s : RenderSettings()) {
        SCOPED_TRACE(s.key);
        EXPECT_TRUE(keys.insert(s.key).second) << "duplicate key";
        EXPECT_TRUE(flags.insert(s.flag).second) << "duplicate flag";
        EXPECT_EQ(std::string(s.flag).rfind("--", 0), 0u);
        EXPECT_FALSE(s.help.empty());
        if (s.kind == RenderSetting::Kind::Int || s.kind == RenderSetting::Kind::Float) {
            EXPECT_LE(s.lo, s.hi);
        }
        EXPECT_EQ(s.kind == RenderSetting::Kind::Choice, !s.choices.empty());
    }
}

// `render --help` shows each knob's default: the help text names it, and it is
// the default RenderOptions' value.
TEST(RenderSettings, HelpNamesEachDefault) {
    for (const RenderSetting& s : RenderSettings()) {
        SCOPED_TRACE(s.key);
        EXPECT_NE(s.help.find("default"), std::string::npos) << s.help;
    }
    const RenderOptions o;
    auto names = [](const char* key, const std::string& text) {
        EXPECT_NE(RenderSettingFor(key).help.find(text), std::string::npos)
            << key << ": " << RenderSettingFor(key).help << "\nlacks: " << text;
    };
    names("width", "default " + std::to_string(o.width));
    names("height", "default " + std::to_string(o.height));
    names("aa", "default " + std::to_string(o.aa));
    names("max_depth", "default " + std::to_string(o.maxDepth));
    names("shadows", "default " + o.shadows);
    names("grid", "default " + std::to_string(o.accelOptions.gridResolution));
    names("cc", "default " + std::to_string(o.lightMesh.cc) + " for lmm, " + std::to_string(o.soft.cc) + " for exact");
    names("ki", "default 2");
    EXPECT_EQ(o.lightMesh.ki, 2.0f);
    names("cell_summaries", "default " + o.lightMesh.cellSummaries);
    names("thin_check", "default " + o.lightMesh.thinCheck);
    names("samples", "default " + std::to_string(o.areaLight.samples));
    // 0 is each soft method's own default.
    EXPECT_EQ(o.soft.samples, 0);
    names("soft_samples", "default " + std::to_string(kSoftFrameSamples) + ")");
    names("soft_samples", "default " + std::to_string(kExactSoftSamples) + ")");
}

// Which knobs a method or back-end uses is the table's: a flag given for a render that does
// not use it gets one warning naming the users; a knob every render uses, none.
TEST(RenderSettings, UnusedFlagsAreNamedByTheTable) {
    EXPECT_EQ(UnusedSettingWarning("cc", "rt"), "--cc is not used by --shadows rt (only by lmm and exact); ignored");
    EXPECT_EQ(UnusedSettingWarning("cc", "lmm"), "");
    EXPECT_EQ(UnusedSettingWarning("light_radius", "none"),
              "--light-radius is not used by --shadows none (only by soft, exact, area, denoised and lmm); ignored");
    EXPECT_EQ(UnusedSettingWarning("light_radius", "area"), "");
    EXPECT_EQ(UnusedSettingWarning("samples", "lmm"), "--samples is not used by --shadows lmm (only by area and denoised); ignored");
    EXPECT_EQ(UnusedSettingWarning("grid", "embree"), "--grid is not used by --accel embree (only by grid); ignored");
    EXPECT_EQ(UnusedSettingWarning("grid", "grid"), "");
    EXPECT_EQ(UnusedSettingWarning("width", "anything"), "");
    for (const RenderSetting& s : RenderSettings()) {
        SCOPED_TRACE(s.key);
        if (!s.usedWith) {
            EXPECT_TRUE(s.usedBy.empty());
            continue;
        }
        // usedWith names a choice row, and every user is one of its choices.
        const RenderSetting& with = RenderSettingFor(s.usedWith);
        ASSERT_EQ(with.kind, RenderSetting::Kind::Choice);
        ASSERT_FALSE(s.usedBy.empty());
        for (const std::string& user : s.usedBy) {
            EXPECT_NE(std::find(with.choices.begin(), with.choices.end(), user), with.choices.end()) << user;
            EXPECT_EQ(UnusedSettingWarning(s.key, user), "");
        }
    }
}

// A factory's error in a knob's value names where the value came from: the flag, the
// scene file's key, or nothing for a default.
TEST(RenderSettings, FactoryErrorsNameTheValuesOrigin) {
    RenderOptions options;
    auto fail = [] { ThrowSettingError("variant", "unknown light-mesh variant \"%s\"", "x"); };
    auto message = [&] {
        try {
            NamingOrigins(options, fail);
        } catch (const Error& e) {
            return std::string(e.what());
        }
        return std::string("<no error>");
    };
    EXPECT_EQ(message(), "unknown light-mesh variant \"x\"");
    options.origins["variant"] = SourceLoc("scene.json", 0, 0, "/render/variant");
    EXPECT_EQ(message(), "scene.json /render/variant: unknown light-mesh variant \"x\"");
    options.origins["variant"] = SourceLoc::Option("--variant");
    EXPECT_EQ(message(), "--variant: unknown light-mesh variant \"x\"");
    // Other errors pass unchanged; a value passes through.
    EXPECT_THROW(NamingOrigins(options, [] { ThrowError("other"); }), Error);
    EXPECT_EQ(NamingOrigins(options, [] { return 7; }), 7);
}

// The README documents every knob: its flag in the table of `render` options, its key in
// the scene file's "render" row.
TEST(RenderSettings, TheReadmeListsEveryRow) {
    std::ifstream in(LIGHTMESH_README);
    ASSERT_TRUE(in) << LIGHTMESH_README;
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const size_t optionsBegin = text.find("`render` options");
    const size_t optionsEnd = text.find("\n\n", text.find("| option | meaning |", optionsBegin));
    ASSERT_NE(optionsBegin, std::string::npos);
    ASSERT_NE(optionsEnd, std::string::npos);
    const std::string options = text.substr(optionsBegin, optionsEnd - optionsBegin);
    const size_t row = text.find("| `render` |");
    ASSERT_NE(row, std::string::npos);
    const std::string renderRow = text.substr(row, text.find('\n', row) - row);
    for (const RenderSetting& s : RenderSettings()) {
        EXPECT_NE(options.find(std::string("`") + s.flag), std::string::npos) << s.flag << " is not in the README's options";
        EXPECT_NE(renderRow.find(std::string("`") + s.key + "`"), std::string::npos)
            << s.key << " is not in the README's \"render\" row";
    }
}

}  // namespace
}  // namespace render_settings_test
}  // namespace lm
