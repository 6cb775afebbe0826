// lightmesh_module.cpp -- the Python module `lightmesh` (docs/python.md). Thin: scenes are
// loaded by the scene loader, keyword options are read as a scene file's "render" object
// (the settings table's keys, checks and messages), renders run through RenderJob, images
// go through the io code. What is here is the translation between Python and those.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>


#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/io/compare.h"
#include "lightmesh/io/image.h"
#include "lightmesh/render/render_job.h"
#include "lightmesh/render/visibility_image.h"
#include "lightmesh/scene/json_reader.h"
#include "lightmesh/scene/scene_file.h"
#include "lightmesh/scene/scene_load.h"
#include "lightmesh/settings/render_settings.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/log.h"
#include "lightmesh/util/progress.h"
#include "lightmesh/util/system.h"
#include "off_gil.h"
#include "view_keywords.h"

namespace py = pybind11;

/// lightmesh.bench (bench_binding.cpp).
void DefineBench(py::module_& m);

namespace {

// ---- Keyword options ------------------------------------------------------------------

/// A render option as a keyword: the CLI's long flag with underscores ("light_radius",
/// "no_textures"), and the settings table's row.
struct Keyword {
    std::string name;
    const lm::RenderSetting* setting;
};

const std::vector<Keyword>& Keywords() {
    static const std::vector<Keyword> keywords = [] {
        std::vector<Keyword> k;
        for (const lm::RenderSetting& s : lm::RenderSettings()) {
            std::string name = std::string(s.flag).substr(2);
            std::replace(name.begin(), name.end(), '-', '_');
            k.push_back({name, &s});
        }
        return k;
    }();
    return keywords;
}

const Keyword* FindKeyword(const std::string& name) {
    for (const Keyword& k : Keywords())
        if (k.name == name) return &k;
    return nullptr;
}

/// Keywords every render call takes besides the settings table's.
const std::vector<std::string> kCallKeywords = {"threads", "strict", "progress", "visibility"};

/// The options of one call, sorted out: the table's as a scene file's "render" object.
struct CallOptions {
    py::dict render;                 ///< scene-file key -> value
    std::vector<std::string> given;  ///< scene-file keys given
    std::optional<int> width, height;
    bool noTextures = false, noInstancing = false;
    lm::python::ViewKeywords view;  ///< camera=, smooth_normals=, camera_position=, ...
    int threads = 0;
    bool strict = false;
    bool visibility = false;  ///< also return the per-light visibility
    py::object progress = py::none();
};

using lm::python::Plain;

[[noreturn]] void UnknownKeyword(const std::string& name, const std::string& function,
                                 const std::vector<std::string>& extra) {
    std::vector<std::string> names = extra;
    for (const Keyword& k : Keywords()) names.push_back(k.name);
    const std::string near = lm::json::Nearest(name, names);
    throw lm::Error(lm::Printable(name) + "=: not an option of lightmesh." + function + "()" +
                    (near.empty() ? " (help(lightmesh." + function + ") lists them)" : "; did you mean " + near + "=?"));
}

CallOptions ParseOptions(const py::kwargs& kwargs, const std::string& function, bool callKeywords = true) {
    CallOptions o;
    for (const auto& [k, v] : kwargs) {
        const std::string name = py::str(k);
        if (callKeywords && name == "threads") {
            o.threads = py::cast<int>(v);
            if (o.threads < 0 || o.threads > 1024) throw lm::Error("threads=: must be between 0 and 1024");
            continue;
        }
        if (callKeywords && name == "strict") {
            o.strict = py::cast<bool>(v);
            continue;
        }
        if (callKeywords && name == "visibility") {
            if (!py::isinstance<py::bool_>(v)) throw lm::Error("visibility=: expected True or False");
            o.visibility = py::cast<bool>(v);
            continue;
        }
        if (callKeywords && name == "progress") {
            o.progress = py::reinterpret_borrow<py::object>(v);
            if (!o.progress.is_none() && !PyCallable_Check(o.progress.ptr()))
                throw lm::Error("progress=: expected a callable f(fraction) or None");
            continue;
        }
        if (callKeywords && lm::python::ParseViewKeyword(name, v, &o.view)) continue;
        const Keyword* kw = FindKeyword(name);
        if (!kw) {
            std::vector<std::string> extra;
            if (callKeywords) {
                extra = kCallKeywords;
                extra.insert(extra.end(), lm::python::kViewKeywords.begin(), lm::python::kViewKeywords.end());
            }
            UnknownKeyword(name, function, extra);
        }
        const lm::RenderSetting& s = *kw->setting;
        o.given.push_back(s.key);
        if (s.kind == lm::RenderSetting::Kind::Bool) {
            // A flag that turns its setting off: no_textures=True is "textures": false.
            if (!py::isinstance<py::bool_>(v)) throw lm::Error(name + "=: expected True or False");
            // These reach the loader (SceneLoadOptions), as --no-textures does.
            const bool on = py::cast<bool>(v);
            if (std::string(s.key) == "textures") o.noTextures = on;
            if (std::string(s.key) == "instancing") o.noInstancing = on;
            continue;
        }
        o.render[s.key] = Plain(v);
        if (std::string(s.key) == "width" && py::isinstance<py::int_>(o.render[s.key])) o.width = py::cast<int>(o.render[s.key]);
        if (std::string(s.key) == "height" && py::isinstance<py::int_>(o.render[s.key])) o.height = py::cast<int>(o.render[s.key]);
    }
    return o;
}

std::string KeywordOf(const std::string& key) {
    for (const Keyword& k : Keywords())
        if (k.setting->key == key) return k.name;
    return key;
}

/// Applies the options to `options` through the scene file's reader: the same ranges,
/// choices and messages, worded with the keyword ("width=: must be between 1 and 16384,
/// got 0"); each value's origin is its keyword.
void ApplyOptions(const CallOptions& o, lm::RenderOptions* options) {
    if (o.render.empty()) return;
    const std::string text = py::module_::import("json").attr("dumps")(o.render).cast<std::string>();
    try {
        lm::ReadRenderSettings("options", text, options);
    } catch (const lm::Error& e) {
        const std::string& path = e.Where().jsonPath;
        if (path.size() > 1) throw lm::Error(lm::SourceLoc::Option(KeywordOf(path.substr(1)) + "="), e.Reason());
        throw;
    }
    for (const std::string& key : o.given) options->origins[key] = lm::SourceLoc::Option(KeywordOf(key) + "=");
}

// ---- Scenes ---------------------------------------------------------------------------

/// A scene argument: a path (str or os.PathLike), "builtin:NAME", or a dict in the scene
/// file format (its mesh paths relative to the current folder).
struct SceneSpec {
    std::string spec;
    std::optional<std::string> text;
};

SceneSpec ToSceneSpec(const py::object& scene) {
    if (py::isinstance<py::dict>(scene)) {
        const std::string text = py::module_::import("json").attr("dumps")(scene).cast<std::string>();
        return {"<dict>.json", text};
    }
    if (py::isinstance<py::str>(scene) || py::hasattr(scene, "__fspath__"))
        return {py::module_::import("os").attr("fspath")(scene).cast<std::string>(), std::nullopt};
    throw lm::Error("scene: expected a path, \"builtin:NAME\" or a dict in the scene file format");
}

lm::Scene LoadSceneFor(const SceneSpec& s, const CallOptions& o) {
    lm::SceneLoadOptions load;
    load.strict = o.strict;
    load.textures = !o.noTextures;
    load.instancing = !o.noInstancing;
    load.frameWidth = o.width.value_or(0);
    load.frameHeight = o.height.value_or(0);
    load.text = s.text;
    std::vector<std::string> warnings;
    lm::Scene scene = lm::python::LoadWithView(s.spec, o.view, load, &warnings);
    for (const std::string& w : warnings) lm::LogWarning(w);
    return scene;
}

// ---- Images ---------------------------------------------------------------------------

py::array_t<float> ToArray(const lm::Image& image) {
    py::array_t<float> a({static_cast<py::ssize_t>(image.height), static_cast<py::ssize_t>(image.width),
                          static_cast<py::ssize_t>(3)});
    float* out = a.mutable_data();
    for (size_t i = 0; i < image.pixels.size(); ++i) {
        out[3 * i] = image.pixels[i].r;
        out[3 * i + 1] = image.pixels[i].g;
        out[3 * i + 2] = image.pixels[i].b;
    }
    return a;
}

lm::Image FromArray(const py::handle& h, const char* what) {
    const auto a = py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(h);
    if (!a || a.ndim() != 3 || a.shape(2) != 3 || a.shape(0) < 1 || a.shape(1) < 1)
        throw lm::Error(std::string(what) + ": expected a (height, width, 3) array of linear RGB, or a path");
    if (a.shape(0) > 65536 || a.shape(1) > 65536) throw lm::Error(std::string(what) + ": larger than 65536 pixels a side");
    lm::Image image(static_cast<int>(a.shape(1)), static_cast<int>(a.shape(0)));
    const float* in = a.data();
    for (size_t i = 0; i < image.pixels.size(); ++i) image.pixels[i] = lm::Color(in[3 * i], in[3 * i + 1], in[3 * i + 2]);
    return image;
}

/// A visibility image as a float32 (height, width, lights) array owning its values.
py::array_t<float> VisibilityArray(lm::VisibilityImage visibility) {
    auto* values = new std::vector<float>(std::move(visibility.values));
    py::capsule owner(values, [](void* p) { delete static_cast<std::vector<float>*>(p); });
    const py::ssize_t w = visibility.width, h = visibility.height, l = static_cast<py::ssize_t>(visibility.lights);
    const py::ssize_t f = sizeof(float);
    return py::array_t<float>({h, w, l}, {w * l * f, l * f, f}, values->data(), owner);
}

/// An image argument: a path (read) or an array.
lm::Image ImageArg(const py::object& x, const char* what) {
    if (py::isinstance<py::str>(x) || py::hasattr(x, "__fspath__")) {
        const std::string path = py::module_::import("os").attr("fspath")(x).cast<std::string>();
        py::gil_scoped_release release;
        return lm::ReadImage(path);
    }
    return FromArray(x, what);
}

// ---- Rendering ------------------------------------------------------------------------

/// Runs `job` on a worker thread while this (Python) thread, the GIL released between
/// looks, checks for signals (KeyboardInterrupt stops the render: the tile renderers stop
/// at their next tile) and calls `progress(fraction)`. Returns the result, or raises.
lm::RenderResult RunJob(const lm::RenderJob& job, const py::object& progressCallback, int threads,
                        lm::VisibilityImage* visibility) {
    lm::ProgressReporter progress(job.Renderer().TileCount(), "Rendering", false);
    lm::RenderResult result;
    double lastFraction = -1;
    lm::python::RunOffPythonThread(
        threads, [&] { result = job.Render(&progress, visibility); },
        [&](const char* reason) { progress.Stop(reason); },
        [&] {
            if (progressCallback.is_none()) return;
            const double fraction =
                std::min(1.0, static_cast<double>(progress.UnitsDone()) / static_cast<double>(progress.Total()));
            if (fraction == lastFraction) return;
            lastFraction = fraction;
            progressCallback(fraction);
        });
    if (!progressCallback.is_none()) progressCallback(1.0);
    return result;
}

/// A loaded scene with its render options and the ray-query back-end built for it, kept
/// between renders while the mesh and the back-end's options stay the same.
class PyScene {
  public:
    PyScene(lm::Scene scene, lm::RenderOptions options, std::vector<std::string> given, std::string spec)
        : scene_(std::move(scene)), options_(std::move(options)), given_(std::move(given)), spec_(std::move(spec)) {}

