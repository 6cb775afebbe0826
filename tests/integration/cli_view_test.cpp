// End-to-end tests of `render`'s view options (the camera from the command line, --up for a
// bare mesh, --width or --height alone), exposure and tone curves, and the command line's
// habits (a repeated option, options before the command, the same short names everywhere).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "lightmesh/io/image.h"
#include "run_lightmesh.h"

namespace cli_view_test {
namespace {

namespace fs = std::filesystem;
using CliRun = lm::testing::CliResult;

CliRun Lightmesh(const std::string& args) { return lm::testing::RunLightmesh(args); }

std::string Temp(const std::string& name) { return lm::testing::TestTempPath("lm_cli_view", name); }

// A red box 1 x 1 x 4, tall along z (a Z-up model standing), beside a grey ground: its
// pixels are the only ones with red and no green (the lights are white, the ground grey).
std::string TallRedBox() {
    const std::string obj = Temp("tall.obj");
    std::ofstream(Temp("tall.mtl")) << "newmtl red\nKd 1 0 0\n";
    std::ofstream(obj) << "mtllib tall.mtl\nusemtl red\n"
                          "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 4\nv 1 0 4\nv 1 1 4\nv 0 1 4\n"
                          "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\n"
                          "f 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
    return obj;
}

// The box's pixels in an image: their bounding box and centre.
struct Silhouette {
    int x0 = 1 << 30, y0 = 1 << 30, x1 = -1, y1 = -1;
    double cx = 0, cy = 0;
    int count = 0;
    int Width() const { return x1 - x0 + 1; }
    int Height() const { return y1 - y0 + 1; }
};

Silhouette RedPixels(const std::string& exr) {
    const lm::Image image = lm::ReadImage(exr);
    Silhouette s;
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x) {
            const lm::Color& c = image.At(x, y);
            if (!(c.r > 0.01f && c.g < 0.001f * c.r)) continue;
            s.x0 = std::min(s.x0, x), s.x1 = std::max(s.x1, x), s.y0 = std::min(s.y0, y), s.y1 = std::max(s.y1, y);
            s.cx += x + 0.5, s.cy += y + 0.5;
            ++s.count;
        }
    if (s.count) s.cx /= s.count, s.cy /= s.count;
    return s;
}

// --up z stands a Z-up model on the ground: its silhouette is taller than wide; without
// it the same file lies on its side.
TEST(CliView, UpZStandsAZUpModel) {
    const std::string obj = TallRedBox(), lying = Temp("lying.exr"), standing = Temp("standing.exr");
    const CliRun a = Lightmesh("render " + obj + " --width 160 --height 120 -q -o " + lying);
    ASSERT_EQ(a.exitCode, 0) << a.output;
    const CliRun b = Lightmesh("render " + obj + " --up z --width 160 --height 120 -o " + standing);
    ASSERT_EQ(b.exitCode, 0) << b.output;
    const Silhouette l = RedPixels(lying), s = RedPixels(standing);
    ASSERT_GT(l.count, 100);
    ASSERT_GT(s.count, 100);
    EXPECT_GT(l.Width(), l.Height()) << l.Width() << "x" << l.Height();
    EXPECT_GT(s.Height(), 1.5 * s.Width()) << s.Width() << "x" << s.Height();
    // The framing's notes say what was done.
    const CliRun v = Lightmesh("render " + obj + " --up z --width 16 --height 12 -v -o " + Temp("v.png"));
    EXPECT_NE(v.output.find("up axis: +z (--up), turned to +y"), std::string::npos) << v.output;
}

// The camera options replace the framing's: looking at the box from the front puts it in
// the middle; looking to its right moves it left; a field of view half as wide makes it
// about twice as tall.
TEST(CliView, CameraOptionsMoveTheView) {
    const std::string obj = TallRedBox();
    // After --up z the box spans x 0..1, y 0..4, z -1..0.
    const std::string front = "render " + obj + " --up z --width 160 --height 120 --camera-position 0.5,2,30 -q ";
    ASSERT_EQ(Lightmesh(front + "--look-at 0.5,2,-0.5 --fov 20 -o " + Temp("c.exr")).exitCode, 0);
    ASSERT_EQ(Lightmesh(front + "--look-at 4,2,-0.5 --fov 20 -o " + Temp("r.exr")).exitCode, 0);
    ASSERT_EQ(Lightmesh(front + "--look-at 0.5,2,-0.5 --fov 10 -o " + Temp("n.exr")).exitCode, 0);
    const Silhouette c = RedPixels(Temp("c.exr")), r = RedPixels(Temp("r.exr")), n = RedPixels(Temp("n.exr"));
    ASSERT_GT(c.count, 20);
    EXPECT_NEAR(c.cx, 80, 3);
    EXPECT_NEAR(c.cy, 60, 3);
    ASSERT_GT(r.count, 20);
    EXPECT_LT(r.cx, 60);
    EXPECT_NEAR(r.cy, 60, 3);
    // Height on the image: 4 / (2·30.5·tan(fov/2)) of 120 rows.
    const double expected20 = 120 * 4 / (2 * 30.5 * std::tan(10 * M_PI / 180));
    EXPECT_NEAR(c.Height(), expected20, 3);
    EXPECT_NEAR(n.Height(), 120 * 4 / (2 * 30.5 * std::tan(5 * M_PI / 180)), 3);

    // A scene file's camera keys are replaced the same way: its own camera looks elsewhere.
    std::ofstream(Temp("box.json")) << R"({"camera": {"position": [40, 2, 0], "look_at": [0, 2, 0]},
        "lights": [{"position": [3, 10, 20]}], "meshes": [{"file": "tall.obj",
        "matrix": [1, 0, 0, 0,  0, 0, 1, 0,  0, -1, 0, 0,  0, 0, 0, 1]}]})";
    ASSERT_EQ(Lightmesh("render " + Temp("box.json") + " --width 160 --height 120 -q --camera-position 0.5,2,30 "
                        "--look-at 0.5,2,-0.5 --fov 20 -o " + Temp("s.exr")).exitCode, 0);
    const Silhouette f = RedPixels(Temp("s.exr"));
    EXPECT_NEAR(f.cx, 80, 3);
    EXPECT_NEAR(f.Height(), expected20, 3);
}

