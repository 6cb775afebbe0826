// Robustness of outputs, caches and threads, through the real executable:
// concurrent runs sharing a template cache, byte-identical images whatever the thread
// count, atomic outputs under SIGINT/SIGTERM, and --stats' peak memory.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <tbb/global_control.h>

#include <algorithm>

#include "support/floor_scenes.h"
#include "lightmesh/render/render_job.h"
#include "lightmesh/shadow/light_mesh.h"
#include "lightmesh/util/progress.h"
#include "lightmesh/shadow/shadow.h"
#include "lightmesh/shadow/sphere_templates.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"
#include "run_lightmesh.h"

namespace robustness_test {
namespace {

namespace fs = std::filesystem;

using lm::testing::CliResult;
using lm::testing::FilesIn;
using Scratch = lm::testing::ScratchFolder;

CliResult Lightmesh(const std::string& args) { return lm::testing::RunLightmesh(args); }
pid_t Spawn(const std::vector<std::string>& args) { return lm::testing::SpawnLightmesh(args); }
std::string Bytes(const std::string& path) { return lm::testing::FileBytes(path); }

// ---------------------------------------------------------------------------------------
// Template cache shared by concurrent runs

TEST(Robustness, ConcurrentRunsShareATemplateCacheWithoutCorruptingIt) {
    const Scratch scratch("lm_robust");
    const std::string& dir = scratch.path;
    const int ns = 12;
    const float ki = 3.0f;
    const lm::SphereTemplates expected = lm::SphereTemplates::Build(ns, ki);
    // An empty cache folder that does not even exist yet; then a folder holding a corrupt
    // file, which every run finds, rebuilds and replaces at the same time.
    for (const char* round : {"new", "corrupt"}) {
        SCOPED_TRACE(round);
        const std::string folder = dir + "/" + round;
        const std::string path = lm::TemplateFileName(folder, ns, ki);
        if (std::string(round) == "corrupt") {
            fs::create_directories(folder);
            std::ofstream(path, std::ios::binary) << "LMSPHTPL, but not really";
        }
        std::vector<pid_t> pids;
        for (int i = 0; i < 6; ++i)
            pids.push_back(Spawn({"templates", "--ns", std::to_string(ns), "--ki", "3", "--template-dir",
                                  folder, "-q"}));
        for (pid_t pid : pids) {
            int status = 0;
            ASSERT_EQ(waitpid(pid, &status, 0), pid);
            EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "status " << status;
        }
        EXPECT_NO_THROW(EXPECT_EQ(lm::ReadSphereTemplates(path, ns, ki), expected));
        // Only the cache file: no temporary file left behind by any of the six.
        EXPECT_EQ(FilesIn(folder), std::vector<std::string>{fs::path(path).filename().string()});
    }
}

// ---------------------------------------------------------------------------------------
// Determinism

TEST(Robustness, EveryShadowMethodIsByteIdenticalForAnyThreadCountAndRun) {
    const Scratch scratch("lm_robust");
    const std::string& dir = scratch.path;
    struct Method {
        std::string shadows, variant;
    };
    std::vector<Method> methods;
    for (const std::string& s : lm::ShadowMethodNames()) {
        if (s == "lmm")
            for (const std::string& v : lm::LightMeshVariantNames()) methods.push_back({s, v});
        else
            methods.push_back({s, ""});
    }
    ASSERT_GE(methods.size(), 9u);  // none, rt, and the light mesh's variants
    for (const Method& m : methods) {
        const std::string name = m.shadows + (m.variant.empty() ? "" : "-" + m.variant);
        SCOPED_TRACE(name);
        std::string extra = "--shadows " + m.shadows;
        if (!m.variant.empty()) extra += " --variant " + m.variant + " --cc 40 --template-dir " + dir;
        if (m.shadows == "area") extra += " --light-radius 0.3 --samples 4";
        std::string reference;
        int run = 0;
        for (const char* threads : {"1", "2", "8", "8"}) {
            const std::string out = dir + "/" + name + "-" + std::to_string(run++) + ".png";
            const CliResult r = Lightmesh("render builtin:gazebo --width 64 --height 48 -q --threads " +
                                          std::string(threads) + " " + extra + " -o " + out);
            ASSERT_EQ(r.exitCode, 0) << r.output;
            const std::string bytes = Bytes(out);
            ASSERT_GT(bytes.size(), 100u);
            if (reference.empty())
                reference = bytes;
            else
                EXPECT_TRUE(bytes == reference) << out << " differs from the 1-thread image";
        }
    }
}

// A bare model with its own floor at its base (a playground's lawn) gets no
// coplanar ground slab, so Embree and brute force agree on every pixel (with the slab they
// would differ at 35 dB PSNR). Hard shadows: the soft default turns its sample pattern by a
// hash of the hit point's bits, which Embree's own triangle test can round differently in
// the last place, so its penumbrae agree across back-ends within sampling noise only.
TEST(Robustness, ModelWithItsOwnFloorRendersTheSameOnEveryBackEnd) {
    const Scratch scratch("lm_robust");
    const std::string& dir = scratch.path;
    std::ofstream(dir + "/playground.obj")
        << "v -10 0 -10\nv 10 0 -10\nv 10 0 10\nv -10 0 10\nf 1 4 3 2\n"
           "v -1 0 -1\nv 1 0 -1\nv 1 2 -1\nv -1 2 -1\nv -1 0 1\nv 1 0 1\nv 1 2 1\nv -1 2 1\n"
           "f 5 8 7 6\nf 9 10 11 12\nf 5 6 10 9\nf 8 12 11 7\nf 5 9 12 8\nf 6 7 11 10\n";
    std::string reference;
    for (const char* accel : {"brute", "grid", "embree"}) {
        SCOPED_TRACE(accel);
        const std::string out = dir + "/" + accel + ".png";
        const CliResult r = Lightmesh("render " + dir + "/playground.obj --width 96 --height 72 --shadows rt --accel " +
                                      accel + " -o " + out);
        ASSERT_EQ(r.exitCode, 0) << r.output;
        EXPECT_NE(r.output.find("no ground plane added: the model has its own floor"), std::string::npos)
            << r.output;
        if (reference.empty())
            reference = Bytes(out);
        else
            EXPECT_TRUE(Bytes(out) == reference) << out << " differs from brute force's image";
    }
}

// ---------------------------------------------------------------------------------------
// Atomic outputs

/// A render killed by `signal` while it runs leaves the previous image untouched and no
/// temporary file.
void InterruptRender(int signal) {
    const Scratch scratch("lm_robust");
    const std::string& dir = scratch.path;
    const std::string out = dir + "/keep.png";
    ASSERT_EQ(Lightmesh("render builtin:gazebo --width 32 --height 24 -q -o " + out).exitCode, 0);
    const std::string before = Bytes(out);
    const pid_t pid = Spawn({"render", "builtin:gazebo", "--width", "4000", "--height", "3000", "--aa", "4",
                             "-q", "-o", out});
    std::this_thread::sleep_for(std::chrono::milliseconds(700));
    kill(pid, signal);
    int status = 0;
    waitpid(pid, &status, 0);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == signal) << "status " << status;
    EXPECT_EQ(Bytes(out), before);
    EXPECT_EQ(FilesIn(dir), std::vector<std::string>{"keep.png"});
}

TEST(Robustness, SigintDuringARenderLeavesThePreviousImage) { InterruptRender(SIGINT); }
TEST(Robustness, SigtermDuringARenderLeavesThePreviousImage) { InterruptRender(SIGTERM); }
TEST(Robustness, SighupDuringARenderLeavesThePreviousImage) { InterruptRender(SIGHUP); }

// A child process that writes `path` atomically and raises `signal` halfway through the
// temporary file (with or without the interrupt clean-up installed); its wait status.
int SignalDuringTheWrite(const std::string& path, int signal, bool cleanup, pid_t* child) {
    const pid_t pid = fork();
    if (pid == 0) {
        if (cleanup) lm::InstallInterruptCleanup();
        lm::WriteFileAtomically(path, [&](const std::string& tmp) {
            std::ofstream(tmp) << "half of the new";
            raise(signal);
        });
        _exit(0);  // not reached
    }
    *child = pid;
    int status = 0;
    if (pid > 0) waitpid(pid, &status, 0);
    return status;
}

// A signal while the temporary file is being written (the moment that matters): the
// handler removes it, the target keeps its old content.
TEST(Robustness, SignalDuringTheWriteRemovesTheTemporaryFile) {
    for (int signal : {SIGINT, SIGTERM, SIGHUP}) {
        SCOPED_TRACE(signal);
        const Scratch scratch("lm_robust");
        const std::string& dir = scratch.path;
        const std::string path = dir + "/image.png";
        std::ofstream(path) << "old";
        pid_t pid = 0;
        const int status = SignalDuringTheWrite(path, signal, /*cleanup=*/true, &pid);
        EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == signal) << "status " << status;
        EXPECT_EQ(Bytes(path), "old");
        EXPECT_EQ(FilesIn(dir), std::vector<std::string>{"image.png"});
    }
}

