// tonemap.cpp -- exposure and the tone curves of PNG output (tonemap.h).
#include "lightmesh/io/tonemap.h"

#include <algorithm>
#include <cmath>

#include "lightmesh/util/error.h"

namespace lm {

const std::vector<std::string>& ToneCurveNames() {
    static const std::vector<std::string> names = {"clamp", "reinhard", "aces"};
    return names;
}

void ApplyExposure(Image* image, float ev) {
    if (ev == 0) return;
    const float scale = std::exp2(ev);
    for (Color& c : image->pixels) c = c * scale;
}

float ToneMap(float x, const std::string& name) {
    if (!(x > 0)) return 0;  // NaN and negative values: black, as the PNG encoder does
    if (name == "clamp") return std::min(x, 1.0f);
    if (name == "reinhard") return std::isinf(x) ? 1.0f : x / (1.0f + x);
    if (name == "aces") {
        if (!(x < 8)) return 1;  // past about 7.24 the fit exceeds 1 (and inf / inf is NaN)
        constexpr float a = 2.51f, b = 0.03f, c = 2.43f, d = 0.59f, e = 0.14f;
        return std::clamp((x * (a * x + b)) / (x * (c * x + d) + e), 0.0f, 1.0f);
    }
    ThrowError("unknown tone curve \"%s\"", name.c_str());
}

void ApplyToneCurve(Image* image, const std::string& name) {
    const auto& names = ToneCurveNames();
    if (std::find(names.begin(), names.end(), name) == names.end())
        ThrowError("unknown tone curve \"%s\"", name.c_str());  // before any pixel changes
    if (name == "clamp") return;
    for (Color& c : image->pixels) c = Color(ToneMap(c.r, name), ToneMap(c.g, name), ToneMap(c.b, name));
}

}  // namespace lm
