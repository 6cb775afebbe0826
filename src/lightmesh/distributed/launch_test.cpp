#include "lightmesh/distributed/launch.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

namespace lm {
namespace launch_test {
namespace {

// The launcher's variables, set and restored around each check.
struct ScopedEnv {
    explicit ScopedEnv(const char* name) : name_(name) {
        if (const char* v = std::getenv(name)) saved_ = v, had_ = true;
        unsetenv(name);
    }
    ~ScopedEnv() {
        if (had_) setenv(name_, saved_.c_str(), 1);
        else unsetenv(name_);
    }
    void Set(const char* value) { setenv(name_, value, 1); }
    const char* name_;
    std::string saved_;
    bool had_ = false;
};

TEST(Launch, ReadsOpenMpisAndHydrasVariables) {
    ScopedEnv size("OMPI_COMM_WORLD_SIZE"), rank("OMPI_COMM_WORLD_RANK"), pmiSize("PMI_SIZE"),
        pmiRank("PMI_RANK"), pmixRank("PMIX_RANK");
    EXPECT_FALSE(LaunchedByMpi());
    EXPECT_EQ(LauncherWorldSize(), 1);
    EXPECT_EQ(LauncherWorldRank(), 0);
    size.Set("3");
    rank.Set("2");
    EXPECT_TRUE(LaunchedByMpi());
    EXPECT_EQ(LauncherWorldSize(), 3);
    EXPECT_EQ(LauncherWorldRank(), 2);
    size.Set("1");  // mpirun -np 1: launched, one rank
    rank.Set("0");
    EXPECT_TRUE(LaunchedByMpi());
    EXPECT_EQ(LauncherWorldSize(), 1);
    unsetenv("OMPI_COMM_WORLD_SIZE");
    unsetenv("OMPI_COMM_WORLD_RANK");
    pmiSize.Set("4");
    pmiRank.Set("1");
    EXPECT_TRUE(LaunchedByMpi());
    EXPECT_EQ(LauncherWorldSize(), 4);
    EXPECT_EQ(LauncherWorldRank(), 1);
    // Garbage is ignored, not trusted.
    pmiSize.Set("4x");
    pmiRank.Set("-1");
    EXPECT_FALSE(LaunchedByMpi());
    EXPECT_EQ(LauncherWorldSize(), 1);
    EXPECT_EQ(LauncherWorldRank(), 0);
}

}  // namespace
}  // namespace launch_test
}  // namespace lm