// A write killed by SIGKILL (no handler runs) leaves its temporary file; the next write of
// the same file removes it, as the process that made it no longer exists, and leaves the
// temporary files of live processes alone.
TEST(Robustness, StaleTemporaryFilesOfDeadProcessesAreRemoved) {
    const Scratch scratch("lm_robust");
    const std::string& dir = scratch.path;
    const std::string path = dir + "/image.png";
    std::ofstream(path) << "old";
    pid_t pid = 0;
    const int status = SignalDuringTheWrite(path, SIGKILL, /*cleanup=*/false, &pid);
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << "status " << status;
    const std::string stale = lm::TemporaryPathFor(path, pid);
    ASSERT_TRUE(fs::exists(stale)) << stale;
    // A live process's temporary (our parent's PID stands in for one) is not touched.
    const std::string live = lm::TemporaryPathFor(path, getppid());
    std::ofstream(live) << "being written";
    lm::WriteFileAtomically(path, [](const std::string& tmp) { std::ofstream(tmp) << "new"; });
    EXPECT_EQ(Bytes(path), "new");
    EXPECT_FALSE(fs::exists(stale));
    EXPECT_TRUE(fs::exists(live));
}

// A legal file name of 252 bytes (NAME_MAX is 255) gets a temporary name that fits; two
// long names sharing their first 240 bytes get different ones.
TEST(Robustness, TemporaryNamesFitNameMax) {
    const std::string a = "/tmp/x/" + std::string(240, 'a') + "-one.png";
    const std::string b = "/tmp/x/" + std::string(240, 'a') + "-two.png";
    for (const std::string& p : {a, b}) {
        const std::string name = fs::path(lm::TemporaryPathFor(p, 4194304)).filename().string();
        EXPECT_LE(name.size(), 255u) << name;
        EXPECT_EQ(name.front(), '.');
    }
    EXPECT_NE(lm::TemporaryPathFor(a, 1), lm::TemporaryPathFor(b, 1));
    EXPECT_EQ(fs::path(lm::TemporaryPathFor("/tmp/x/short.png", 42)).filename().string(),
              ".short.png.tmp42");
}

