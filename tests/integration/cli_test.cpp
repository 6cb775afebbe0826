// End-to-end tests of the lightmesh executable: exit codes, messages, outputs.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <thread>

#include "lightmesh/io/image.h"
#include "run_lightmesh.h"

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
