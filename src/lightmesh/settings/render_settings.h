// render_settings.h -- the render knobs in one table: each row is one knob with its
// scene-file key (in the "render" object), its `lightmesh render` flag, its kind, its range
// or choices, and its help text. The scene-file reader and the CLI both take their checks
// from it, so a knob cannot accept one range in a file and another on the command line
// (kI, ns and the grid resolution had drifted apart); a test checks that the README lists
// every row and that the choices are the ones the factories accept.
#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "lightmesh/util/error.h"

namespace lm {

/// The default ray-query back-end: the fastest compiled in.
#ifdef LIGHTMESH_HAS_EMBREE
inline constexpr const char* kDefaultAccelerator = "embree";
#else
inline constexpr const char* kDefaultAccelerator = "grid";
#endif

struct RenderSetting {
    enum class Kind { Int, Float, String, Choice, Bool };  ///< Bool: a JSON true/false, a flag that turns it off
    const char* key;   ///< in the scene file's "render" object
    const char* flag;  ///< of `lightmesh render`
    Kind kind;
    double lo = 0, hi = 0;             ///< Int, Float: the accepted range, both ends included
    std::vector<std::string> choices;  ///< Choice: the accepted values
    std::string help;                  ///< the CLI's help text
    /// The knob matters only when setting `usedWith` (a Choice row's key) takes one of
    /// `usedBy`; null for knobs every render uses. A flag given for a render that does not
    /// use it is reported (UnusedSettingWarning), as pbrt reports unused parameters.
    const char* usedWith = nullptr;
    std::vector<std::string> usedBy;
};

/// Every row, in the order of `lightmesh render --help`.
const std::vector<RenderSetting>& RenderSettings();

/// The row of scene-file key `key`. An unknown key is a programming error (std::logic_error).
const RenderSetting& RenderSettingFor(std::string_view key);

/// An error in the value of one knob, thrown by the factory that reads it (the shadow
/// method, the back-end). Its message is the reason alone; NamingOrigins (options.h) puts
/// in front of it where the value came from when it did not come from the defaults.
class SettingError : public Error {
  public:
    SettingError(std::string key, const std::string& reason) : Error(reason), key_(std::move(key)) {}
    /// The knob's scene-file key ("variant").
    const std::string& Key() const { return key_; }

  private:
    std::string key_;
};

/// Throws a SettingError for knob `key` with a printf-style reason.
[[noreturn]] void ThrowSettingError(const char* key, const char* fmt, ...) __attribute__((format(printf, 2, 3)));

/// The warning for knob `key` given as its flag when setting `s.usedWith` is `value`, or ""
/// when that render uses it: "--cc is not used by --shadows rt (only by lmm and soft); ignored".
std::string UnusedSettingWarning(std::string_view key, std::string_view value);

}  // namespace lm
