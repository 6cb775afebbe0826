// occluder_bvh.h -- a bounding volume hierarchy over the scene's triangles for the one query
// the ray back-ends do not answer: which triangles may lie between a region of space and a
// spherical light, i.e. meet the convex hull of two balls. The soft-shadow mode (soft_shadows.h)
// asks it once per light-mesh cell and light, and then shades every point of the cell against
// the short list it returns instead of tracing rays through the whole scene.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "lightmesh/geometry/mesh.h"
#include "lightmesh/math/bounds.h"

namespace lm {

/// The convex hull of the balls (a, ra) and (b, rb): the union of the balls centred at
/// a + t·(b − a) with radius ra + t·(rb − ra), t in [0, 1]. Every segment from a point of
/// the first ball to a point of the second lies inside it.
struct BallHull {
    Vec3 a;
    float ra = 0;
    Vec3 b;
    float rb = 0;
};

/// A BallHull as OccluderBvh tests it: kPieces capsules along the axis, each with the
/// largest radius of its stretch; a box meets it if the axis of some piece meets the box
/// grown by the piece's radius. Conservative: a box that meets the hull always passes.
class HullPieces {
  public:
    static constexpr int kPieces = 4;
    explicit HullPieces(const BallHull& hull);
    bool MeetsBox(const float lo[3], const float hi[3]) const;
    bool MeetsBox(const Bounds3& b) const {
        const float lo[3] = {b.lo.x, b.lo.y, b.lo.z}, hi[3] = {b.hi.x, b.hi.y, b.hi.z};
        return MeetsBox(lo, hi);
    }

  private:
    // The pieces side by side, one per SSE lane: MeetsBox tests all four at once, with the
    // same operations per piece as one at a time (so the same answer, bit for bit).
    alignas(16) float o_[3][kPieces];
    alignas(16) float inv_[3][kPieces];
    alignas(16) float r_[kPieces];
};

/// A binary BVH (median splits on the longest axis of the centroids, up to 4 triangles a
/// leaf) over a TriangleMesh, which must outlive it. With instances (mesh.h), two levels:
/// the top one over the flat triangles and the instances' world boxes, and one hierarchy
/// per prototype in its own space, shared by its instances, whose node boxes are mapped to
/// world space (the box of the transformed box, a little grown) as a query descends; at its
/// leaves each triangle's world box (the min and max of its world-space corners) is tested
/// as a flat triangle's is. So a query lists the same triangles as over the mesh flattened.
class OccluderBvh {
  public:
    explicit OccluderBvh(const TriangleMesh& mesh);
    ~OccluderBvh();

    /// Appends to *out the ids of the triangles whose bounding boxes may meet `hull`. It is
    /// conservative: every triangle that meets the hull is listed, and some near it may be.
    /// The hull is tested as HullPieces against the nodes' and the triangles' boxes. The
    /// order is the tree's (deterministic for a given mesh).
    /// Stops, returning false, once more than `limit` ids have been appended.
    bool Query(const BallHull& hull, std::vector<uint32_t>* out, size_t limit = SIZE_MAX) const;

    size_t NodeCount() const;
    size_t Bytes() const;
    /// The prototypes' hierarchies (0 without instances).
    size_t PrototypeCount() const { return protos_.size(); }
    double BuildSeconds() const { return buildSeconds_; }

    static constexpr int kLeafSize = 4;

  private:
    struct Node {
        float lo[3];
        uint32_t index;  ///< leaf: first of prims_; inner: the right child (the left is next)
        float hi[3];
        uint32_t count;  ///< leaf: triangles (> 0); inner: 0
    };
    struct BuildItem {
        Bounds3 bounds;
        Vec3 centroid;
        uint32_t prim;
    };
    uint32_t Build(BuildItem* items, size_t count, size_t first, int depth);
    /// The hierarchy over `items` (triangles, or instances marked by kInstanceBit).
    void BuildOver(std::vector<BuildItem> items);
    /// Query's walk of prototype hierarchy `p` placed by instance `i`.
    void QueryInstance(const HullPieces& pieces, uint32_t i, std::vector<uint32_t>* out) const;
    static constexpr uint32_t kInstanceBit = 0x80000000u;

    /// A triangle's bounding box (the min and max of its vertices), in prims_' order: the
    /// leaves' tests read them in sequence.
    struct PrimBox {
        float lo[3], hi[3];
    };

    const TriangleMesh& mesh_;
    std::vector<Node> nodes_;
    std::vector<uint32_t> prims_;
    std::vector<PrimBox> boxes_;
    std::vector<std::unique_ptr<OccluderBvh>> protos_;
    double buildSeconds_ = 0;
};

}  // namespace lm
