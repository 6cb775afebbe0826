// bench_binding.cpp -- lightmesh.bench() of the Python module (docs/python.md): the
// keyword options into lm::BenchOptions, which the CLI's `bench` fills from its command
// line (MakeBenchMatrix checks both alike), the matrix run with the GIL released, and the
// cells as `lightmesh bench --json` writes them.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>


#include <algorithm>
#include <atomic>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "lightmesh/bench/bench_options.h"
#include "lightmesh/bench/benchmark.h"
#include "lightmesh/scene/json_reader.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/log.h"
#include "off_gil.h"

namespace py = pybind11;

namespace {

/// A value as C++ casts it: NumPy scalars become Python ones.
py::object Plain(const py::handle& v) {
    if (py::hasattr(v, "item") && py::hasattr(v, "dtype")) return v.attr("item")();
    return py::reinterpret_borrow<py::object>(v);
}

/// A keyword's value as a list: a list or tuple as it is, anything else as one element.
template <typename T>
std::vector<T> ListOf(const py::handle& v, const std::string& name, const char* what) {
    try {
        if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) {
            std::vector<T> out;
            for (const py::handle& e : v) {
                if constexpr (std::is_same_v<T, std::string>) {
                    if (!py::isinstance<py::str>(e) && !py::hasattr(e, "__fspath__")) throw py::cast_error();
                    out.push_back(py::module_::import("os").attr("fspath")(e).cast<std::string>());
                } else {
                    if (py::isinstance<py::bool_>(e) || py::isinstance<py::str>(e)) throw py::cast_error();
                    out.push_back(Plain(e).cast<T>());
                }
            }
            return out;
        }
        return ListOf<T>(py::make_tuple(v), name, what);
    } catch (const py::cast_error&) {
        throw lm::Error(name + "=: expected " + what + " or a list of them");
    }
}

