// bench_options.cpp -- `lightmesh bench`'s options into its matrix (see the header).
#include "lightmesh/bench/bench_options.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/settings/render_settings.h"
#include "lightmesh/shadow/light_mesh.h"
#include "lightmesh/util/error.h"

namespace lm {

bool BenchOptions::Given(const std::string& key) const { return std::find(given.begin(), given.end(), key) != given.end(); }

std::string BenchOptionName(const BenchOptions& o, const std::string& key) {
    if (o.keywords) return key + "=";
    std::string flag = "--" + key;
    std::replace(flag.begin(), flag.end(), '_', '-');
    return flag;
}

namespace {

void CheckRange(const BenchOptions& o, const char* key, double v, double lo, double hi) {
    if (!(v >= lo && v <= hi))
        ThrowError("%s: must be between %g and %g, got %g", BenchOptionName(o, key).c_str(), lo, hi, v);
}

void CheckChoice(const BenchOptions& o, const char* key, const std::string& v, const std::vector<std::string>& choices) {
    if (std::find(choices.begin(), choices.end(), v) != choices.end()) return;
    std::string list;
    for (const std::string& c : choices) list += (list.empty() ? "" : ", ") + c;
    ThrowError("%s: \"%s\" is not one of %s", BenchOptionName(o, key).c_str(), Printable(v).c_str(), list.c_str());
}

/// The values the CLI's parser checks, checked again for the other front ends.
void CheckValues(const BenchOptions& o) {
    const BenchMatrix& m = o.matrix;
    const RenderSetting &cc = RenderSettingFor("cc"), &ki = RenderSettingFor("ki");
    for (int v : m.cc) CheckRange(o, "cc", v, cc.lo, cc.hi);
    for (float v : m.ki) CheckRange(o, "ki", v, ki.lo, ki.hi);
    CheckRange(o, "repeat", m.repeat, 1, 100);
    CheckRange(o, "ref_samples", m.refSamples, 1, 4096);
    for (int n : m.competitorSamples) CheckRange(o, "area_samples", n, 1, 4096);
    if (o.table) CheckRange(o, "table", o.table, 1, 4);
    CheckChoice(o, "cell_summaries", m.cellSummaries, {"auto", "on", "off"});
    CheckChoice(o, "thin_check", m.thinCheck, RenderSettingFor("thin_check").choices);
    for (const std::string& a : m.accels) CheckChoice(o, "accels", a, AcceleratorNames());
    if (m.lightRadius && !(*m.lightRadius >= 0 && std::isfinite(*m.lightRadius)))
        ThrowError("%s: must be a finite number >= 0", BenchOptionName(o, "light_radius").c_str());
    for (const char* key : {"scene", "size", "cc", "ki", "variants", "accels", "area_samples"})
        if (o.Given(key)) {
            const bool empty = std::string(key) == "scene"          ? m.scenes.empty()
                               : std::string(key) == "size"         ? o.sizes.empty()
                               : std::string(key) == "cc"           ? m.cc.empty()
                               : std::string(key) == "ki"           ? m.ki.empty()
                               : std::string(key) == "accels"       ? m.accels.empty()
                               : std::string(key) == "area_samples" ? m.competitorSamples.empty()
                                                                    : false;
            if (empty) ThrowError("%s: must not be empty", BenchOptionName(o, key).c_str());
        }
    // --table and --matrix replace the matrix's lists (the CLI's parser refuses them together).
    for (const char* preset : {"table", "matrix"}) {
        if (!o.Given(preset)) continue;
        for (const char* key : {"scene", "size", "cc", "ki", "variants"})
            if (o.Given(key))
                ThrowError("%s cannot be combined with %s", BenchOptionName(o, key).c_str(),
                           BenchOptionName(o, preset).c_str());
    }
    if (o.Given("table") && o.Given("matrix"))
        ThrowError("%s cannot be combined with %s", BenchOptionName(o, "table").c_str(),
                   BenchOptionName(o, "matrix").c_str());
}

}  // namespace

BenchMatrix MakeBenchMatrix(const BenchOptions& o) {
    CheckValues(o);
    BenchMatrix matrix = o.matrix;
    // An empty list, or an empty name in it, is refused like the other empty values
    // (`--variants ""` ran the default variant).
    if (o.Given("variants")) {
        const auto& v = matrix.variants;
        if (v.empty() || std::any_of(v.begin(), v.end(), [](const std::string& s) { return s.empty(); }))
            ThrowError("%s: %s (list LMM variants, comma-separated, or leave the option out for the default)",
                       BenchOptionName(o, "variants").c_str(),
                       v.size() > 1 ? "an empty name in the list" : "must not be empty");
        TakeSoftFromVariants(&matrix);  // "soft": the default shadow method, timed too
    }
    // Where CC and kI came from, for the light mesh's messages (a CC too large for memory).
    if (o.Given("cc")) matrix.ccOrigins.assign(matrix.cc.size(), SourceLoc::Option(BenchOptionName(o, "cc")));
    if (o.Given("ki")) matrix.kiOrigins.assign(matrix.ki.size(), SourceLoc::Option(BenchOptionName(o, "ki")));
    if (!o.sizes.empty()) {
        matrix.sizes.clear();
        for (const std::string& s : o.sizes) {
            int w = 0, h = 0;
            char x = 0, extra = 0;
            if (std::sscanf(s.c_str(), "%d%c%d%c", &w, &x, &h, &extra) != 3 || (x != 'x' && x != 'X') || w < 1 ||
                h < 1 || w > 16384 || h > 16384)
                ThrowError("%s %s: expected WIDTHxHEIGHT, e.g. 1024x768", BenchOptionName(o, "size").c_str(),
                           Printable(s).c_str());
            matrix.sizes.push_back({w, h});
        }
    }
    // --table / --matrix replace the scenes, sizes, CC, kI and variants; the other options
    // still apply.
    if (o.table || !o.matrixFile.empty()) {
        BenchMatrix preset = o.table ? BenchTablePreset(o.table, o.quick, o.repoDir) : LoadBenchMatrix(o.matrixFile);
        const BenchMatrix& given = matrix;
        if (o.Given("repeat")) preset.repeat = given.repeat;
        if (!o.matrixFile.empty() && o.Given("accels")) preset.accels = given.accels;
        // The paper's tables run on its nested grid unless --accels says otherwise.
        if (o.table) preset.accels = o.Given("accels") ? given.accels : std::vector<std::string>{"grid"};
        preset.imageDir = given.imageDir;
        preset.quality = given.quality;
        preset.refSamples = given.refSamples;
        preset.lightRadius = given.lightRadius;
        if (o.table) {
            const SourceLoc table = SourceLoc::Option(StringPrintf("bench %s %d", BenchOptionName(o, "table").c_str(), o.table));
            preset.ccOrigins.assign(preset.cc.size(), table);
            preset.kiOrigins.assign(preset.ki.size(), table);
        }
        matrix = preset;
    } else if (o.quick) {
        for (auto& s : matrix.sizes) s = {std::max(1, s.first / 4), std::max(1, s.second / 4)};
        if (!o.Given("repeat")) matrix.repeat = 1;
    }
    matrix.noShadows = !o.noNone;
    matrix.maxSeconds = o.force ? 0 : kBenchLimitSeconds;
    return matrix;
}

const std::vector<BenchOptionInfo>& BenchOptionTable() {
    static const std::vector<BenchOptionInfo> table = {
        {"scene", "scenes (a list, or one): paths or builtin:NAME; default builtin:gazebo"},
        {"size", "image sizes \"WIDTHxHEIGHT\" (a list, or one); default 1024x768"},
        {"cc", "light mesh CC values (a list, or one), 1-4096; default 100"},
        {"ki", "light mesh kI values (a list, or one), 0.01-16; default 2"},
        {"variants", "light mesh variants (a list, or one); default all seven of the paper's tables and consensus"},
        {"cell_summaries", "auto, on or off for every light mesh cell; default auto"},
        {"accels", "ray-query back-ends for RT (a list, or one); the first also serves no shadows and LMM"},
        {"repeat", "timed runs per cell after a warm-up, 1-100; the median is reported (default 3; 1 with quick)"},
        {"no_none", "skip the render without shadows"},
        {"quick", "every size divided by 4 in each dimension, repeat 1"},
        {"table", "the paper's table 1, 2, 3 or 4 on scenes/real (replaces scene, size, cc, ki, variants)"},
        {"matrix", "the matrix from a JSON file (scenes, sizes, cc, ki, variants, accels, repeat, thin_check)"},
        {"quality", "also judge every cell against a converged area-light reference (PSNR, SSIM, shadow total)"},
        {"area_samples", "with quality: the competitors' area rows, rays per light (a list), 1-4096; default 1,2,4,8,16,32,64,128,256"},
        {"ref_samples", "rays per light of the quality references, 1-4096; default 256"},
        {"light_radius", "with quality: every light's radius in the default-against-competitors table"},
        {"thin_check", "with quality: the penumbra mode's thin-occluder check (all, lit or off)"},
        {"images", "write each cell's image (PNG) into this folder"},
        {"force", "run a matrix estimated to take more than an hour"},
    };
    return table;
}

}  // namespace lm
