// light_terms.h -- the unshadowed terms Ω(i, P) of formula (1) at a shading point, several
// lights at a time: the lights' positions, intensities, squared ranges and falloffs as
// arrays (structure of arrays, made once per render), the term computed for 4 lanes (SSE,
// the x86-64 baseline) or 8 (AVX2, chosen at run time), and the lit lights compacted into
// the point's list in ascending order. Every lane does the scalar formula's operations in
// its order (sqrt and division are exactly rounded in SIMD too; the build contracts no
// multiply-add), and the specular power is the scalar std::pow per lane that needs it, so
// the terms are the scalar formula's bit for bit (light_terms_test.cpp checks it).
#pragma once

#include <cstdint>
#include <vector>

#include "lightmesh/math/vec.h"
#include "lightmesh/scene/scene.h"

namespace lm {

/// What the lights' terms at a shading point depend on besides the lights.
struct LightTermPoint {
    Vec3 p;      ///< the point
    Vec3 n;      ///< the normal a light must face (unit, on the viewer's side): the renderer
                 ///< passes the shading normal, so a smooth surface is lit as its normals say
    Vec3 ns;     ///< the shading normal (unit), on the same side
    Vec3 toEye;  ///< unit direction from the point towards the viewer
    Color kd;    ///< the diffuse reflectance here
    Color ks;    ///< the Phong specular reflectance (black: none)
    float phong = 1.0f;  ///< the Phong exponent
};

/// For light i with toLight = position − p, dist² = |toLight|², l = toLight / √dist²:
/// nothing if dist² > range² or unless n·l > 0 and ns·l > 0; else
/// Ω = intensity · (kd·(ns·l) + ks·max(0, reflect(−l, ns)·toEye)^phong) · falloff, with
/// falloff 1/dist² (inverse square) or 1, and the light is lit where Ω is not black. A spot's
/// Ω is then multiplied by its cone's factor (SpotCone::Factor), and it is not lit where
/// that is 0.
class LightTerms {
  public:
    LightTerms() = default;
    /// The lights' arrays; `width` the lanes (4, or 8 where the CPU has AVX2), 0 for the
    /// widest the CPU runs. Throws Error for another width.
    explicit LightTerms(const std::vector<PointLight>& lights, int width = 0);

    /// The lit lights among all of them, ascending: lit[k] and its term omega[k] for
    /// k < the count returned. omega and lit have room for every light.
    uint32_t All(const LightTermPoint& point, Color* omega, uint32_t* lit) const;
    /// The lit lights among ids[0 .. count) (ascending, each < the light count), in that
    /// order. ids may be lit itself (each group of ids is read before its entries are
    /// written); omega and lit have room for count entries.
    uint32_t Listed(const LightTermPoint& point, const uint32_t* ids, uint32_t count, Color* omega,
                    uint32_t* lit) const;

    int Width() const { return width_; }
    size_t Count() const { return count_; }

    /// The arrays, padded to a multiple of 8 lights (padding is never read as a light).
    struct Arrays {
        std::vector<float> x, y, z, range2, r, g, b;
        std::vector<int32_t> inverseSquare;  ///< −1 (all bits) for 1/dist² falloff, else 0
        /// The same light by light: x, y, z, range², r, g, b and the falloff's bits, 8
        /// floats each (the lists' lights, read apart).
        std::vector<float> records;
    };

  private:
    /// Spots' cones applied to the lit lights' terms (a light whose factor is 0 is dropped).
    uint32_t ApplyCones(const LightTermPoint& point, Color* omega, uint32_t* lit, uint32_t count) const;

    int width_ = 4;
    size_t count_ = 0;
    Arrays a_;
    /// Per light: its cone (spots), and whether any light is a spot: without one the terms
    /// are today's, with no pass over them.
    std::vector<SpotCone> cones_;
    std::vector<uint8_t> isSpot_;
    bool anySpot_ = false;
};

}  // namespace lm
