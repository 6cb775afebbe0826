// view_keywords.cpp -- the view keywords (view_keywords.h).
#include "view_keywords.h"

#include <pybind11/stl.h>

#include "lightmesh/util/error.h"

namespace py = pybind11;

namespace lm::python {

const std::vector<std::string> kViewKeywords = {"camera", "smooth_normals", "camera_position", "look_at", "up", "fov"};

const char* const kViewKeywordsDoc =
    "    camera (str or int): which of a mesh file's own cameras to render from, by name or index from 0 "
    "(default: the first; a file without cameras is framed automatically); a load option\n"
    "    smooth_normals (float, 0..180): give the meshes of mesh files without normals smooth ones, keeping "
    "edges sharper than this many degrees as creases (0: flat faces; default: 60 for a bare mesh file, a scene "
    "file's \"smooth_normals\" per mesh); a load option\n"
    "    camera_position (3 numbers): the camera's position\n"
    "    look_at (3 numbers): the point the camera looks at\n"
    "    up (3 numbers, or \"x\", \"y\", \"z\"): the camera's up direction (default 0,1,0); for a mesh file "
    "a letter names the model's up axis instead: the model is turned to stand on the ground (a load option)\n"
    "    fov (float, 0..180 excluded): the vertical field of view in degrees (a mesh file is framed for it "
    "when it is loaded)\n";

ViewKeywords::ViewKeywords() { overrides.names = {"camera_position=", "look_at=", "up=", "fov="}; }

py::object Plain(const py::handle& v) {
    if (py::isinstance<py::str>(v) || py::isinstance<py::bool_>(v) || py::isinstance<py::int_>(v) ||
        py::isinstance<py::float_>(v))
        return py::reinterpret_borrow<py::object>(v);
    if (py::hasattr(v, "item") && py::hasattr(v, "dtype")) return v.attr("item")();
    return py::reinterpret_borrow<py::object>(v);
}

namespace {

std::string Repr(const py::handle& v) { return py::repr(v).cast<std::string>(); }

/// A real number (Python's or NumPy's, not a bool) given for `name`, else Error.
double Number(const py::handle& v, const std::string& name) {
    const py::object x = Plain(v);
    if (py::isinstance<py::bool_>(x) || !(py::isinstance<py::int_>(x) || py::isinstance<py::float_>(x)))
        throw Error(name + "=: expected a number, got " + Repr(v));
    return py::cast<double>(x);
}

/// Three numbers (a sequence or a NumPy array) given for `name`, checked as the CLI checks
/// its X,Y,Z (finite, within ±1e18).
Vec3 Vec3Keyword(const py::handle& v, const std::string& name) {
    const auto fail = [&] { throw Error(name + "=: expected 3 numbers (a sequence or an array), got " + Repr(v)); };
    if (py::isinstance<py::str>(v) || py::isinstance<py::bytes>(v) || !py::isinstance<py::sequence>(v)) fail();
    const py::sequence seq = py::reinterpret_borrow<py::sequence>(v);
    if (seq.size() != 3) fail();
    double d[3];
    for (size_t i = 0; i < 3; ++i) {
        const py::object x = Plain(seq[i]);
        if (py::isinstance<py::bool_>(x) || !(py::isinstance<py::int_>(x) || py::isinstance<py::float_>(x))) fail();
        d[i] = py::cast<double>(x);
    }
    return Vec3Option(name + "=", d, Repr(v));
}

}  // namespace

bool ParseViewKeyword(const std::string& name, const py::handle& v, ViewKeywords* o) {
    if (name == "camera") {
        // An index from 0 (int) or a name (str), as --camera NAME|INDEX.
        const py::object x = Plain(v);
        o->cameraShown = Repr(v);
        if (py::isinstance<py::int_>(x) && !py::isinstance<py::bool_>(x)) {
            const std::string index = py::str(x);  // digits, as --camera takes an index
            if (index[0] == '-') throw Error("camera=: an index counts from 0, got " + o->cameraShown);
            o->camera = index;
        } else if (py::isinstance<py::str>(x) && !py::cast<std::string>(x).empty()) {
            o->camera = py::cast<std::string>(x);
        } else {
            throw Error("camera=: expected a camera's name (str) or its index from 0 (int), got " + o->cameraShown);
        }
        return true;
    }
    if (name == "smooth_normals") {
        const double degrees = Number(v, name);
        if (const std::string problem = SmoothNormalsProblem(degrees, Repr(v)); !problem.empty())
            throw Error("smooth_normals=: " + problem);
        o->smoothNormals = static_cast<float>(degrees);
        return true;
    }
    if (name == "camera_position") {
        o->overrides.position = Vec3Keyword(v, name);
        return true;
    }
    if (name == "look_at") {
        o->overrides.lookAt = Vec3Keyword(v, name);
        return true;
    }
    if (name == "up") {
        // "x", "y" or "z" as --up's letter (for a mesh file: the model's up axis), or 3 numbers.
        if (py::isinstance<py::str>(v)) {
            const std::string letter = py::cast<std::string>(v);
            o->overrides.upAxis = AxisOfLetter(letter);
            if (o->overrides.upAxis < 0) throw Error("up=: expected \"x\", \"y\", \"z\" or 3 numbers, got " + Repr(v));
            o->overrides.up = ParseUpOption(letter);
        } else {
            o->overrides.up = Vec3Keyword(v, name);
            o->overrides.upAxis = -1;
        }
        return true;
    }
    if (name == "fov") {
        o->overrides.fovY = FovOption("fov=", Number(v, name), Repr(v));
        return true;
    }
    return false;
}

Scene LoadWithView(const std::string& spec, const ViewKeywords& k, SceneLoadOptions load,
                   std::vector<std::string>* warnings) {
    load.camera = k.camera.value_or("");
    load.smoothNormals = k.smoothNormals.value_or(-1.0f);
    CameraOverrides view = k.overrides;
    PrepareCameraOverrides(spec, &view, &load);
    Scene scene;
    try {
        py::gil_scoped_release release;
        scene = LoadScene(spec, load, warnings);
    } catch (const Error& e) {
        // The loader names the CLI's flag ("model.gltf: --camera 5: the file has 2
        // cameras ..."); here the keyword is named instead.
        const std::string flag = "--camera " + load.camera + ":";
        const std::string message = e.what();
        const size_t at = message.find(flag);
        if (load.camera.empty() || at == std::string::npos) throw;
        throw Error(message.substr(0, at) + "camera=" + k.cameraShown + ":" + message.substr(at + flag.size()));
    }
    ApplyCameraOverrides(view, &scene);
    return scene;
}

void MoveCameraForOneRender(const std::string& spec, const ViewKeywords& k, Scene* scene) {
    if (!k.overrides.Any()) return;
    // A letter turns a mesh file's model as it is framed: that is the load's.
    if (k.overrides.upAxis >= 0 && IsMeshFileSpec(spec))
        throw Error("up=: for a mesh file a letter names the model's up axis, which turns the model as it is "
                    "loaded: give it to lightmesh.load(), or 3 numbers for the camera's up here");
    SceneLoadOptions unused;  // the scene is loaded: the framing's options no longer apply
    CameraOverrides view = k.overrides;
    PrepareCameraOverrides(spec, &view, &unused);
    ApplyCameraOverrides(view, scene);
}

}  // namespace lm::python
