// tonemap.h -- exposure and the tone curves of PNG output. The exposure is a scale of the
// linear radiance the user asks for (--exposure EV multiplies it by 2^EV, for EXR and PNG
// alike); a tone curve maps linear radiance to display values in [0, 1] and is applied to
// PNG only, before its sRGB encoding: an EXR keeps the linear values.
#pragma once

#include <string>
#include <vector>

#include "lightmesh/io/image.h"

namespace lm {

/// The tone curves --tonemap names: "clamp" (values above 1 are 1: the PNG's own clamp,
/// the default), "reinhard" (x / (1 + x)) and "aces" (Narkowicz's fit of the ACES filmic
/// curve).
const std::vector<std::string>& ToneCurveNames();

/// Multiplies every channel by 2^ev; ev = 0 leaves the image as it is (no multiplication,
/// so the default's bytes cannot change).
void ApplyExposure(Image* image, float ev);

/// A linear value mapped by curve `name` (one of ToneCurveNames): within [0, 1] for every
/// input, monotonic (non-decreasing), 0 for NaN and negative values. "clamp" is the
/// identity below 1.
///
/// "aces": K. Narkowicz, "ACES Filmic Tone Mapping Curve" (2016),
/// f(x) = x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14), clamped to [0, 1]; its
/// derivative's numerator (ad - bc) x^2 + 2ae x + be has positive coefficients, so it rises
/// for every x >= 0, and it reaches 1 near x = 7.2.
float ToneMap(float linear, const std::string& name);

/// The image a PNG shows: each channel through ToneMap(`name`); "clamp" leaves the image
/// as it is (the PNG encoder clamps), so the default's bytes cannot change.
void ApplyToneCurve(Image* image, const std::string& name);

}  // namespace lm
