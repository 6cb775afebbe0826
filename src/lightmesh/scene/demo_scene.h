// demo_scene.h -- scenes built in code, needing no files ("builtin:NAME").
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "lightmesh/scene/scene.h"

namespace lm {

/// Names accepted after "builtin:", e.g. "gazebo".
std::vector<std::string> BuiltinSceneNames();

/// Builds the named scene (without the "builtin:" prefix). Throws Error for an unknown name.
Scene MakeBuiltinScene(std::string_view name);

}  // namespace lm