TEST(Robustness, FailedWriteLeavesTheOldFileAndNoTemporary) {
    const Scratch scratch("lm_robust");
    const std::string& dir = scratch.path;
    const std::string path = dir + "/out.exr";
    std::ofstream(path) << "old";
    EXPECT_THROW(lm::WriteFileAtomically(path,
                                         [](const std::string& tmp) {
                                             std::ofstream(tmp) << "partial";
                                             lm::ThrowError("disk full (simulated)");
                                         }),
                 lm::Error);
    EXPECT_EQ(Bytes(path), "old");
    EXPECT_EQ(FilesIn(dir), std::vector<std::string>{"out.exr"});
}

// ---------------------------------------------------------------------------------------
// Memory

TEST(Robustness, StatsReportPeakMemory) {
    const Scratch scratch("lm_robust");
    const std::string& dir = scratch.path;
    const CliResult r = Lightmesh("render builtin:gazebo --width 32 --height 24 --shadows lmm --cc 60 --stats -q -o " +
                                  dir + "/m.png");
    ASSERT_EQ(r.exitCode, 0) << r.output;
    const size_t at = r.output.find("memory    peak ");
    ASSERT_NE(at, std::string::npos) << r.output;
    double value = 0;
    char unit[8] = {};
    ASSERT_EQ(std::sscanf(r.output.c_str() + at, "memory    peak %lf %7s", &value, unit), 2);
    EXPECT_GT(value, 0);
    EXPECT_TRUE(std::string(unit) == "MiB" || std::string(unit) == "GiB") << unit;
}

