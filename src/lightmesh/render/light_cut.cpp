// light_cut.cpp -- the lights' hierarchy and the per-point cut (see the header).
#include "lightmesh/render/light_cut.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "lightmesh/util/error.h"
#include "lightmesh/util/hash.h"

namespace lm {

namespace {

/// The luminance the bound is judged in (Rec. 709 weights).
inline float Luminance(const Color& c) { return 0.2126f * c.r + 0.7152f * c.g + 0.0722f * c.b; }

/// Squared distance from p to the box (0 inside it).
inline float DistanceSquared(const Bounds3& b, const Vec3& p) {
    const float dx = std::max({b.lo.x - p.x, 0.0f, p.x - b.hi.x});
    const float dy = std::max({b.lo.y - p.y, 0.0f, p.y - b.hi.y});
    const float dz = std::max({b.lo.z - p.z, 0.0f, p.z - b.hi.z});
    return dx * dx + dy * dy + dz * dz;
}

/// The largest n·(x − p) over the box's points x (a linear function: its largest value is at
/// a corner, axis by axis).
inline float MaxHeight(const Bounds3& b, const Vec3& p, const Vec3& n) {
    return std::max(n.x * (b.lo.x - p.x), n.x * (b.hi.x - p.x)) + std::max(n.y * (b.lo.y - p.y), n.y * (b.hi.y - p.y)) +
           std::max(n.z * (b.lo.z - p.z), n.z * (b.hi.z - p.z));
}

/// A node of the cut under way: its bound, its estimate and the estimate's luminance.
struct Item {
    float bound;
    uint32_t node;
    Color estimate;
    float luminance;
};

struct Scratch {
    std::vector<Item> heap;
    std::vector<std::pair<uint32_t, Color>> out;
};

Scratch& ThreadScratch() {
    thread_local Scratch scratch;
    return scratch;
}

}  // namespace

LightCuts::LightCuts(const std::vector<PointLight>& lights, const LightTerms& terms, float error)
    : terms_(terms), error_(error) {
    if (!(error >= 0) || !std::isfinite(error)) ThrowError("light cut: error bound %g: must be a finite number >= 0", error);
    std::vector<uint32_t> ids;
    intensity_.reserve(lights.size());
    for (const PointLight& l : lights) intensity_.push_back(l.intensity);
    for (uint32_t i = 0; i < lights.size(); ++i) (lights[i].kind == LightKind::Sun ? suns_ : ids).push_back(i);
    if (ids.empty()) return;
    nodes_.reserve(2 * ids.size() - 1);
    Build(ids, 0, ids.size(), lights);
}

uint32_t LightCuts::Build(std::vector<uint32_t>& ids, size_t first, size_t last, const std::vector<PointLight>& lights) {
    const uint32_t index = static_cast<uint32_t>(nodes_.size());
    nodes_.emplace_back();
    Node node;
    node.lights = static_cast<uint32_t>(last - first);
    for (size_t k = first; k < last; ++k) {
        const PointLight& l = lights[ids[k]];
        node.box.Extend(l.position);
        node.intensity += l.intensity;
        node.maxRange2 = std::max(node.maxRange2, std::isfinite(l.range) ? l.range * l.range
                                                                          : std::numeric_limits<float>::infinity());
        (l.falloff == Falloff::InverseSquare ? node.inverseSquare : node.constant) = true;
    }

    if (node.lights == 1) {
        node.rep = ids[first];
        nodes_[index] = node;
        return index;
    }
    // Split at the median along the box's longest axis (ties by index: the same hierarchy
    // on every machine).
    const Vec3 d = node.box.Diagonal();
    const int axis = d.x >= d.y && d.x >= d.z ? 0 : (d.y >= d.z ? 1 : 2);
    auto coord = [&](uint32_t i) { return axis == 0 ? lights[i].position.x : axis == 1 ? lights[i].position.y : lights[i].position.z; };
    std::sort(ids.begin() + static_cast<std::ptrdiff_t>(first), ids.begin() + static_cast<std::ptrdiff_t>(last),
              [&](uint32_t a, uint32_t b) { return coord(a) < coord(b) || (coord(a) == coord(b) && a < b); });
    const size_t mid = first + (last - first) / 2;
    node.child[0] = Build(ids, first, mid, lights);
    node.child[1] = Build(ids, mid, last, lights);
    // The representative: a child's, chosen in proportion to the children's intensity by a
    // hash of the node.
    const Node &a = nodes_[node.child[0]], &b = nodes_[node.child[1]];
    const float la = Luminance(a.intensity), lb = Luminance(b.intensity);
    const float u = static_cast<float>(Mix64(0x6A09E667F3BCC909ull + index) >> 40) * 0x1p-24f;
    node.rep = la + lb > 0 && u * (la + lb) >= la ? b.rep : a.rep;
    nodes_[index] = node;
    return index;
}

size_t LightCuts::Bytes() const {
    return nodes_.capacity() * sizeof(Node) + suns_.capacity() * sizeof(uint32_t) + intensity_.capacity() * sizeof(Color);
}

uint32_t LightCuts::Cut(const LightTermPoint& point, Color* omega, uint32_t* lit) const {
    Scratch& sc = ThreadScratch();
    std::vector<Item>& heap = sc.heap;
    std::vector<std::pair<uint32_t, Color>>& out = sc.out;
    heap.clear(), out.clear();
    float total = 0;
    if (!suns_.empty()) {
        const uint32_t n = terms_.Listed(point, suns_.data(), static_cast<uint32_t>(suns_.size()), omega, lit);
        for (uint32_t k = 0; k < n; ++k) out.emplace_back(lit[k], omega[k]), total += Luminance(omega[k]);
    }
    auto byBound = [](const Item& a, const Item& b) { return a.bound < b.bound || (a.bound == b.bound && a.node > b.node); };
    // A node joins the cut: a light its exact term; a node of several its estimate and
    // bound; nothing where none of its lights can reach the point.
    auto consider = [&](uint32_t index) {
        const Node& node = nodes_[index];
        Color term;
        uint32_t id;
        if (node.lights == 1) {
            if (terms_.Listed(point, &node.rep, 1, &term, &id)) out.emplace_back(id, term), total += Luminance(term);
            return;
        }
        const float d2 = DistanceSquared(node.box, point.p);
        // Out of every light's range (a margin over the rounding of the terms' own test).
        if (d2 > node.maxRange2 * 1.0001f) return;
        // Wholly behind the surface: no light of it faces the point (ns·l > 0 fails).
        const float h = MaxHeight(node.box, point.p, point.ns);
        const float d = std::sqrt(d2);
        if (h < -1e-4f * d) return;
        Item item;
        item.node = index;
        // The representative's term, scaled to the node's intensity channel by channel.
        if (terms_.Listed(point, &node.rep, 1, &term, &id)) {
            const Color& ri = intensity_[node.rep];
            item.estimate = Color(ri.r > 0 ? term.r / ri.r * node.intensity.r : 0.0f,
                                  ri.g > 0 ? term.g / ri.g * node.intensity.g : 0.0f,
                                  ri.b > 0 ? term.b / ri.b * node.intensity.b : 0.0f);
        }
        item.luminance = Luminance(item.estimate);
        // The bound: intensity · (kd·cos + ks) · falloff, the largest over the box (inside
        // the box it is unbounded: the node is split).
        if (d2 > 0) {
            const float cosMax = std::clamp(h / d, 0.0f, 1.0f);
            const float falloff = std::max(node.inverseSquare ? 1.0f / d2 : 0.0f, node.constant ? 1.0f : 0.0f);
            const Color reflect(point.kd.r * cosMax + point.ks.r, point.kd.g * cosMax + point.ks.g,
                                point.kd.b * cosMax + point.ks.b);
            item.bound = Luminance(Color(node.intensity.r * reflect.r, node.intensity.g * reflect.g,
                                         node.intensity.b * reflect.b)) *
                         falloff;
        } else {
            item.bound = std::numeric_limits<float>::infinity();
        }
        total += item.luminance;
        heap.push_back(item);
        std::push_heap(heap.begin(), heap.end(), byBound);
    };
    if (!nodes_.empty()) consider(0);
    // Split the node of the largest bound while it is above error × total (with error 0,
    // every node of several lights: the exact list).
    while (!heap.empty()) {
        const Item& top = heap.front();
        if (error_ > 0 && top.bound <= error_ * total) break;
        const uint32_t index = top.node;
        total -= top.luminance;
        std::pop_heap(heap.begin(), heap.end(), byBound);
        heap.pop_back();
        consider(nodes_[index].child[0]);
        consider(nodes_[index].child[1]);
    }
    for (const Item& item : heap)
        if (!item.estimate.IsBlack()) out.emplace_back(nodes_[item.node].rep, item.estimate);
    std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    for (size_t k = 0; k < out.size(); ++k) lit[k] = out[k].first, omega[k] = out[k].second;
    return static_cast<uint32_t>(out.size());
}

float ResolvedLightCutError(float requested, const std::string& shadows, const std::vector<PointLight>& lights) {
    if (shadows != "soft") return 0.0f;
    if (requested >= 0) return requested;
    size_t count = 0;
    for (const PointLight& l : lights) count += l.kind != LightKind::Sun && !std::isfinite(l.range);
    return count >= kLightCutMinLights ? kDefaultLightCutError : 0.0f;
}

}  // namespace lm