TEST(CliView, BadCameraOptionsAreOneLine) {
    const std::string obj = TallRedBox();
    const std::pair<const char*, const char*> cases[] = {
        {"--look-at 1,2", "lightmesh: error: --look-at: expected X,Y,Z (3 numbers), got 1,2\n"},
        {"--camera-position nan,0,0", "lightmesh: error: --camera-position: every number must be finite"},
        {"--fov 180", "lightmesh: error: --fov: must be a number of degrees between 0 and 180"},
        {"--fov nan", "lightmesh: error: --fov: must be a number of degrees between 0 and 180"},
        {"--camera-position 1,1,1 --look-at 1,1,1", "lightmesh: error: --look-at: the camera position equals"},
        {"--up 0,0,0", "lightmesh: error: --up: must not be zero"},
        {"--up w", "lightmesh: error: --up: expected X,Y,Z (3 numbers), got w"},
    };
    for (const auto& [args, message] : cases) {
        const std::string out = Temp("bad.png");
        fs::remove(out);
        const CliRun r = Lightmesh("render " + obj + " --width 16 --height 12 " + args + " -o " + out);
        EXPECT_EQ(r.exitCode, 1) << args;
        EXPECT_EQ(r.output.rfind(message, 0), 0u) << args << "\n" << r.output;
        EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
        EXPECT_FALSE(fs::exists(out)) << args;
    }
}

// --width alone keeps the scene's aspect ratio (the gazebo's 800x600), --height alone too.
TEST(CliView, OneSideKeepsTheAspectRatio) {
    const CliRun w = Lightmesh("render builtin:gazebo --width 64 -o " + Temp("w.png"));
    ASSERT_EQ(w.exitCode, 0) << w.output;
    EXPECT_NE(w.output.find(": 64x48, "), std::string::npos) << w.output;
    const CliRun h = Lightmesh("render builtin:gazebo --height 30 -o " + Temp("h.png"));
    ASSERT_EQ(h.exitCode, 0) << h.output;
    EXPECT_NE(h.output.find(": 40x30, "), std::string::npos) << h.output;
    // A scene file's own size: 320x200.
    std::ofstream(Temp("wide.json")) << R"({"camera": {"position": [0, 2, 8], "look_at": [0, 0, 0]},
        "lights": [{"position": [3, 6, 4]}], "meshes": [{"file": "tall.obj"}], "render": {"width": 320, "height": 200}})";
    TallRedBox();
    const CliRun s = Lightmesh("render " + Temp("wide.json") + " --width 32 -o " + Temp("s.png"));
    ASSERT_EQ(s.exitCode, 0) << s.output;
    EXPECT_NE(s.output.find(": 32x20, "), std::string::npos) << s.output;
    const CliRun big = Lightmesh("render " + Temp("wide.json") + " --height 16384 -o " + Temp("big.png"));
    EXPECT_EQ(big.exitCode, 1);
    EXPECT_NE(big.output.find("lightmesh: error: --height 16384: the width that keeps the scene's aspect ratio "
                              "(320x200) would be 26214, outside 1..16384; give --width too\n"),
              std::string::npos)
        << big.output;
}

