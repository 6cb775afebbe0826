// End-to-end tests of the lightmesh executable: exit codes, messages, outputs.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <thread>

#include "lightmesh/io/image.h"
#include "run_lightmesh.h"

namespace cli_test {
namespace {

namespace fs = std::filesystem;

using CliRun = lm::testing::CliResult;

CliRun Lightmesh(const std::string& args) { return lm::testing::RunLightmesh(args); }

std::string Temp(const std::string& name) {
    const fs::path dir = fs::path(::testing::TempDir()) / "lm_cli";
    fs::create_directories(dir);
    return (dir / name).string();
}

std::string Bytes(const std::string& path) { return lm::testing::FileBytes(path); }

TEST(Cli, HelpForEveryCommand) {
    for (const char* cmd : {"--help", "render --help", "info --help"}) {
        const CliRun r = Lightmesh(cmd);
        EXPECT_EQ(r.exitCode, 0) << cmd;
        EXPECT_NE(r.output.find("Usage"), std::string::npos) << r.output;
    }
    EXPECT_NE(Lightmesh("render --help").output.find("--shadows"), std::string::npos);
}

// The help shows the defaults; `lightmesh help [COMMAND]` is the help.
TEST(Cli, HelpShowsTheDefaults) {
    const std::string render = Lightmesh("render --help").output;
    for (const char* text : {"default soft", "default 640", "default 480", "(default 1)", "default 5",
                             "default 100 for lmm, 64 for exact", "(default 2)", "default 8", "(default 16)",
                             "default 64", "default auto", "default all"})
        EXPECT_NE(render.find(text), std::string::npos) << text << "\n" << render;
    const std::string templates = Lightmesh("templates --help").output;
    EXPECT_NE(templates.find("default 8; 0: the default"), std::string::npos) << templates;
    EXPECT_NE(templates.find("(default 2)"), std::string::npos) << templates;
    EXPECT_NE(Lightmesh("bench --help").output.find("(default 3; 1 with --quick)"), std::string::npos);

    const CliRun help = Lightmesh("help");
    EXPECT_EQ(help.exitCode, 0) << help.output;
    EXPECT_NE(help.output.find("Usage"), std::string::npos) << help.output;
    const CliRun renderHelp = Lightmesh("help render");
    EXPECT_EQ(renderHelp.exitCode, 0) << renderHelp.output;
    EXPECT_NE(renderHelp.output.find("--shadows"), std::string::npos) << renderHelp.output;
}

// -q prints errors only; --stats still prints the summary line and the figures.
TEST(Cli, QuietPrintsErrorsOnly) {
    const std::string out = Temp("quiet.png");
    const CliRun quiet = Lightmesh("render builtin:gazebo --width 16 --height 12 -q -o " + out);
    EXPECT_EQ(quiet.exitCode, 0);
    EXPECT_EQ(quiet.output, "");
    const CliRun stats = Lightmesh("render builtin:gazebo --width 16 --height 12 -q --stats -o " + out);
    EXPECT_EQ(stats.exitCode, 0);
    EXPECT_NE(stats.output.find(out + ": 16x12, shadows soft"), std::string::npos) << stats.output;
    EXPECT_NE(stats.output.find("peak"), std::string::npos) << stats.output;
}

// The summary line: thousands separators, and a singular for one.
TEST(Cli, SummaryLineCountsReadWell) {
    const CliRun r = Lightmesh("render builtin:gazebo --width 16 --height 12 -o " + Temp("counts.png"));
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find(", 2,572 triangles, 2 lights: render "), std::string::npos) << r.output;
    std::ofstream(Temp("one.obj")) << "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nf 1 2 3\n";
    std::ofstream(Temp("one.json")) << R"({"camera": {"position": [0, 2, 8], "look_at": [0, 0, 0]},
        "lights": [{"position": [3, 6, 4]}], "meshes": [{"file": "one.obj"}]})";
    const CliRun one = Lightmesh("render " + Temp("one.json") + " --width 16 --height 12 -o " + Temp("one.png"));
    ASSERT_EQ(one.exitCode, 0) << one.output;
    EXPECT_NE(one.output.find(", 1 triangle, 1 light: render "), std::string::npos) << one.output;
}