TEST(Robustness, MemoryLimitComesFromTheEnvironment) {
    EXPECT_EQ(lm::ParseByteCount("4096"), 4096u);
    EXPECT_EQ(lm::ParseByteCount("64M"), 64u << 20);
    EXPECT_EQ(lm::ParseByteCount("1.5G"), 3ull << 29);
    EXPECT_EQ(lm::ParseByteCount("2T"), 2ull << 40);
    // The spellings people write, all powers of 1024.
    for (const char* eight : {"8G", "8g", "8GB", "8gb", "8GiB", "8gib", "8 GB", " 8G ", "8589934592", "8589934592B",
                              "8192M", "8192MiB", "0.0078125T", "8.0G"})
        EXPECT_EQ(lm::ParseByteCount(eight), 8ull << 30) << eight;
    EXPECT_EQ(lm::ParseByteCount("1B"), 1u);
    EXPECT_EQ(lm::ParseByteCount("18446744073709551615"), UINT64_MAX);
    for (const char* bad : {"", "-1", "0", "0G", "M", "12Q", "1e300", "1e3G", "-5G", "+5G", "abc", "nan", "inf",
                            "8GBB", "8Gi", "8 G B", "1.5", "1.", ".", "8G8", "18446744073709551616",
                            "99999999999999999999", "16777216T", "1..5G", "0x10M"})
        EXPECT_EQ(lm::ParseByteCount(bad), 0u) << bad;
    uint64_t bytes = 0;
    EXPECT_EQ(lm::ByteCountProblem("abc", &bytes), "not a size");
    EXPECT_EQ(lm::ByteCountProblem("-5G", &bytes), "not a size: no sign is allowed");
    EXPECT_EQ(lm::ByteCountProblem("1e3G", &bytes), "not a size: unknown unit \"e3G\"");
    EXPECT_EQ(lm::ByteCountProblem("99999999999999999999", &bytes), "too large (more than 16 EiB)");
    EXPECT_EQ(lm::ByteCountProblem("0", &bytes), "must be at least 1 byte");
    EXPECT_EQ(lm::ByteCountProblem("1.5", &bytes), "not a size: a fraction of a byte");
    const uint64_t machine = lm::PhysicalMemoryBytes();
    ASSERT_GT(machine, 0u);
    setenv("LIGHTMESH_MEMORY_LIMIT", "64M", 1);
    EXPECT_EQ(lm::PhysicalMemoryBytes(), std::min<uint64_t>(machine, 64u << 20));
    setenv("LIGHTMESH_MEMORY_LIMIT", "64MiB", 1);
    EXPECT_EQ(lm::PhysicalMemoryBytes(), std::min<uint64_t>(machine, 64u << 20));
    setenv("LIGHTMESH_MEMORY_LIMIT", "", 1);  // empty: as unset
    EXPECT_EQ(lm::PhysicalMemoryBytes(), machine);
    // Not a size: an error, no longer a process without a budget.
    setenv("LIGHTMESH_MEMORY_LIMIT", "not a size", 1);
    EXPECT_THROW(lm::PhysicalMemoryBytes(), lm::Error);
    EXPECT_THROW(lm::MemoryLimitFromEnvironment(), lm::Error);
    unsetenv("LIGHTMESH_MEMORY_LIMIT");
}

// ---------------------------------------------------------------------------------------
// Outputs that are devices or FIFOs are written into, never renamed over

bool IsCharDevice(const std::string& path) {
    struct stat st {};
    return stat(path.c_str(), &st) == 0 && S_ISCHR(st.st_mode);
}

bool IsFifo(const std::string& path) {
    struct stat st {};
    return stat(path.c_str(), &st) == 0 && S_ISFIFO(st.st_mode);
}