// A repeated option takes the last value; -t, -q and -v may come before the command.
TEST(CliView, RepeatedOptionTakesTheLastValueAndGlobalsMayComeFirst) {
    const CliRun r = Lightmesh("render builtin:gazebo --width 16 --height 12 --width 24 --threads 1 -t 2 -o " +
                               Temp("rep.png"));
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find(": 24x12, "), std::string::npos) << r.output;
    const CliRun g = Lightmesh("--threads 2 -q render builtin:gazebo --width 16 --height 12 -o " + Temp("g.png"));
    EXPECT_EQ(g.exitCode, 0) << g.output;
    EXPECT_EQ(g.output, "");  // -q reached render
    const CliRun i = Lightmesh("-t 1 info builtin:gazebo");
    EXPECT_EQ(i.exitCode, 0) << i.output;
    // Not before the command: a render option.
    const CliRun bad = Lightmesh("--shadows rt render builtin:gazebo");
    EXPECT_EQ(bad.exitCode, 1);
    EXPECT_NE(bad.output.find("only -t, -q and -v may also come before it"), std::string::npos) << bad.output;
    // Leading -t, -q, -v are not what a missing or mistyped command is blamed on.
    EXPECT_EQ(Lightmesh("--threads 2").output.rfind("lightmesh: error: a command is required: render", 0), 0u);
    EXPECT_NE(Lightmesh("-q rendr x").output.find("unknown command \"rendr\"; did you mean render?"), std::string::npos);
}

// -t, -q and -v mean the same in every command.
TEST(CliView, ShortNamesAreTheSameInEveryCommand) {
    for (const char* cmd : {"render", "info", "templates", "compare", "bench"}) {
        const std::string help = Lightmesh(std::string(cmd) + " --help").output;
        for (const char* name : {"-t,--threads", "-q,--quiet", "-v,--verbose"})
            EXPECT_NE(help.find(name), std::string::npos) << cmd << " lacks " << name << "\n" << help;
    }
    const CliRun t = Lightmesh("templates -t 1 -v --ns 2 --template-dir " + Temp("templates"));
    EXPECT_EQ(t.exitCode, 0) << t.output;
    const std::string a = Temp("t.png");
    ASSERT_EQ(Lightmesh("render builtin:gazebo --width 16 --height 12 -q -o " + a).exitCode, 0);
    const CliRun c = Lightmesh("compare -t 1 -q " + a + " " + a);
    EXPECT_EQ(c.exitCode, 0) << c.output;
}

// The help's first line names the default; the paper's knobs have their own heading.
TEST(CliView, HelpSpeaksTheUsersWords) {
    const std::string top = Lightmesh("--help").output;
    EXPECT_EQ(top.rfind("lightmesh: soft shadows", 0), 0u) << top;
    EXPECT_NE(top.substr(0, top.find('\n')).find("the default is --shadows soft"), std::string::npos) << top;
    const std::string render = Lightmesh("render --help").output;
    const size_t heading = render.find("The paper's light mesh method");
    ASSERT_NE(heading, std::string::npos) << render;
    for (const char* flag : {"--ki", "--variant", "--ns", "--cell-summaries", "--thin-check"})
        EXPECT_GT(render.find(flag), heading) << flag;
    EXPECT_NE(render.find("Camera (each replaces"), std::string::npos) << render;
}

