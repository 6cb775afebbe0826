// disc_pattern.h -- stratified directions towards a spherical light: the golden-ratio
// lattice on the unit disc, and the cone from a point to a sphere it is mapped onto. Every
// method that samples a light's sphere (area, soft, exact) takes its directions from here.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "lightmesh/math/ray.h"

namespace lm {

/// Shirley and Chiu's concentric map of [0, 1)² to the unit disc (pbrt-v4's
/// SampleUniformDiskConcentric): area-preserving, and it keeps strata compact.
void ConcentricDisc(float u0, float u1, float* dx, float* dy);

/// Point k of n of the golden-ratio (Fibonacci-type) lattice ((k + ½)/n, frac(k·(φ − 1)))
/// in [0, 1)², shifted modulo 1 by (shift0, shift1) (a Cranley–Patterson rotation; 0 for
/// the lattice itself), each coordinate below 1.
void GoldenLattice(int k, int n, double shift0, double shift1, float* u0, float* u1);

/// n points of the golden-ratio lattice mapped to the unit disc (ConcentricDisc), stored
/// in `passes` passes: pass p holds the points k ≡ p (mod passes), so each pass alone is a
/// lattice of n/passes points spread over the whole disc (a first pass can decide alone
/// where it sees a light wholly or not at all). n must be a multiple of passes.
struct DiscPattern {
    std::vector<float> x, y, r2;  ///< the points in pass order, and their squared radius
    int passes = 1;
    int Size() const { return static_cast<int>(x.size()); }
    static DiscPattern Golden(int n, int passes = 1);
};

/// The unit direction of disc point (dx, dy) (r2 = dx² + dy²) in the cone of axis `axis`
/// (frame e1, e2) whose half-angle has 1 − cos θmax = oneMinusCosMax: uniform in solid
/// angle, 1 − cos θ = r²·(1 − cos θmax), sin θ = r·sqrt(k(2 − r²k)).
inline Vec3 ConeDirection(const Vec3& e1, const Vec3& e2, const Vec3& axis, float oneMinusCosMax, float dx, float dy,
                          float r2) {
    const float r2k = r2 * oneMinusCosMax;
    const float cosTheta = 1.0f - r2k;
    const float s = std::sqrt(std::max(0.0f, oneMinusCosMax * (2.0f - r2k)));
    return e1 * (dx * s) + e2 * (dy * s) + axis * cosTheta;
}

/// The turns a point gives a DiscPattern: kDiscTurns angles 2π·(t + ½)/kDiscTurns, their
/// cosines and sines tabulated once.
inline constexpr int kDiscTurns = 1024;
struct DiscTurns {
    float cs[kDiscTurns], sn[kDiscTurns];
    DiscTurns();
    static const DiscTurns& Get();
};

/// The cone of directions from `origin` to a sphere (centre, radius): its axis frame and
/// 1 − cos θmax (sin θmax = radius / distance). Maps disc points to directions uniform in
/// solid angle: 1 − cos θ = r²·(1 − cos θmax), the disc's angle kept, which preserves
/// measure (dΩ = d(cos θ) dφ).
class SphereCone {
  public:
    SphereCone(const Vec3& origin, const Vec3& center, float radius);
    /// The origin lies in the sphere (or on it): it sees all of the light.
    bool Inside() const { return inside_; }
    /// The frame turned by kDiscTurns turn `turn` (e1, e2 rotated about the axis).
    void Turn(int turn);
    /// The unit direction through disc point (dx, dy) (|(dx, dy)| <= 1, r2 its squared
    /// radius).
    Vec3 Direction(float dx, float dy, float r2) const {
        return ConeDirection(f1_, f2_, axis_, oneMinusCosMax_, dx, dy, r2);
    }
    /// The ray from the origin along unit direction w (in the cone) to the near side of the
    /// sphere, ending just short of it (t in (0, 1 − 1e-5) like LightSegment's).
    Ray RayAlong(const Vec3& w) const;
    /// RayAlong(Direction(dx, dy, r2)).
    Ray RayTo(float dx, float dy, float r2) const { return RayAlong(Direction(dx, dy, r2)); }
    /// The unit axis and the distance to the centre.
    const Vec3& Axis() const { return axis_; }
    float Distance() const { return d_; }
    /// tan θmax: the cone's radius per unit of length along the axis.
    float TanHalfAngle() const { return tan_; }

  private:
    Vec3 origin_, oc_, axis_, e1_, e2_, f1_, f2_;
    float r2_ = 0, d_ = 0, oneMinusCosMax_ = 0, tan_ = 0;
    bool inside_ = false;
};

}  // namespace lm