// A copy of /dev/null or /dev/full as -o, --csv or --diff: the atomic write used to rename
// a regular file over it (as root, `--csv /dev/null` would have replaced the system's).
TEST(Robustness, DeviceAndFifoOutputsAreWrittenIntoNotReplaced) {
    const Scratch scratch("lm_robust");
    const std::string& dir = scratch.path;
    const std::string null = dir + "/null.png", nullCsv = dir + "/null.csv", full = dir + "/full.png";
    if (mknod(null.c_str(), S_IFCHR | 0666, makedev(1, 3)) != 0 ||
        mknod(nullCsv.c_str(), S_IFCHR | 0666, makedev(1, 3)) != 0 ||
        mknod(full.c_str(), S_IFCHR | 0666, makedev(1, 7)) != 0)
        GTEST_SKIP() << "mknod of a copy of /dev/null failed (" << std::strerror(errno)
                     << "): device outputs need root or CAP_MKNOD";
    const std::string render = "render builtin:gazebo --width 16 --height 12 --shadows rt -q -o ";
    CliResult r = Lightmesh(render + null);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    r = Lightmesh("bench --scene builtin:gazebo --size 8x6 --repeat 1 --variants grid -q --csv " + nullCsv);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    ASSERT_EQ(Lightmesh(render + dir + "/a.png").exitCode, 0);
    r = Lightmesh("compare " + dir + "/a.png " + dir + "/a.png --diff " + null);
    EXPECT_EQ(r.exitCode, 0) << r.output;
    // /dev/full takes nothing: an error naming it, and it stays a device.
    r = Lightmesh(render + full);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_EQ(r.output, "lightmesh: error: " + full + ": cannot write: No space left on device\n");
    for (const std::string& device : {null, nullCsv, full}) EXPECT_TRUE(IsCharDevice(device)) << device;
    // A FIFO: with no reader an error at once, not a wait; with one, the image arrives.
    const std::string fifo = dir + "/fifo.png";
    ASSERT_EQ(mkfifo(fifo.c_str(), 0644), 0);
    r = Lightmesh(render + fifo);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_EQ(r.output, "lightmesh: error: " + fifo + ": is a FIFO with no reader: nothing written\n");
    std::string received;
    std::thread reader([&] { received = Bytes(fifo); });  // blocks until the writer opens it
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    r = Lightmesh(render + fifo);
    reader.join();
    EXPECT_EQ(r.exitCode, 0) << r.output;
    EXPECT_EQ(received.substr(0, 4), "\x89PNG");
    EXPECT_EQ(received, Bytes(dir + "/a.png"));
    EXPECT_TRUE(IsFifo(fifo));
    // Nothing but the devices, the FIFO and the one image: no temporary file.
    for (const std::string& name : FilesIn(dir)) EXPECT_EQ(name.find(".tmp"), std::string::npos) << name;
}

