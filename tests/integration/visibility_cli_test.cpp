// `lightmesh render --visibility FILE.exr`: one float channel per light, the values the
// renderer hands out in process, the image unchanged; bad paths refused before the render.
#include <gtest/gtest.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "lightmesh/io/channels_exr.h"
#include "lightmesh/render/render_job.h"
#include "lightmesh/scene/scene_file.h"
#include "run_lightmesh.h"

namespace visibility_cli_test {
namespace {

namespace fs = std::filesystem;

std::string Temp(const std::string& name) { return lm::testing::TestTempPath("lm_visibility_cli", name); }

/// The file's channel names (in the file's order: by name) and its values, interleaved in
/// that order.
std::vector<float> ReadChannels(const std::string& path, std::vector<std::string>* names, int* w, int* h) {
    Imf::InputFile file(path.c_str());
    const auto box = file.header().dataWindow();
    *w = box.max.x - box.min.x + 1, *h = box.max.y - box.min.y + 1;
    names->clear();
    for (auto c = file.header().channels().begin(); c != file.header().channels().end(); ++c) names->push_back(c.name());
    const size_t n = names->size();
    std::vector<float> values(static_cast<size_t>(*w) * static_cast<size_t>(*h) * n);
    Imf::FrameBuffer fb;
    char* base = reinterpret_cast<char*>(values.data());
    for (size_t c = 0; c < n; ++c)
        fb.insert((*names)[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), n * sizeof(float), n * sizeof(float) * *w));
    file.setFrameBuffer(fb);
    file.readPixels(box.min.y, box.max.y);
    return values;
}

TEST(CliVisibility, WritesTheRenderersValuesOneChannelPerLight) {
    lm::SceneLoadOptions load;
    std::vector<std::string> warnings;
    const lm::Scene scene = lm::LoadScene("builtin:gazebo", load, &warnings);
    for (const char* shadows : {"soft", "rt"}) {
        const std::string image = Temp(std::string("img-") + shadows + ".exr"),
                          plain = Temp(std::string("plain-") + shadows + ".exr"),
                          vis = Temp(std::string("vis-") + shadows + ".exr");
        const std::string common = std::string("render builtin:gazebo --width 48 --height 36 -q --shadows ") + shadows;
        ASSERT_EQ(lm::testing::RunLightmesh(common + " -o " + image + " --visibility " + vis).exitCode, 0);
        ASSERT_EQ(lm::testing::RunLightmesh(common + " -o " + plain).exitCode, 0);
        EXPECT_EQ(lm::testing::FileBytes(image), lm::testing::FileBytes(plain)) << shadows;

        std::vector<std::string> names;
        int w = 0, h = 0;
        const std::vector<float> got = ReadChannels(vis, &names, &w, &h);
        EXPECT_EQ(names, lm::LightChannelNames(scene.lights.size()));
        EXPECT_EQ(w, 48);
        EXPECT_EQ(h, 36);

        lm::RenderOptions o = scene.render;
        o.width = 48, o.height = 36, o.shadows = shadows;
        const lm::RenderJob job(scene, o);
        lm::VisibilityImage expected = job.MakeVisibility();
        job.Render(nullptr, &expected);
        ASSERT_EQ(got.size(), expected.values.size());
        EXPECT_EQ(std::memcmp(got.data(), expected.values.data(), got.size() * sizeof(float)), 0) << shadows;
    }
}

TEST(CliVisibility, BadPathsAreRefusedBeforeTheRender) {
    const std::string out = Temp("never.png");
    fs::remove(out);
    struct Case {
        std::string flags, message;
    } cases[] = {
        {"--visibility " + Temp("v.png"), "--visibility: must be an .exr file"},
        {"--visibility " + out, "--visibility: must be an .exr file"},
        {"--visibility " + Temp("same.exr") + " -o " + Temp("same.exr"), "the same file as the image"},
        {"--visibility " + Temp("no_such_folder/v.exr"), "no_such_folder"},
        {"--visibility " + Temp(""), "folder"},
    };
    for (const Case& c : cases) {
        const std::string flags = c.flags.find(" -o ") == std::string::npos ? c.flags + " -o " + out : c.flags;
        const lm::testing::CliResult r =
            lm::testing::RunLightmesh("render builtin:gazebo --width 16 --height 12 -q " + flags);
        EXPECT_EQ(r.exitCode, 1) << flags;
        EXPECT_NE(r.output.find(c.message), std::string::npos) << r.output;
        EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
        EXPECT_FALSE(fs::exists(out));
    }
}

}  // namespace
}  // namespace visibility_cli_test