// Options that do nothing without another one say so.
TEST(Cli, OptionsIgnoredWithoutTheirPartnerWarn) {
    const CliRun info = Lightmesh("info builtin:gazebo --accel brute --grid 20");
    EXPECT_EQ(info.exitCode, 0) << info.output;
    EXPECT_NE(info.output.find("lightmesh: warning: --grid is not used by --accel brute (only by grid); ignored"),
              std::string::npos)
        << info.output;
    EXPECT_EQ(Lightmesh("info builtin:gazebo --accel grid --grid 20").output.find("warning"), std::string::npos);

    const std::string a = Temp("cmp-a.png");
    ASSERT_EQ(Lightmesh("render builtin:gazebo --width 16 --height 12 -q -o " + a).exitCode, 0);
    const CliRun compare = Lightmesh("compare " + a + " " + a + " --diff-scale 2");
    EXPECT_EQ(compare.exitCode, 0) << compare.output;
    EXPECT_NE(compare.output.find("lightmesh: warning: --diff-scale is used only with --diff; ignored"),
              std::string::npos)
        << compare.output;
}

// templates takes render's --ns range: 0 is the default, 8.
TEST(Cli, TemplatesTakesNsZeroAsTheDefault) {
    const CliRun r = Lightmesh("templates --ns 0 --ki 1.5 --template-dir " + Temp("templates"));
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("templates ns 8, kI 1.5"), std::string::npos) << r.output;
}

TEST(Cli, RendersTheDemoSceneEndToEnd) {
    const std::string out = Temp("demo.png");
    fs::remove(out);
    const CliRun r = Lightmesh("render builtin:gazebo --width 64 --height 48 --shadows lmm --stats -q -o " + out);
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("render"), std::string::npos);
    EXPECT_NE(r.output.find("nodes evaluated"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("peak"), std::string::npos) << r.output;
    const lm::Image img = lm::ReadImage(out);
    EXPECT_EQ(img.width, 64);
    EXPECT_EQ(img.height, 48);
}

TEST(Cli, ImageBytesIdenticalForOneAndSeveralThreads) {
    for (const char* shadows : {"rt", "lmm"}) {
        const std::string a = Temp(std::string("t1-") + shadows + ".png");
        const std::string b = Temp(std::string("t3-") + shadows + ".png");
        const std::string common = std::string("render builtin:gazebo --width 80 --height 60 -q --shadows ") + shadows;
        ASSERT_EQ(Lightmesh(common + " --threads 1 -o " + a).exitCode, 0);
        ASSERT_EQ(Lightmesh(common + " --threads 3 -o " + b).exitCode, 0);
        EXPECT_EQ(Bytes(a), Bytes(b)) << shadows;
        EXPECT_GT(Bytes(a).size(), 100u);
    }
}