// The tone curve changes PNGs only, and only when asked for; the exposure scales the
// linear values, EXR included.
TEST(CliView, ExposureAndToneCurve) {
    const std::string base = "render builtin:gazebo --width 40 --height 30 -q ";
    ASSERT_EQ(Lightmesh(base + "-o " + Temp("e0.exr")).exitCode, 0);
    ASSERT_EQ(Lightmesh(base + "--exposure -1 -o " + Temp("e1.exr")).exitCode, 0);
    const lm::Image e0 = lm::ReadImage(Temp("e0.exr")), e1 = lm::ReadImage(Temp("e1.exr"));
    ASSERT_EQ(e0.pixels.size(), e1.pixels.size());
    int lit = 0;
    for (size_t i = 0; i < e0.pixels.size(); ++i) {
        EXPECT_EQ(e1.pixels[i], e0.pixels[i] * 0.5f) << i;
        lit += e0.pixels[i].r > 0;
    }
    EXPECT_GT(lit, 100);
    // The tone curve leaves the EXR linear; --tonemap clamp is the default's PNG.
    ASSERT_EQ(Lightmesh(base + "--tonemap aces -o " + Temp("aces.exr")).exitCode, 0);
    EXPECT_EQ(lm::testing::FileBytes(Temp("aces.exr")), lm::testing::FileBytes(Temp("e0.exr")));
    ASSERT_EQ(Lightmesh(base + "-o " + Temp("d.png")).exitCode, 0);
    ASSERT_EQ(Lightmesh(base + "--tonemap clamp -o " + Temp("c.png")).exitCode, 0);
    EXPECT_EQ(lm::testing::FileBytes(Temp("d.png")), lm::testing::FileBytes(Temp("c.png")));
    // An overexposed render: clamp burns it white, aces keeps most of it below white.
    ASSERT_EQ(Lightmesh(base + "--exposure 2 -o " + Temp("over.png")).exitCode, 0);
    ASSERT_EQ(Lightmesh(base + "--exposure 2 --tonemap aces -o " + Temp("over-aces.png")).exitCode, 0);
    const lm::Image over = lm::ReadImage(Temp("over.png")), aces = lm::ReadImage(Temp("over-aces.png"));
    int white = 0, acesWhite = 0;
    for (size_t i = 0; i < over.pixels.size(); ++i) {
        white += over.pixels[i].r >= 1.0f;
        acesWhite += aces.pixels[i].r >= 1.0f;
    }
    EXPECT_GT(white, 100);
    EXPECT_LT(acesWhite, white / 4);
    // Bad values: one line naming the option.
    for (const char* bad : {"--exposure nan", "--exposure 1e9", "--exposure 33", "--tonemap filmic"}) {
        const CliRun r = Lightmesh(base + bad + " -o " + Temp("bad.png"));
        EXPECT_EQ(r.exitCode, 1) << bad;
        EXPECT_EQ(r.output.rfind(std::string("lightmesh: error: ") + std::string(bad).substr(0, std::string(bad).find(' ')) + ":", 0), 0u)
            << r.output;
    }
    // A scene file's "render" takes them too.
    std::ofstream(Temp("exposed.json")) << R"({"camera": {"position": [0, 2, 8], "look_at": [0, 0, 0]},
        "lights": [{"position": [3, 6, 4]}], "meshes": [{"file": "tall.obj"}],
        "render": {"exposure": 33}})";
    TallRedBox();
    const CliRun file = Lightmesh("render " + Temp("exposed.json") + " -o " + Temp("f.png"));
    EXPECT_EQ(file.exitCode, 1);
    EXPECT_NE(file.output.find("/render/exposure: must be between -32 and 32, got 33"), std::string::npos) << file.output;
}

// compare names both files when their sizes differ.
TEST(CliView, CompareNamesBothFilesInItsSizeError) {
    const std::string a = Temp("ca.png"), b = Temp("cb.png");
    ASSERT_EQ(Lightmesh("render builtin:gazebo --width 16 --height 12 -q -o " + a).exitCode, 0);
    ASSERT_EQ(Lightmesh("render builtin:gazebo --width 20 --height 12 -q -o " + b).exitCode, 0);
    const CliRun r = Lightmesh("compare " + a + " " + b);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_EQ(r.output, "lightmesh: error: " + a + " is 16x12 and " + b +
                            " is 20x12: images of different sizes cannot be compared\n");
    const CliRun m = Lightmesh("compare " + a + " " + a + " --mask " + b);
    EXPECT_EQ(m.exitCode, 1);
    EXPECT_NE(m.output.find(b), std::string::npos) << m.output;
}

}  // namespace
}  // namespace cli_view_test

namespace cli_view_test {
namespace {

// bench times the default shadow method by default, and --variants soft times it alone
// against RT.
TEST(CliView, BenchTimesTheDefault) {
    const CliRun soft = Lightmesh("bench --variants soft --size 32x24 --repeat 1 --no-none -q");
    ASSERT_EQ(soft.exitCode, 0) << soft.output;
    EXPECT_NE(soft.output.find("RT ("), std::string::npos) << soft.output;
    EXPECT_NE(soft.output.find("; soft shadows (the default) "), std::string::npos) << soft.output;
    EXPECT_EQ(soft.output.find("| CC | kI |"), std::string::npos) << soft.output;  // no light mesh cell
    const CliRun all = Lightmesh("bench --size 16x12 --repeat 1 --cc 10 --no-none -q");
    ASSERT_EQ(all.exitCode, 0) << all.output;
    EXPECT_NE(all.output.find("; soft shadows (the default) "), std::string::npos) << all.output;
    EXPECT_NE(all.output.find("ОТ+consensus (consensus)"), std::string::npos) << all.output;
    const CliRun lmm = Lightmesh("bench --variants consensus --size 16x12 --repeat 1 --cc 10 --no-none -q");
    ASSERT_EQ(lmm.exitCode, 0) << lmm.output;
    EXPECT_EQ(lmm.output.find("soft shadows"), std::string::npos) << lmm.output;
}

}  // namespace
}  // namespace cli_view_test