    py::object Render(const py::kwargs& kwargs) {
        CallOptions o = ParseOptions(kwargs, "Scene.render");
        if (o.noTextures || o.noInstancing || o.view.camera || o.view.smoothNormals)
            throw lm::Error("no_textures=, no_instancing=, camera= and smooth_normals= are load options: give them "
                            "to lightmesh.load()");
        // One render at a time per scene (it holds the back-end); the lock is taken
        // without the GIL, so a render in another thread can finish.
        std::unique_lock<std::mutex> lock(mutex_, std::defer_lock);
        {
            py::gil_scoped_release release;
            lock.lock();
        }
        lm::RenderOptions options = options_;
        ApplyOptions(o, &options);
        std::vector<std::string> given = given_;
        given.insert(given.end(), o.given.begin(), o.given.end());
        if (changed_) {
            lm::scene_load::Validate(scene_);
            changed_ = false;
        }
        // The camera keywords move the camera for this render only.
        const lm::Camera camera = scene_.camera;
        struct Restore {
            lm::Scene& scene;
            const lm::Camera& camera;
            ~Restore() { scene.camera = camera; }
        } restore{scene_, camera};
        lm::python::MoveCameraForOneRender(spec_, o.view, &scene_);
        lm::CheckRenderOptions(scene_, options, given);
        const bool hadInstances = scene_.mesh.instances != nullptr;
        lm::PrepareSceneForRender(&scene_, options, spec_);
        const bool flattened = hadInstances && !scene_.mesh.instances;
        if (!accel_ || flattened || accelName_ != options.accel ||
            accelOptions_.gridResolution != options.accelOptions.gridResolution) {
            accel_.reset();
            py::gil_scoped_release release;
            accel_ = lm::NamingOrigins(options,
                                       [&] { return lm::CreateAccelerator(options.accel, scene_.mesh, options.accelOptions); });
            accelName_ = options.accel;
            accelOptions_ = options.accelOptions;
        }
        std::unique_ptr<lm::RenderJob> job;
        {
            py::gil_scoped_release release;
            job = std::make_unique<lm::RenderJob>(scene_, options, accel_.get());
        }
        if (!o.visibility) return ToArray(RunJob(*job, o.progress, o.threads, nullptr).image);
        std::optional<lm::VisibilityImage> visibility;
        {
            py::gil_scoped_release release;
            visibility.emplace(job->MakeVisibility());
        }
        py::array_t<float> image = ToArray(RunJob(*job, o.progress, o.threads, &*visibility).image);
        return py::make_tuple(image, VisibilityArray(std::move(*visibility)));
    }

