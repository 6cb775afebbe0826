// Helpers of the tests that run the real `lightmesh` executable (LIGHTMESH_EXE): the
// integration tests under tests/integration and the CLI parts of unit tests.
#pragma once

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace lm::testing {

struct CliResult {
    int exitCode = -1;   ///< 128 + signal if it died by a signal; -1 if it could not start
    std::string output;  ///< stdout and stderr together
};

/// `name` in a temporary folder of the running test's own (`prefix`_TestName_pid): ctest runs a
/// file's tests side by side, and two builds' test runs can share /tmp, so fixed paths shared
/// between tests would race.
inline std::string TestTempPath(const std::string& prefix, const std::string& name) {
    const std::filesystem::path dir =
        std::filesystem::path(::testing::TempDir()) /
        (prefix + "_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
         std::to_string(getpid()));
    std::filesystem::create_directories(dir);
    return (dir / name).string();
}

/// Runs `prefix lightmesh args` through the shell and waits for it. `prefix` goes before the
/// executable (environment variables, setpriv), `args` after it.
inline CliResult RunLightmesh(const std::string& args, const std::string& prefix = "") {
    const std::string cmd = prefix + " " + LIGHTMESH_EXE + " " + args + " 2>&1";
    CliResult run;
    FILE* pipe = popen(cmd.c_str(), "r");
    if (!pipe) return run;
    std::array<char, 4096> buf;
    size_t n;
    while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) run.output.append(buf.data(), n);
    const int status = pclose(pipe);
    run.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    return run;
}

/// Starts `lightmesh args...` without a shell and without waiting; stdout goes to /dev/null
/// so that several children do not interleave with the test's output.
inline pid_t SpawnLightmesh(const std::vector<std::string>& args) {
    const pid_t pid = fork();
    if (pid == 0) {
        std::vector<char*> argv{const_cast<char*>("lightmesh")};
        for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
        argv.push_back(nullptr);
        if (FILE* null = std::freopen("/dev/null", "w", stdout)) (void)null;
        execv(LIGHTMESH_EXE, argv.data());
        _exit(127);
    }
    return pid;
}

/// A file's whole content ("" if it cannot be read).
inline std::string FileBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), {}};
}

/// The sorted names in a folder.
inline std::vector<std::string> FilesIn(const std::string& folder) {
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(folder))
        names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

/// A fresh, empty folder for the running test, per process (several test runs may share
/// /tmp), removed afterwards unless the test failed.
struct ScratchFolder {
    std::string path;
    explicit ScratchFolder(const std::string& prefix = "lm") {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        std::string name = info->name();
        std::replace(name.begin(), name.end(), '/', '_');
        path = (std::filesystem::path(::testing::TempDir()) /
                (prefix + "-" + std::to_string(getpid()) + "-" + name))
                   .string();
        std::filesystem::remove_all(path);
        std::filesystem::create_directories(path);
    }
    ~ScratchFolder() {
        std::error_code ec;
        if (!::testing::Test::HasFailure()) std::filesystem::remove_all(path, ec);
    }
    ScratchFolder(const ScratchFolder&) = delete;
    ScratchFolder& operator=(const ScratchFolder&) = delete;
};

}  // namespace lm::testing