/// lightmesh.bench(**options): the options into lm::BenchOptions (the CLI's `bench` options,
/// checked and turned into the matrix by MakeBenchMatrix), the matrix run on a worker
/// thread, the cells as `lightmesh bench --json` writes them (BenchJson), parsed.
py::object Bench(const py::kwargs& kwargs) {
    lm::BenchOptions o;
    o.keywords = true;
#ifdef LIGHTMESH_SOURCE_DIR
    o.repoDir = LIGHTMESH_SOURCE_DIR;
#endif
    int threads = 0;
    bool wholeReport = false;
    py::object progressCallback = py::none();
    lm::BenchMatrix& m = o.matrix;
    auto single = [](const py::handle& v, const std::string& name, const char* what, auto example) {
        using T = decltype(example);
        try {
            if constexpr (std::is_same_v<T, bool>) {
                if (!py::isinstance<py::bool_>(v)) throw py::cast_error();
            } else if constexpr (std::is_same_v<T, std::string>) {
                if (!py::isinstance<py::str>(v) && !py::hasattr(v, "__fspath__")) throw py::cast_error();
                return T(py::module_::import("os").attr("fspath")(v).cast<std::string>());
            } else if (py::isinstance<py::bool_>(v) || py::isinstance<py::str>(v)) {
                throw py::cast_error();
            }
            return Plain(v).cast<T>();
        } catch (const py::cast_error&) {
            throw lm::Error(name + "=: expected " + what);
        }
    };
    std::vector<std::string> known = {"threads", "progress", "report"};
    for (const lm::BenchOptionInfo& info : lm::BenchOptionTable()) known.push_back(info.key);
    for (const auto& [k, v] : kwargs) {
        const std::string name = py::str(k);
        if (std::find(known.begin(), known.end(), name) == known.end()) {
            const std::string near = lm::json::Nearest(name, known);
            throw lm::Error(lm::Printable(name) + "=: not an option of lightmesh.bench()" +
                            (near.empty() ? " (help(lightmesh.bench) lists them)" : "; did you mean " + near + "=?"));
        }
        if (v.is_none()) continue;  // None: the default
        o.given.push_back(name);
        if (name == "threads") {
            threads = single(v, name, "an int", 0);
            if (threads < 0 || threads > 1024) throw lm::Error("threads=: must be between 0 and 1024");
        } else if (name == "progress") {
            if (!PyCallable_Check(v.ptr())) throw lm::Error("progress=: expected a callable f(done, total) or None");
            progressCallback = py::reinterpret_borrow<py::object>(v);
        } else if (name == "report") {
            wholeReport = single(v, name, "True or False", false);
        } else if (name == "scene") {
            m.scenes = ListOf<std::string>(v, name, "a scene (a path or \"builtin:NAME\")");
        } else if (name == "size") {
            o.sizes = ListOf<std::string>(v, name, "\"WIDTHxHEIGHT\"");
        } else if (name == "cc") {
            m.cc = ListOf<int>(v, name, "an int");
        } else if (name == "ki") {
            m.ki = ListOf<float>(v, name, "a number");
        } else if (name == "variants") {
            m.variants = ListOf<std::string>(v, name, "a variant name");
        } else if (name == "accels") {
            m.accels = ListOf<std::string>(v, name, "a back-end name");
        } else if (name == "area_samples") {
            m.competitorSamples = ListOf<int>(v, name, "an int");
        } else if (name == "cell_summaries") {
            m.cellSummaries = single(v, name, "a str", std::string());
        } else if (name == "thin_check") {
            m.thinCheck = single(v, name, "a str", std::string());
        } else if (name == "matrix") {
            o.matrixFile = single(v, name, "a path", std::string());
        } else if (name == "images") {
            m.imageDir = single(v, name, "a path", std::string());
        } else if (name == "repeat") {
            m.repeat = single(v, name, "an int", 0);
        } else if (name == "ref_samples") {
            m.refSamples = single(v, name, "an int", 0);
        } else if (name == "table") {
            o.table = single(v, name, "an int", 0);
        } else if (name == "light_radius") {
            m.lightRadius = single(v, name, "a number", 0.0f);
        } else if (name == "quality") {
            m.quality = single(v, name, "True or False", false);
        } else if (name == "quick") {
            o.quick = single(v, name, "True or False", false);
        } else if (name == "no_none") {
            o.noNone = single(v, name, "True or False", false);
        } else if (name == "force") {
            o.force = single(v, name, "True or False", false);
        }
    }
    if (o.table && o.repoDir.empty()) throw lm::Error("table=: this module does not know the repository's scenes/real");
    lm::BenchMatrix matrix;
    {
        py::gil_scoped_release release;
        matrix = lm::MakeBenchMatrix(o);
    }
    if (matrix.lightRadius && !matrix.quality)
        lm::LogWarning("bench: light_radius= is ignored without quality=True (it sizes the competitors' table)");

    // The matrix on a worker thread; this thread looks for signals and reports progress
    // between waits of 50 ms. Ctrl-C stops the bench after the render under way (the bench
    // starts no render once BenchMatrix::stop is set).
    std::atomic<bool> stop{false};
    std::atomic<int> cellsDone{0}, cellsTotal{0};
    lm::BenchReport report;
    int lastDone = -1;  // the count progress() was last called with
    lm::python::RunOffPythonThread(
        threads,
        [&] {
            matrix.stop = &stop;
            report = lm::RunBenchmarkReport(matrix, [&](int n, int total, const lm::BenchResult&) {
                cellsDone = n, cellsTotal = total;
            });
        },
        [&](const char*) { stop = true; },
        [&] {
            if (progressCallback.is_none() || cellsDone == lastDone || cellsTotal == 0) return;
            lastDone = cellsDone;
            progressCallback(lastDone, cellsTotal.load());
        });
    if (!progressCallback.is_none() && cellsTotal > 0 && cellsDone != lastDone) progressCallback(cellsDone.load(), cellsTotal.load());
    const py::object doc = py::module_::import("json").attr("loads")(lm::BenchJson(report));
    return wholeReport ? doc : doc["cells"];
}

std::string BenchDoc() {
    std::string doc =
        "bench(**options) -> list of dict\n\n"
        "Runs `lightmesh bench`'s matrix (scenes x sizes x CC x kI x variants, plus RT and no shadows; with "
        "quality=True the default against its competitors, judged against an area-light reference) and returns its "
        "cells as `lightmesh bench --json` writes them: per cell scene, width, height, method, variant, paper_name, "
        "accel, cc, ki, samples, role, median_s, runs_s, setup_s, image, camera_rays, shadow_rays, "
        "peak_memory_bytes, and with quality=True ref_psnr, ref_ssim, shadow_total_ratio for the competitors' cells "
        "(None: not finite). report=True returns the whole document instead: {\"repeat\", \"cells\", \"quality\"}. "
        "The GIL is released; Ctrl-C (KeyboardInterrupt) stops it after the render under way. Raises lightmesh.Error "
        "with the CLI's message, naming the keyword.\n\n"
        "Options (`lightmesh bench`'s, underscores for dashes; a list option takes a list or one value; None is the "
        "default):\n";
    for (const lm::BenchOptionInfo& info : lm::BenchOptionTable()) doc += std::string("    ") + info.key + ": " + info.help + "\n";
    doc += "    threads (int): worker threads (default 0: all cores)\n"
           "    progress (callable): called as f(done, total) from the calling thread as cells finish\n"
           "    report (bool): return the whole JSON document, not its cells\n";
    return doc;
}

}  // namespace

void DefineBench(py::module_& m) { m.def("bench", &Bench, BenchDoc().c_str()); }