    lm::Scene& Get() { return scene_; }
    void Changed() { changed_ = true; }
    const lm::RenderOptions& Options() const { return options_; }

  private:
    lm::Scene scene_;
    lm::RenderOptions options_;
    std::vector<std::string> given_;
    std::string spec_;
    std::unique_ptr<lm::Accelerator> accel_;
    std::string accelName_;
    lm::AccelOptions accelOptions_;
    bool changed_ = false;
    std::mutex mutex_;
};

std::shared_ptr<PyScene> Load(const py::object& sceneArg, const py::kwargs& kwargs, const std::string& function) {
    const CallOptions o = ParseOptions(kwargs, function);
    const SceneSpec spec = ToSceneSpec(sceneArg);
    lm::Scene scene = LoadSceneFor(spec, o);
    lm::RenderOptions options = scene.render;
    ApplyOptions(o, &options);
    return std::make_shared<PyScene>(std::move(scene), std::move(options), o.given, spec.spec);
}

py::object Render(const py::object& sceneArg, const py::kwargs& kwargs) {
    // threads=, progress= and visibility= are the render's; strict= the load's (Load reads
    // them all).
    py::kwargs renderOnly;
    for (const char* k : {"threads", "progress", "visibility"})
        if (kwargs.contains(k)) renderOnly[k] = kwargs[k];
    const std::shared_ptr<PyScene> scene = Load(sceneArg, kwargs, "render");
    return scene->Render(renderOnly);
}

// ---- Camera and lights ----------------------------------------------------------------

py::tuple Tuple(const lm::Vec3& v) { return py::make_tuple(v.x, v.y, v.z); }
py::tuple Tuple(const lm::Color& c) { return py::make_tuple(c.r, c.g, c.b); }

lm::Vec3 ToVec3(const py::handle& h, const char* what) {
    const auto seq = py::cast<std::vector<float>>(h);
    if (seq.size() != 3) throw lm::Error(std::string(what) + ": expected 3 numbers");
    return lm::Vec3(seq[0], seq[1], seq[2]);
}

lm::Color ToColor(const py::handle& h, const char* what) {
    if (py::isinstance<py::float_>(h) || py::isinstance<py::int_>(h)) return lm::Color(py::cast<float>(h));
    const lm::Vec3 v = ToVec3(h, what);
    return lm::Color(v.x, v.y, v.z);
}

/// Scene.camera: reads and writes the loaded scene's camera.
struct PyCamera {
    std::shared_ptr<PyScene> scene;
    lm::Camera& Get() const { return scene->Get().camera; }
};

/// Scene.lights[i]: reads and writes one light of the loaded scene.
struct PyLight {
    std::shared_ptr<PyScene> scene;
    size_t index;
    lm::PointLight& Get() const {
        if (index >= scene->Get().lights.size()) throw lm::Error("the light is gone");
        return scene->Get().lights[index];
    }
};

// ---- Documentation ----------------------------------------------------------------------

std::string OptionsDoc() {
    std::string doc = "Options (the CLI's `lightmesh render` flags with underscores; the scene file's values "
                      "and then these replace the defaults):\n";
    for (const Keyword& k : Keywords()) {
        const lm::RenderSetting& s = *k.setting;
        std::string kind;
        switch (s.kind) {
            case lm::RenderSetting::Kind::Int: kind = lm::StringPrintf("int, %g..%g", s.lo, s.hi); break;
            case lm::RenderSetting::Kind::Float:
                kind = std::isfinite(s.hi) ? lm::StringPrintf("float, %g..%g", s.lo, s.hi)
                                           : lm::StringPrintf("float >= %g", s.lo);
                break;
            case lm::RenderSetting::Kind::String: kind = "str"; break;
            case lm::RenderSetting::Kind::Choice: {
                kind = "one of";
                for (size_t i = 0; i < s.choices.size(); ++i) kind += (i ? ", " : " ") + s.choices[i];
                break;
            }
            case lm::RenderSetting::Kind::Bool: kind = "bool"; break;
        }
        doc += "    " + k.name + " (" + kind + "): " + s.help + "\n";
    }
    doc += lm::python::kViewKeywordsDoc;
    doc += "    threads (int): worker threads (default 0: all cores)\n"
           "    strict (bool): unknown keys in the scene file are errors, not warnings\n"
           "    progress (callable): called with the fraction done (0..1) from the calling thread\n"
           "    visibility (bool): also return the per-light visibility: (image, visibility), visibility a float32 "
           "(height, width, lights) array of the fraction of each light seen at each pixel's camera hits, as the "
           "shadow method shaded them (the mean over the pixel's samples that hit; NaN where none hit; 0 for a light "
           "behind the surface or out of range)\n";
    return doc;
}

}  // namespace

