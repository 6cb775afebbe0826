// The unit-test runner: quiet logging, so expected warnings do not clutter the output, and
// a private cache folder, so tests never touch the user's template cache.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "lightmesh/util/log.h"

int main(int argc, char** argv) {
    testing::InitGoogleTest(&argc, argv);
    lm::SetLogLevel(lm::LogLevel::Error);
    const std::string cache = testing::TempDir() + "/lightmesh-test-cache-" + std::to_string(getpid());
    std::filesystem::create_directories(cache);
    setenv("XDG_CACHE_HOME", cache.c_str(), 1);
    const int result = RUN_ALL_TESTS();
    std::error_code ec;
    std::filesystem::remove_all(cache, ec);
    return result;
}
