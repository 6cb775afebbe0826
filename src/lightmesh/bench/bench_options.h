// bench_options.h -- `lightmesh bench`'s options as given, checked and turned into the
// matrix it runs. The CLI (apps/lightmesh/cmd_bench.cpp) and the Python module's
// lightmesh.bench() both go through MakeBenchMatrix, so the presets, the defaults and the
// checks are one code.
#pragma once

#include <string>
#include <vector>

#include "lightmesh/bench/benchmark.h"

namespace lm {

/// The options that shape the matrix, as given. Keys are the CLI's long options with
/// underscores ("light_radius" for --light-radius), which are the Python keywords.
struct BenchOptions {
    BenchMatrix matrix;              ///< scenes, cc, ki, variants, accels, repeat, quality, ... as given
    std::vector<std::string> sizes;  ///< "WIDTHxHEIGHT" each (replaces matrix.sizes when not empty)
    std::string matrixFile;          ///< --matrix
    int table = 0;                   ///< --table (0: none)
    bool quick = false, noNone = false, force = false;
    std::vector<std::string> given;  ///< the keys given (a default is not "given")
    std::string repoDir;             ///< the repository whose scenes/real --table reads
    bool keywords = false;           ///< messages name options as keywords ("cc=") instead of flags ("--cc")
    bool Given(const std::string& key) const;
};

/// Option `key` as the front end spells it: "--light-radius" or "light_radius=".
std::string BenchOptionName(const BenchOptions& o, const std::string& key);

/// The matrix to run: the values checked (ranges, choices, sizes, the options that exclude
/// each other), --table's or --matrix's preset with the options that still apply, --quick,
/// --no-none, and the hour limit unless --force. Throws Error naming the option.
BenchMatrix MakeBenchMatrix(const BenchOptions& o);

/// The options a front end besides the CLI takes (lightmesh.bench()): key and meaning.
struct BenchOptionInfo {
    const char* key;
    const char* help;
};
const std::vector<BenchOptionInfo>& BenchOptionTable();

}  // namespace lm