PYBIND11_MODULE(lightmesh, m) {
    m.doc() = "lightmesh: soft shadows of spherical lights, from Python (docs/python.md).";
    // Notes (what the loader chose) are for the CLI's user; warnings still go to stderr.
    lm::SetLogLevel(lm::LogLevel::Warning);

    static py::exception<lm::Error> error(m, "Error", PyExc_RuntimeError);
    error.doc() = "An error in the input (scene, option, image), with the CLI's message: it names the file and "
                  "the JSON path, or the keyword.";
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const lm::Error& e) {
            error(e.what());
        } catch (const std::bad_alloc&) {
            error(lm::CurrentExceptionLine().c_str());
        }
    });

    const std::string options = OptionsDoc();
    m.def("render", &Render, py::arg("scene"),
          ("render(scene, **options) -> numpy.ndarray, or (image, visibility) with visibility=True\n\n"
           "Renders `scene` (a path to a .json scene file or a mesh file, \"builtin:NAME\", or a dict in the scene "
           "file format, its mesh paths relative to the current folder) and returns the linear image as a float32 "
           "array of shape (height, width, 3): the pixels `lightmesh render SCENE -o x.exr` writes with the same "
           "options. With visibility=True it returns (image, visibility), visibility a float32 (height, width, "
           "lights) array: each light's visibility at each pixel's camera hits, as the shadow method shaded them "
           "(the image is the same). The GIL is released while rendering; Ctrl-C (KeyboardInterrupt) stops the render. Raises "
           "lightmesh.Error with the CLI's message.\n\n" +
           options)
              .c_str());
    m.def("load", [](const py::object& scene, const py::kwargs& kwargs) { return Load(scene, kwargs, "load"); },
          py::arg("scene"),
          ("load(scene, **options) -> Scene\n\n"
           "Loads `scene` (as render() takes it) once, for many renders: its camera and lights can be read and "
           "changed between them, and Scene.render(**options) reuses the loaded meshes and the ray-query back-end "
           "(rebuilt only when the back-end's options change). The options given here are the scene's; those "
           "given to Scene.render() replace them for one render.\n\n" +
           options)
              .c_str());

    py::class_<PyScene, std::shared_ptr<PyScene>>(m, "Scene", "A loaded scene (lightmesh.load).")
        .def("render", &PyScene::Render,
             ("render(**options) -> numpy.ndarray, or (image, visibility) with visibility=True\n\nRenders the "
              "scene as it is now, with the load's options replaced by these for this render; the image (and the "
              "visibility) as lightmesh.render() returns it.\n\n" +
              options)
                 .c_str())
        .def_property_readonly("camera", [](const std::shared_ptr<PyScene>& s) { return PyCamera{s}; })
        .def_property_readonly("lights",
                               [](const std::shared_ptr<PyScene>& s) {
                                   std::vector<PyLight> lights;
                                   for (size_t i = 0; i < s->Get().lights.size(); ++i) lights.push_back({s, i});
                                   return lights;
                               })
        .def_property_readonly("name", [](const std::shared_ptr<PyScene>& s) { return s->Get().name; })
        .def_property_readonly("triangles", [](const std::shared_ptr<PyScene>& s) { return s->Get().mesh.PrimCount(); })
        .def_property_readonly("width", [](const std::shared_ptr<PyScene>& s) { return s->Options().width; })
        .def_property_readonly("height", [](const std::shared_ptr<PyScene>& s) { return s->Options().height; });

    py::class_<PyCamera>(m, "Camera", "The camera of a loaded scene: position, look_at, up, fov (vertical, degrees).")
        .def_property(
            "position", [](const PyCamera& c) { return Tuple(c.Get().position); },
            [](PyCamera& c, const py::object& v) { c.Get().position = ToVec3(v, "position"); c.scene->Changed(); })
        .def_property(
            "look_at", [](const PyCamera& c) { return Tuple(c.Get().lookAt); },
            [](PyCamera& c, const py::object& v) { c.Get().lookAt = ToVec3(v, "look_at"); c.scene->Changed(); })
        .def_property(
            "up", [](const PyCamera& c) { return Tuple(c.Get().up); },
            [](PyCamera& c, const py::object& v) { c.Get().up = ToVec3(v, "up"); c.scene->Changed(); })
        .def_property(
            "fov", [](const PyCamera& c) { return c.Get().fovY; },
            [](PyCamera& c, float v) { c.Get().fovY = v; c.scene->Changed(); });

    py::class_<PyLight>(m, "Light", "A light of a loaded scene: position, intensity (RGB), radius, range.")
        .def_property(
            "position", [](const PyLight& l) { return Tuple(l.Get().position); },
            [](PyLight& l, const py::object& v) { l.Get().position = ToVec3(v, "position"); l.scene->Changed(); })
        .def_property(
            "intensity", [](const PyLight& l) { return Tuple(l.Get().intensity); },
            [](PyLight& l, const py::object& v) { l.Get().intensity = ToColor(v, "intensity"); l.scene->Changed(); })
        .def_property(
            "radius", [](const PyLight& l) { return l.Get().radius; },
            [](PyLight& l, float v) {
                if (!(v >= 0) || !std::isfinite(v)) throw lm::Error("radius: must be a finite number >= 0");
                l.Get().radius = v;
                l.scene->Changed();
            })
        .def_property(
            "range", [](const PyLight& l) { return l.Get().range; },
            [](PyLight& l, float v) {
                if (!(v > 0)) throw lm::Error("range: must be > 0 (inf: no limit)");
                l.Get().range = v;
                l.scene->Changed();
            });

    m.def(
        "read_image",
        [](const py::object& path) { return ToArray(ImageArg(path, "path")); }, py::arg("path"),
        "read_image(path) -> numpy.ndarray\n\nReads a PNG (decoded from sRGB to linear) or an EXR as a float32 "
        "(height, width, 3) linear array.");
    m.def(
        "write_image",
        [](const py::object& pathArg, const py::object& array) {
            const std::string path = py::module_::import("os").attr("fspath")(pathArg).cast<std::string>();
            const lm::Image image = FromArray(array, "array");
            py::gil_scoped_release release;
            lm::WriteImage(path, image);
        },
        py::arg("path"), py::arg("array"),
        "write_image(path, array)\n\nWrites a (height, width, 3) linear array as PNG (8-bit sRGB, clamped) or EXR "
        "(32-bit float) by the extension, atomically, as `lightmesh render -o` does.");
    m.def(
        "compare",
        [](const py::object& a, const py::object& b, const py::object& mask, const py::object& noShadows) {
            const lm::Image ia = ImageArg(a, "a"), ib = ImageArg(b, "b");
            std::optional<lm::Image> im;
            if (!mask.is_none()) im = ImageArg(mask, "mask");
            std::optional<lm::Image> none;
            if (!noShadows.is_none()) none = ImageArg(noShadows, "no_shadows");
            lm::ImageMetrics metrics;
            double totalA = 0, totalB = 0;
            {
                py::gil_scoped_release release;
                metrics = lm::CompareImages(ia, ib, im ? &*im : nullptr);
                if (none) {
                    totalA = lm::ShadowTotal(*none, ia);
                    totalB = lm::ShadowTotal(*none, ib);
                }
            }
            py::dict d;
            d["psnr"] = metrics.psnr;
            d["ssim"] = metrics.ssim;
            d["rmse"] = metrics.rmse;
            d["rmse_linear"] = metrics.rmseLinear;
            d["max_diff"] = metrics.maxDiff;
            d["pixels"] = metrics.pixels;
            d["nonfinite_a"] = metrics.nonFiniteA;
            d["nonfinite_b"] = metrics.nonFiniteB;
            d["identical"] = metrics.Identical();
            if (none) {
                d["shadow_total_a"] = totalA;
                d["shadow_total_b"] = totalB;
                d["shadow_ratio"] = totalA != 0 ? py::object(py::float_(totalB / totalA)) : py::object(py::none());
            }
            return d;
        },
        py::arg("a"), py::arg("b"), py::arg("mask") = py::none(), py::arg("no_shadows") = py::none(),
        "compare(a, b, mask=None, no_shadows=None) -> dict\n\nImage quality of B against A (arrays or paths), as "
        "`lightmesh compare` computes it: psnr (dB, inf for images equal on display), ssim, rmse and max_diff (of "
        "display values), rmse_linear, pixels compared, nonfinite_a, nonfinite_b, identical. With a mask, only "
        "where it is not black. With no_shadows (the render with shadows='none'): shadow_total_a, shadow_total_b "
        "(sum of no-shadow minus image, linear luminance) and shadow_ratio (B's over A's).");

    DefineBench(m);

    py::list names;
    for (const Keyword& k : Keywords()) names.append(k.name);
    m.attr("OPTIONS") = names;
}
