// Replays the fuzzers' kept corpus (fuzz/corpus/<target>/) and every crash they found
// (fuzz/regressions/<target>/) through the fuzzers' own entry points, so the normal test
// suite -- and its sanitizer builds -- keep covering them.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_entry_points.h"

namespace fuzz_regression_test {
namespace {

namespace fs = std::filesystem;

std::vector<fs::path> Inputs(const std::string& kind, const std::string& target) {
    std::vector<fs::path> files;
    const fs::path dir = fs::path(LIGHTMESH_FUZZ_DIR) / kind / target;
    if (fs::is_directory(dir))
        for (const auto& entry : fs::directory_iterator(dir))
            if (entry.is_regular_file()) files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    return files;
}

size_t Replay(const std::string& kind, const std::string& target,
              int (*entry)(const uint8_t*, size_t)) {
    const std::vector<fs::path> files = Inputs(kind, target);
    for (const fs::path& file : files) {
        SCOPED_TRACE(file.string());
        std::ifstream in(file, std::ios::binary);
        const std::string bytes{std::istreambuf_iterator<char>(in), {}};
        EXPECT_NO_THROW(entry(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()));
    }
    return files.size();
}

TEST(FuzzRegression, SceneFileCorpusAndCrashes) {
    EXPECT_GT(Replay("corpus", "fuzz_scene_file", lm::fuzz::FuzzSceneFile), 0u);
    Replay("regressions", "fuzz_scene_file", lm::fuzz::FuzzSceneFile);
}

TEST(FuzzRegression, TemplateFileCorpusAndCrashes) {
    EXPECT_GT(Replay("corpus", "fuzz_template_file", lm::fuzz::FuzzTemplateFile), 0u);
    Replay("regressions", "fuzz_template_file", lm::fuzz::FuzzTemplateFile);
}

// The image decoders: the kept corpus in-process, the findings inside the decoders (an
// out-of-bounds index in stb_image's JPEG Huffman tables, which libjpeg-turbo now reads; an
// EXR attribute whose size asks for gigabytes) through the decoding child, as the renderer
// reads images.
TEST(FuzzRegression, ImageDecodeCorpusAndCrashes) {
    EXPECT_GT(Replay("corpus", "fuzz_image_decode",
                     [](const uint8_t* d, size_t n) { return lm::fuzz::FuzzImageDecode(d, n); }),
              0u);
    EXPECT_GT(Replay("regressions", "fuzz_image_decode",
                     [](const uint8_t* d, size_t n) { return lm::fuzz::FuzzImageDecode(d, n, true); }),
              0u);
}

// Assimp's importers: the kept corpus in-process (none of it crashes Assimp), the crashes
// through the child process, as the renderer imports them.
TEST(FuzzRegression, MeshImportCorpusAndCrashes) {
    EXPECT_GT(Replay("corpus", "fuzz_mesh_import",
                     [](const uint8_t* d, size_t n) { return lm::fuzz::FuzzMeshImport(d, n); }),
              0u);
    // One of them makes Assimp loop forever: the child's deadline, shortened here, stops it.
    setenv("LIGHTMESH_IMPORT_TIMEOUT", "2", 1);
    EXPECT_GT(Replay("regressions", "fuzz_mesh_import",
                     [](const uint8_t* d, size_t n) { return lm::fuzz::FuzzMeshImport(d, n, true); }),
              0u);
    unsetenv("LIGHTMESH_IMPORT_TIMEOUT");
}

}  // namespace
}  // namespace fuzz_regression_test