TEST(Cli, InfoDescribesTheScene) {
    const CliRun r = Lightmesh("info builtin:gazebo --accel grid");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("triangles"), std::string::npos);
    EXPECT_NE(r.output.find("every object is a closed solid"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("lights     2"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("accel      grid"), std::string::npos) << r.output;
}

// Many lights: info lists the first 16 and sums up the rest; -v lists them all.
TEST(Cli, InfoSumsUpManyLights) {
    std::ofstream(Temp("many.obj")) << "v -1 0 -1\nv 1 0 -1\nv 0 0 1\nf 1 2 3\n";
    std::string lights;
    for (int i = 0; i < 20; ++i)
        lights += (i ? ", " : "") + std::string("{\"position\": [") + std::to_string(i) + ", 5, 0], \"radius\": " +
                  (i < 19 ? "0.5" : "0.25") + (i % 2 ? ", \"range\": 30}" : "}");
    std::ofstream(Temp("many.json")) << R"({"camera": {"position": [0, 2, 8], "look_at": [0, 0, 0]}, "lights": [)"
                                     << lights << R"(], "meshes": [{"file": "many.obj"}]})";
    const CliRun r = Lightmesh("info " + Temp("many.json"));
    ASSERT_EQ(r.exitCode, 0) << r.output;
    EXPECT_NE(r.output.find("  light 15  at [15 5 0]"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("  light 16 "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("  and 4 more: radius 0.25 to 0.5, 2 with a range (30) (-v lists every light)\n"),
              std::string::npos)
        << r.output;
    const CliRun all = Lightmesh("info -v " + Temp("many.json"));
    ASSERT_EQ(all.exitCode, 0) << all.output;
    EXPECT_NE(all.output.find("  light 19  at [19 5 0]"), std::string::npos) << all.output;
    EXPECT_EQ(all.output.find("more: radius"), std::string::npos) << all.output;
}

// A file referenced 64 times (65,536 triangles in copies) is placed as instances: info
// lists them, --stats gives each part's figures, every method and back-end renders it, and
// --no-instancing copies the references.
TEST(Cli, InstancesInInfoStatsAndEveryMethod) {
    std::string obj;
    const int rings = 17, segments = 32;  // 2 * 32 * 16 = 1,024 triangles
    for (int i = 0; i <= rings; ++i)
        for (int j = 0; j < segments; ++j) {
            const double th = M_PI * i / rings, ph = 2 * M_PI * j / segments;
            obj += "v " + std::to_string(std::sin(th) * std::cos(ph)) + " " + std::to_string(std::cos(th)) + " " +
                   std::to_string(std::sin(th) * std::sin(ph)) + "\n";
        }
    auto v = [&](int i, int j) { return std::to_string(1 + i * segments + j % segments); };
    for (int i = 0; i < rings; ++i)
        for (int j = 0; j < segments; ++j) {
            if (i > 0) obj += "f " + v(i, j) + " " + v(i, j + 1) + " " + v(i + 1, j) + "\n";
            if (i < rings - 1) obj += "f " + v(i, j + 1) + " " + v(i + 1, j + 1) + " " + v(i + 1, j) + "\n";
        }
    std::ofstream(Temp("ball.obj")) << obj;
    std::string meshes;
    for (int k = 0; k < 64; ++k)
        meshes += (k ? ", " : "") + std::string(R"({"file": "ball.obj", "transform": {"translate": [)") +
                  std::to_string(3 * (k % 8)) + ", 1, " + std::to_string(3 * (k / 8)) + "]}}";
    std::ofstream(Temp("balls.json")) << R"({"camera": {"position": [10, 20, 40], "look_at": [10, 0, 10]},
        "lights": [{"position": [0, 30, 5], "radius": 0.5}], "meshes": [)" << meshes << R"(], "ground": {"up": "y"}})";
    const CliRun info = Lightmesh("info " + Temp("balls.json"));
    ASSERT_EQ(info.exitCode, 0) << info.output;
    EXPECT_NE(info.output.find("triangles  65,548 "), std::string::npos) << info.output;
    EXPECT_NE(info.output.find("instances  64 of 1 prototype (1,024 triangles), standing for 65,536 triangles;"),
              std::string::npos)
        << info.output;
    EXPECT_NE(info.output.find("embree instances 64 instance geometries of 1 prototype scenes"), std::string::npos)
        << info.output;
    const CliRun soft = Lightmesh("render " + Temp("balls.json") + " --shadows exact --width 64 --height 48 --stats -o " +
                                  Temp("balls.png"));
    ASSERT_EQ(soft.exitCode, 0) << soft.output;
    EXPECT_NE(soft.output.find("1 prototype hierarchies under one over 64 instances"), std::string::npos) << soft.output;
    for (const char* args : {"--shadows lmm", "--shadows area --accel grid", "--shadows rt --accel brute"}) {
        const CliRun r = Lightmesh("render " + Temp("balls.json") + " --width 32 --height 24 -q " + args + " -o " +
                                   Temp("balls2.png"));
        EXPECT_EQ(r.exitCode, 0) << args << r.output;
    }
    const CliRun copies = Lightmesh("render --no-instancing " + Temp("balls.json") + " --width 64 --height 48 --stats -o " +
                                    Temp("balls3.png"));
    ASSERT_EQ(copies.exitCode, 0) << copies.output;
    EXPECT_EQ(copies.output.find("instances"), std::string::npos) << copies.output;
}

// Lights have sizes: info lists them; --shadows area samples them without a warning;
// --light-radius 0 overrides them all to points, which is RT's image byte for byte, and
// says so.
TEST(Cli, LightRadiiInInfoAndTheAreaReference) {
    const CliRun info = Lightmesh("info builtin:gazebo");
    ASSERT_EQ(info.exitCode, 0) << info.output;
    EXPECT_NE(info.output.find("falloff inverse_square, radius 0.173\n"), std::string::npos) << info.output;
    EXPECT_NE(info.output.find("falloff inverse_square, radius 0.164\n"), std::string::npos) << info.output;

    const std::string common = "render builtin:gazebo --width 40 --height 30 --samples 4 ";
    const CliRun sized = Lightmesh(common + "--shadows area -o " + Temp("area-own.png"));
    ASSERT_EQ(sized.exitCode, 0) << sized.output;
    EXPECT_EQ(sized.output.find("warning"), std::string::npos) << sized.output;
    const CliRun points = Lightmesh(common + "--shadows area --light-radius 0 -o " + Temp("area-points.png"));
    ASSERT_EQ(points.exitCode, 0) << points.output;
    EXPECT_NE(points.output.find("lightmesh: warning: --shadows area with light radius 0: point lights, the same "
                                 "image as --shadows rt"),
              std::string::npos)
        << points.output;
    ASSERT_EQ(Lightmesh(common + "--shadows rt -q -o " + Temp("area-rt.png")).exitCode, 0);
    EXPECT_EQ(Bytes(Temp("area-points.png")), Bytes(Temp("area-rt.png")));
    EXPECT_NE(Bytes(Temp("area-own.png")), Bytes(Temp("area-rt.png")));  // the lights' own radii soften
}

TEST(Cli, BadInputIsAClearErrorAndWritesNothing) {
    const std::string out = Temp("bad.png");
    fs::remove(out);
    struct Case {
        std::string args, message;
    };
    const Case cases[] = {
        {"render builtin:nothing -o " + out, "unknown built-in scene"},
        {"render " + Temp("missing.json") + " -o " + out, "missing.json"},
        {"render builtin:gazebo -o " + Temp("x.jpg"), "unknown image extension"},
        {"render builtin:gazebo -o /no/such/folder/x.png", "does not exist"},
        {"render builtin:gazebo --shadows hard -o " + out, "--shadows"},
        {"render builtin:gazebo --width 0 -o " + out, "--width"},
        {"render builtin:gazebo --shadows lmm --cc 0 -o " + out, "--cc"},
        {"render builtin:gazebo --shadows lmm --ki -1 -o " + out, "--ki"},
        {"render builtin:gazebo --accel kdtree -o " + out, "--accel"},
    };
    for (const Case& c : cases) {
        const CliRun r = Lightmesh(c.args);
        EXPECT_NE(r.exitCode, 0) << c.args;
        EXPECT_LT(r.exitCode, 128) << "crashed: " << c.args << "\n" << r.output;
        EXPECT_NE(r.output.find(c.message), std::string::npos) << c.args << "\n" << r.output;
    }
    EXPECT_FALSE(fs::exists(out));
    EXPECT_FALSE(fs::exists(Temp("x.jpg")));
}

// Ctrl-C during a render: one line says so and what became of the output.
TEST(Cli, InterruptedRenderSaysSo) {
    const std::string out = Temp("interrupted.png");
    ASSERT_EQ(Lightmesh("render builtin:gazebo --width 32 --height 24 -q -o " + out).exitCode, 0);
    const std::string before = Bytes(out);
    const CliRun r = lm::testing::RunLightmesh(
        "render builtin:gazebo --width 4000 --height 3000 --aa 4 -o " + out, "timeout -s INT 1.5");
    ASSERT_NE(r.output.find("lightmesh: interrupted"), std::string::npos) << r.output;
    EXPECT_EQ(r.output.substr(r.output.find("lightmesh: interrupted")),
              "lightmesh: interrupted; " + out + " not written: the previous file is kept\n")
        << r.output;
    EXPECT_EQ(Bytes(out), before);
}

// An interrupted render leaves a previous output untouched and no temporary file behind.
TEST(Cli, InterruptedRenderLeavesThePreviousOutputUntouched) {
    const std::string out = Temp("keep.png");
    ASSERT_EQ(Lightmesh("render builtin:gazebo --width 32 --height 24 -q -o " + out).exitCode, 0);
    const std::string before = Bytes(out);
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
        // A render far too long to finish before the signal.
        execl(LIGHTMESH_EXE, "lightmesh", "render", "builtin:gazebo", "--width", "4000", "--height",
              "3000", "--aa", "4", "-q", "-o", out.c_str(), static_cast<char*>(nullptr));
        _exit(127);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(700));
    kill(pid, SIGTERM);
    int status = 0;
    waitpid(pid, &status, 0);
    EXPECT_TRUE(WIFSIGNALED(status));
    EXPECT_EQ(Bytes(out), before);
    for (const auto& entry : fs::directory_iterator(fs::path(out).parent_path()))
        EXPECT_EQ(entry.path().filename().string().find(".keep.png.tmp"), std::string::npos)
            << "left behind: " << entry.path();
}

}  // namespace
}  // namespace cli_test
