// light_cut.h -- many lights for the price of a few: a binary hierarchy over the scene's
// lights and, at each shading point, a cut through it under a relative error bound
// (Lightcuts, Walter et al. 2005).
//
// A node of the hierarchy stands for its lights: the box of their positions, their summed
// intensity, the farthest range among them and a representative, one of its lights. At a
// point, a node is shaded as its representative's term scaled by the node's intensity
// over the representative's (channel by channel), and its visibility is the
// representative's: the node enters the point's light list under the representative's
// index, so every shadow method treats it as that light. A node's error is at most a bound
// computed from its box alone (its intensity times the largest reflectance and falloff
// any point of the box could give); the cut starts at the root and splits the node of the
// largest bound until every bound is at most `error` times the cut's total (Weber's law:
// 1-2 % is invisible). A node of one light is that light's exact term. With error 0 every
// node is split: the cut is the exact list of the lit lights, the terms bit for bit those
// of LightTerms, in ascending order.
//
// Lights that cannot contribute are left out exactly, never estimated: a box wholly out
// of the range of all its lights, or wholly behind the point's surface. Suns stay out of
// the hierarchy and are always shaded one by one.
//
// Representatives are chosen when the hierarchy is built, each parent's from one of its
// two children's with probability proportional to the children's intensity, drawn from a
// hash of the node: the image depends on nothing but the scene and the bound.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "lightmesh/math/bounds.h"
#include "lightmesh/render/light_terms.h"
#include "lightmesh/scene/scene.h"

namespace lm {

/// The default relative error bound of the cut (Lightcuts uses 2 %; at 1 % the soft
/// default stays within 50 dB of the all-lights reference on the playground's 1,024 lamps).
inline constexpr float kDefaultLightCutError = 0.01f;
/// The automatic cut is made where at least this many lights (suns not counted) reach
/// everywhere (no "range"): lights with a range are already shaded only near them, and
/// below this count the cut saves little of the soft default's time (at 256 lamps over the
/// playground it was within the noise) and costs quality (docs/many-lights.md).
inline constexpr size_t kLightCutMinLights = 512;

class LightCuts {
  public:
    /// The hierarchy over `lights`, whose terms `terms` computes (it must outlive this).
    /// error: the relative bound, finite and >= 0.
    LightCuts(const std::vector<PointLight>& lights, const LightTerms& terms, float error);

    /// The cut at `point`: the lit entries in ascending index (a node's representative's
    /// index for a node of several lights), their terms in omega. omega and lit have room
    /// for every light. Returns the count.
    uint32_t Cut(const LightTermPoint& point, Color* omega, uint32_t* lit) const;

    float Error() const { return error_; }
    size_t NodeCount() const { return nodes_.size(); }

    size_t Bytes() const;

  private:
    struct Node {
        Bounds3 box;             ///< the lights' positions
        Color intensity;         ///< their summed intensity
        float maxRange2 = 0;     ///< the largest range², infinite if any light has none
        uint32_t rep = 0;        ///< the representative light
        uint32_t child[2] = {0, 0};  ///< children, for a node of more than one light
        uint32_t lights = 0;     ///< how many lights
        bool inverseSquare = false;  ///< some light falls off as 1/dist²
        bool constant = false;       ///< some light does not fall off
    };
    uint32_t Build(std::vector<uint32_t>& ids, size_t first, size_t last, const std::vector<PointLight>& lights);

    const LightTerms& terms_;
    float error_ = kDefaultLightCutError;
    std::vector<Node> nodes_;      ///< the root is nodes_[0] when there is one
    std::vector<uint32_t> suns_;   ///< shaded one by one
    std::vector<Color> intensity_;  ///< each light's, for its nodes' estimates
};

/// The error bound a render uses: 0 (every light) for every method but the soft default;
/// for it `requested` when >= 0, otherwise (automatic) the default bound where
/// kLightCutMinLights lights or more have no range, and 0 elsewhere.
float ResolvedLightCutError(float requested, const std::string& shadows, const std::vector<PointLight>& lights);

}  // namespace lm
