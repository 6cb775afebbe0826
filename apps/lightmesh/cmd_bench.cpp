// cmd_bench.cpp -- `lightmesh bench`.
#include "commands.h"

#include <algorithm>
#include <filesystem>

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
    // An empty list, or an empty name in it, is refused like the other empty values
    // (`--variants ""` ran the default variant).
    if (cmd.variantsOption && cmd.variantsOption->count()) {
        const auto& v = cmd.matrix.variants;
        if (v.empty() || std::any_of(v.begin(), v.end(), [](const std::string& s) { return s.empty(); }))
            lm::ThrowError("--variants: %s (list LMM variants, comma-separated, or leave the option out for the "
                           "default)",
                           v.size() > 1 ? "an empty name in the list" : "must not be empty");
        lm::TakeSoftFromVariants(&cmd.matrix);  // "soft": the default shadow method, timed too
    }
    // Where CC and kI came from, for the light mesh's messages (a CC too large for memory).
    if (cmd.ccOption && cmd.ccOption->count())
        cmd.matrix.ccOrigins.assign(cmd.matrix.cc.size(), lm::SourceLoc::Option("--cc"));
    if (cmd.kiOption && cmd.kiOption->count())
        cmd.matrix.kiOrigins.assign(cmd.matrix.ki.size(), lm::SourceLoc::Option("--ki"));
    if (!cmd.sizes.empty()) {
        cmd.matrix.sizes.clear();
        for (const std::string& s : cmd.sizes) {
            int w = 0, h = 0;
            char x = 0;
            if (std::sscanf(s.c_str(), "%d%c%d", &w, &x, &h) != 3 || (x != 'x' && x != 'X') || w < 1 || h < 1 ||
                w > 16384 || h > 16384)
                lm::ThrowError("--size %s: expected WIDTHxHEIGHT, e.g. 1024x768", s.c_str());
            cmd.matrix.sizes.push_back({w, h});
        }
    }
    // --table / --matrix replace the scenes, sizes, CC, kI and variants (CLI11 rejects them
    // together); the other options still apply.
    if (cmd.table || !cmd.matrixFile.empty()) {
        lm::BenchMatrix preset = cmd.table ? lm::BenchTablePreset(cmd.table, cmd.quick, BenchRepoDir(cmd.argv0))
                                           : lm::LoadBenchMatrix(cmd.matrixFile);
        const lm::BenchMatrix& given = cmd.matrix;
        if (cmd.repeatOption->count()) preset.repeat = given.repeat;
        if (!cmd.matrixFile.empty() && cmd.accelsOption->count()) preset.accels = given.accels;
        // The paper's tables run on its nested grid unless --accels says otherwise.
        if (cmd.table) preset.accels = cmd.accelsOption->count() ? given.accels : std::vector<std::string>{"grid"};
        preset.imageDir = given.imageDir;
        preset.quality = given.quality;
        preset.refSamples = given.refSamples;
        preset.lightRadius = given.lightRadius;
        if (cmd.table) {
            const lm::SourceLoc table = lm::SourceLoc::Option(lm::StringPrintf("bench --table %d", cmd.table));
            preset.ccOrigins.assign(preset.cc.size(), table);
            preset.kiOrigins.assign(preset.ki.size(), table);
        }
        cmd.matrix = preset;
    } else if (cmd.quick) {
        for (auto& s : cmd.matrix.sizes) s = {std::max(1, s.first / 4), std::max(1, s.second / 4)};
        if (!cmd.repeatOption->count()) cmd.matrix.repeat = 1;
    }
    cmd.matrix.noShadows = !cmd.noNone;
    cmd.matrix.maxSeconds = cmd.force ? 0 : lm::kBenchLimitSeconds;
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
