// cmd_bench.cpp -- `lightmesh bench`.
#include "commands.h"

#include <algorithm>
#include <filesystem>

#include "lightmesh/bench/bench_options.h"
#include "lightmesh/util/log.h"

namespace lm::cli {

/// The repository (for scenes/real): the source dir compiled in, else two folders above
/// the executable (build/apps/lightmesh).
namespace {
std::string BenchRepoDir(const std::string& argv0) {
    namespace fs = std::filesystem;
    std::vector<fs::path> candidates;
#ifdef LIGHTMESH_SOURCE_DIR
    candidates.push_back(LIGHTMESH_SOURCE_DIR);
#endif
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (!ec) candidates.push_back(exe.parent_path().parent_path().parent_path());
    if (!argv0.empty()) candidates.push_back(fs::absolute(argv0, ec).parent_path().parent_path().parent_path());
    for (const fs::path& c : candidates)
        if (fs::exists(c / "scenes" / "real", ec)) return c.string();
    lm::ThrowError("bench --table: cannot find the repository's scenes/real folder (looked in %s)",
                   candidates.empty() ? "nothing" : candidates.front().string().c_str());
}

}  // namespace

int RunBench(BenchCommand& cmd) {
    lm::SetLogLevel(cmd.quiet ? lm::LogLevel::Error : (cmd.verbose ? lm::LogLevel::Info : lm::LogLevel::Warning));
    lm::InstallInterruptCleanup();
    // The matrix from the options, as lightmesh.bench() makes it (bench/bench_options.h).
    lm::BenchOptions options;
    options.matrix = cmd.matrix;
    options.sizes = cmd.sizes;
    options.matrixFile = cmd.matrixFile;
    options.table = cmd.table;
    options.quick = cmd.quick;
    options.noNone = cmd.noNone;
    options.force = cmd.force;
    const std::pair<const char*, CLI::Option*> given[] = {{"variants", cmd.variantsOption}, {"cc", cmd.ccOption},
                                                          {"ki", cmd.kiOption},             {"repeat", cmd.repeatOption},
                                                          {"accels", cmd.accelsOption}};
    for (const auto& [key, option] : given)
        if (option && option->count()) options.given.push_back(key);
    if (cmd.table) options.repoDir = BenchRepoDir(cmd.argv0);
    cmd.matrix = lm::MakeBenchMatrix(options);
    if (cmd.matrix.lightRadius && !cmd.matrix.quality)
        lm::LogWarning("bench: --light-radius is ignored without --quality (it sizes the competitors' table)");
    for (const std::string& path : {cmd.csv, cmd.markdown, cmd.html, cmd.json})
        if (!path.empty()) lm::CheckWritableFolder(path);
    if (!cmd.html.empty() && cmd.matrix.imageDir.empty()) {
        // The report embeds the images: render them next to it.
        const std::filesystem::path p(cmd.html);
        cmd.matrix.imageDir = (p.parent_path() / (p.stem().string() + "-images")).string();
        std::filesystem::create_directories(cmd.matrix.imageDir);
    }
    const auto start = Clock::now();
    const auto report = lm::RunBenchmarkReport(
        cmd.matrix,
        [&](int done, int total, const lm::BenchResult& r) {
            if (cmd.quiet) return;
            const double elapsed = SecondsSince(start);
            std::fprintf(stderr, "[%d/%d] %s %dx%d %s%s: %.3f s (median of %zu); %.0f s elapsed, ~%.0f s left\n", done,
                         total, r.scene.c_str(), r.width, r.height, r.paperName.c_str(),
                         r.method == "lmm"        ? lm::StringPrintf(" CC %d kI %g", r.cc, r.ki).c_str()
                         : r.method == "penumbra" ? lm::StringPrintf(" CC %d kI %g, light radius %g", r.cc, r.ki,
                                                                     r.lightRadius).c_str()
                                                  : (" " + r.accel).c_str(),
                         r.median, r.seconds.size(), elapsed, elapsed / done * (total - done));
        },
        [&](double seconds) {
            if (cmd.quiet) return;
            std::fprintf(stderr,
                         "bench: estimated %s in all (sampled tiles of RT and LMM renders timed per scene, "
                         "extrapolated by pixels, CC, kI and method)%s\n",
                         lm::FormatDuration(seconds).c_str(), cmd.matrix.quality ? ", quality references included" : "");
        });
    std::string md = lm::BenchMarkdown(report.results);
    if (!report.quality.empty()) md += lm::BenchQualityMarkdown(report);
    std::printf("%s", md.c_str());
    auto write = [](const std::string& path, const std::string& text) {
        lm::WriteFileAtomically(path, [&](const std::string& tmp) {
            FILE* f = std::fopen(tmp.c_str(), "wb");
            if (!f || std::fwrite(text.data(), 1, text.size(), f) != text.size() || std::fclose(f) != 0)
                lm::ThrowErrorAt({path}, "cannot write");
        });
    };
    if (!cmd.csv.empty()) write(cmd.csv, lm::BenchCsv(report.results));
    if (!cmd.markdown.empty()) write(cmd.markdown, md);
    if (!cmd.json.empty()) write(cmd.json, lm::BenchJson(report));
    if (!cmd.html.empty()) {
        write(cmd.html, lm::BenchHtml(report, cmd.table ? lm::StringPrintf("lightmesh bench: the paper's table %d%s",
                                                                           cmd.table, cmd.quick ? " (quick)" : "")
                                                        : "lightmesh bench"));
        if (!cmd.quiet) std::fprintf(stderr, "bench: wrote %s\n", cmd.html.c_str());
    }
    return 0;
}

}  // namespace lm::cli
