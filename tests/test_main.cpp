// The unit-test runner: quiet logging, so expected warnings do not clutter the output.
#include <gtest/gtest.h>

#include "lightmesh/util/log.h"

int main(int argc, char** argv) {
    testing::InitGoogleTest(&argc, argv);
    lm::SetLogLevel(lm::LogLevel::Error);
    return RUN_ALL_TESTS();
}