// A render of hours (such as 16384 x 16384 at aa 16) says how long
// once its first tiles are measured, also when stderr is not a terminal; SIGINT then
// leaves no output.
TEST(Robustness, LongRenderSaysHowLongItWillTake) {
    const Scratch scratch("lm_robust");
    const std::string out = scratch.path + "/long.png";
    // 4096 x 4096 at aa 16: 4.3 G camera rays, several minutes on any machine.
    const CliResult r = lm::testing::RunLightmesh(
        "render builtin:gazebo --width 4096 --height 4096 --aa 16 --shadows rt --threads 2 --force -o " + out,
        "timeout -s INT 12");
    EXPECT_NE(r.output.find("lightmesh: Rendering: about "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(" tiles spread over the image ("), std::string::npos) << r.output;  // (64 unless slow)
    EXPECT_NE(r.output.find("; 4,294,967,296 camera rays (4096x4096 at aa 16), shadows rt; Ctrl-C stops it"),
              std::string::npos)
        << r.output;
    EXPECT_FALSE(fs::exists(out));
    // A short render says nothing of the kind.
    const CliResult quick = Lightmesh("render builtin:gazebo --width 64 --height 48 -o " + out);
    EXPECT_EQ(quick.exitCode, 0) << quick.output;
    EXPECT_EQ(quick.output.find("Rendering: about"), std::string::npos) << quick.output;
}

// A render estimated past an hour is refused, from its first tiles, the output as
// it was; --force renders it (announced, stopped here by SIGINT).
TEST(Robustness, ARenderPastAnHourIsRefusedUnlessForced) {
    const Scratch scratch("lm_robust");
    const std::string out = scratch.path + "/hours.png";
    { std::ofstream(out) << "a previous image"; }
    const std::string render =
        "render builtin:gazebo --width 4096 --height 4096 --aa 16 --shadows area --samples 256 --threads 2 -o " + out;
    const auto start = std::chrono::steady_clock::now();
    const CliResult r = lm::testing::RunLightmesh(render, "timeout -s INT 60");
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 30.0);
    EXPECT_EQ(r.exitCode, 1) << r.output;
    EXPECT_NE(r.output.find("lightmesh: error: " + out + ": not rendered: about "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find(" tiles spread over the image ("), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("more than the limit of 1 h 0 min; 4,294,967,296 camera rays (4096x4096 at aa 16), "
                            "shadows area; --force renders it anyway\n"),
              std::string::npos)
        << r.output;
    EXPECT_EQ(Bytes(out), "a previous image");
    // (Forced, a cheaper one: still hours here, announced within seconds even on a busy machine.)
    std::string cheaper = render;
    cheaper.replace(cheaper.find("--samples 256"), 13, "--samples 16");
    const CliResult forced = lm::testing::RunLightmesh(cheaper + " --force", "timeout -s INT 15");
    EXPECT_EQ(forced.output.find("not rendered"), std::string::npos) << forced.output;
    EXPECT_NE(forced.output.find("lightmesh: Rendering: about "), std::string::npos) << forced.output;
    EXPECT_EQ(Bytes(out), "a previous image");
}

// The estimate comes from tiles spread over the image, made as soon as they are done, the
// set-up apart. A frame whose upper two thirds are sky and whose floor is costly (area
// shadows) is estimated within 3x of its time, early on; the first tiles (sky) alone would
// give a fraction of it.
TEST(Robustness, ASkyFirstFrameIsEstimatedFromTilesSpreadOverIt) {
    lm::Scene s = lm::testing::FloorScene(10);
    lm::testing::AddBox(&s, {-1, 0, -1}, {1, 1.5f, 1});
    s.camera = lm::Camera{{0, 0.6f, 9}, {0, 2.4f, 0}, {0, 1, 0}, 50.0f};
    lm::RenderOptions o = s.render;
    o.width = 480;
    o.height = 360;
    o.shadows = "area";
    o.areaLight.samples = 256;
    o.areaLight.radius = 0.5f;
    const tbb::global_control oneThread(tbb::global_control::max_allowed_parallelism, 1);
    const lm::RenderJob job(s, o);
    lm::ProgressReporter progress(job.Renderer().TileCount(), "Rendering", false);
    const auto t0 = std::chrono::steady_clock::now();
    const lm::RenderResult r = job.Render(&progress);
    const double truth = lm::SecondsSince(t0);
    ASSERT_GT(truth, 0.3) << "too fast to judge";
    EXPECT_GT(progress.EstimatedSeconds(), truth / 3) << truth << " s, estimated after " << progress.EstimatedAfterSeconds();
    EXPECT_LT(progress.EstimatedSeconds(), truth * 3) << truth;
    EXPECT_LT(progress.EstimatedAfterSeconds(), truth / 2) << truth;
    // The image is the one the plain order renders.
    const lm::RenderResult plain = job.Render();
    EXPECT_EQ(std::memcmp(plain.image.pixels.data(), r.image.pixels.data(), r.image.pixels.size() * sizeof(lm::Color)), 0);
}

TEST(Robustness, SpreadSamplesCoverTheGridInEveryPrefix) {
    const std::vector<int64_t> cells = lm::SpreadOverGrid(40, 30, 64);
    EXPECT_GE(cells.size(), 48u);
    EXPECT_LE(cells.size(), 64u);
    std::vector<int64_t> sorted = cells;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_EQ(std::unique(sorted.begin(), sorted.end()), sorted.end());
    // Each quadrant of the grid holds one of the first four, and a quarter of them all.
    int quadrant[4] = {};
    for (size_t i = 0; i < cells.size(); ++i) {
        const int q = (cells[i] % 40 >= 20) + 2 * (cells[i] / 40 >= 15);
        if (i < 4) {
            EXPECT_EQ(quadrant[q], 0) << i;
        }
        ++quadrant[q];
    }
    for (const int n : quadrant) EXPECT_NEAR(n, static_cast<double>(cells.size()) / 4, cells.size() / 12.0);
    // A grid of one row (not one column), and more samples than cells: all of them.
    const std::vector<int64_t> row = lm::SpreadOverGrid(1024, 1, 8);
    EXPECT_EQ(row.size(), 8u);
    EXPECT_EQ(lm::SpreadOverGrid(3, 2, 64), (std::vector<int64_t>{0, 1, 2, 3, 4, 5}));
}

TEST(Robustness, DurationsReadAsAPersonWritesThem) {
    EXPECT_EQ(lm::FormatDuration(8.54), "8.5 s");
    EXPECT_EQ(lm::FormatDuration(725), "12 min 5 s");
    EXPECT_EQ(lm::FormatDuration(3 * 3600 + 12 * 60 + 20), "3 h 12 min");
    EXPECT_EQ(lm::FormatDuration(51e6), "590 d 6 h");
    EXPECT_EQ(lm::FormatDuration(-1), "?");
}

}  // namespace
}  // namespace robustness_test
