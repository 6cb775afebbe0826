// embree_accel.cpp -- the Embree 3 back-end (the only file that calls rtc*).
#include "lightmesh/accel/embree_accel.h"

#include <embree3/rtcore.h>
#include <tbb/task_arena.h>

#include <array>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <string>

#include "lightmesh/geometry/cutouts.h"
#include "lightmesh/geometry/instances.h"
#include "lightmesh/geometry/triangle.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/log.h"
#include "lightmesh/util/system.h"

namespace lm {
namespace {

const char* ErrorName(RTCError code) {
    switch (code) {
        case RTC_ERROR_NONE:
            return "no error";
        case RTC_ERROR_UNKNOWN:
            return "unknown error";
        case RTC_ERROR_INVALID_ARGUMENT:
            return "invalid argument";
        case RTC_ERROR_INVALID_OPERATION:
            return "invalid operation";
        case RTC_ERROR_OUT_OF_MEMORY:
            return "out of memory";
        case RTC_ERROR_UNSUPPORTED_CPU:
            return "unsupported CPU";
        case RTC_ERROR_CANCELLED:
            return "cancelled";
    }
    return "error";
}

// Embree's hit parameter range is [tnear, tfar] with tnear >= 0; ours is (tMin, tMax) and
// tMin may be negative. Such a ray is moved to start at tMin; `shift` is added back to t.
struct EmbreeRayRange {
    Vec3 o;
    float tnear, tfar, shift;
};
// Embree counts hits at tnear and tfar, we do not: the range is narrowed by one ulp at each
// end (a ray starting exactly on a surface must not hit it at t = 0).
EmbreeRayRange ToEmbree(const Ray& r) {
    EmbreeRayRange e{r.o, r.tMin, r.tMax, 0.0f};
    if (r.tMin < 0) e = {r.At(r.tMin), 0.0f, r.tMax - r.tMin, r.tMin};
    e.tnear = NextFloatUp(e.tnear);
    if (e.tfar < Infinity) e.tfar = NextFloatDown(e.tfar);
    return e;
}

void SetRay(RTCRay* ray, const Vec3& o, const Vec3& d, float tnear, float tfar) {
    ray->org_x = o.x;
    ray->org_y = o.y;
    ray->org_z = o.z;
    ray->dir_x = d.x;
    ray->dir_y = d.y;
    ray->dir_z = d.z;
    ray->tnear = tnear;
    ray->tfar = tfar;
    ray->time = 0.0f;
    ray->mask = 0xFFFFFFFFu;
    ray->id = 0;
    ray->flags = 0;
}

// The context CountCrossings passes to Embree; Embree hands it back to the callbacks
// (Embree's documented way to carry per-query data: a struct that begins with the
// RTCIntersectContext).
struct CountContext {
    RTCIntersectContext context;
    const Ray* ray;  // the query, as the caller gave it
    const TriangleMesh* mesh;
    std::vector<uint32_t>* hits;  // triangles IntersectTriangle accepted
};

}  // namespace

struct EmbreeAccel::Impl {
    const TriangleMesh& mesh;
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    std::vector<float> vertices;  // x, y, z, pad: Embree reads 16 bytes per vertex
    float extent = 1.0f;
    double buildMs = 0;
    // Embree's own allocations (its memory monitor): now, and once the scene was built.
    std::atomic<int64_t> embreeBytes{0};
    int64_t bvhBytes = 0;
    static bool OnMemory(void* user, ssize_t bytes, bool /*post*/) {
        static_cast<Impl*>(user)->embreeBytes.fetch_add(bytes, std::memory_order_relaxed);
        return true;
    }
    bool packets = false;    // native rtcOccluded4/8 kernels (OccludedMany)
    bool packets16 = false;  // and rtcOccluded16 (AVX-512)
    std::mutex errorMutex;
    std::string error;  // first error Embree reported

    // CountCrossings' scene (built on first use): the triangles as user primitives whose
    // boxes are padded, so Embree's conservative box traversal offers every triangle the ray
    // could touch, and IntersectTriangle decides. (Gathering candidates through a filter on
    // the triangle geometry is not enough: where Embree's own test rounds a vertex or edge
    // hit of an open mesh to a miss, the filter never sees the triangle.)
    std::once_flag countOnce;
    RTCScene countScene = nullptr;
    float pad = 0;  // box padding of the count scene

    // Alpha cut-outs (TriangleMesh::cutouts): the cut-out triangles in a geometry of their
    // own (id 1) whose intersection and occlusion filters reject the holes, so that the
    // opaque ones (id 0) pay nothing. Without cut-outs, one geometry of the mesh's own
    // buffers, as before. ids[g][primID] is the mesh's triangle.
    const CutoutMask* cut = nullptr;
    std::vector<std::array<uint32_t, 3>> split[2];
    std::vector<uint32_t> ids[2];
    uint32_t Prim(unsigned geomID, unsigned primID) const { return cut ? ids[geomID][primID] : primID; }

    // Instances (TriangleMesh::instances): one scene per prototype, and an instance
    // geometry per instance in the top scene, with geometry ids instBase, instBase + 1, …
    // A hit in instance i is the global triangle flat + first(i) + primID; under a
    // mirroring transform the world triangle's corners 1 and 2 are the prototype's 2 and 1,
    // so Embree's (u, v) swap.
    // A prototype with cut-outs is split as the flat mesh is (its cut-out triangles in a
    // geometry of their own, id 1, whose filters ask its own mask with Embree's (u, v) in
    // its space).
    struct Proto {
        const TriangleMesh* mesh = nullptr;
        const CutoutMask* cut = nullptr;
        std::vector<std::array<uint32_t, 3>> split[2];
        std::vector<uint32_t> ids[2];
        uint32_t Prim(unsigned geomID, unsigned primID) const { return cut ? ids[geomID][primID] : primID; }
    };
    static void ProtoCutoutFilter(const RTCFilterFunctionNArguments* args) {
        const Proto& p = *static_cast<const Proto*>(args->geometryUserPtr);
        for (unsigned i = 0; i < args->N; ++i) {
            if (args->valid[i] == 0) continue;
            const uint32_t prim = p.ids[1][RTCHitN_primID(args->hit, args->N, i)];
            if (!p.cut->Solid(*p.mesh, prim, RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i)))
                args->valid[i] = 0;
        }
    }
    std::vector<Proto> protos;
    std::vector<RTCScene> protoScenes;
    std::vector<std::vector<float>> protoVertices;
    unsigned instBase = 0;
    std::vector<uint32_t> instFirst;  // flat + first, per instance
    std::vector<uint32_t> instProto;
    std::vector<uint8_t> instMirrors;
    size_t protoBytes = 0;  // the prototypes' vertex copies (and split indices)
    Hit MakeHit(float t, unsigned geomID, unsigned primID, unsigned instID, float u, float v) const {
        if (instID == RTC_INVALID_GEOMETRY_ID) return Hit{t, Prim(geomID, primID), u, v};
        const unsigned i = instID - instBase;
        const uint32_t prim = instFirst[i] + protos[instProto[i]].Prim(geomID, primID);
        return instMirrors[i] ? Hit{t, prim, v, u} : Hit{t, prim, u, v};
    }
    static void CutoutFilter(const RTCFilterFunctionNArguments* args) {
        const Impl& m = *static_cast<const Impl*>(args->geometryUserPtr);
        for (unsigned i = 0; i < args->N; ++i) {
            if (args->valid[i] == 0) continue;
            const uint32_t prim = m.ids[1][RTCHitN_primID(args->hit, args->N, i)];
            if (!m.cut->Solid(m.mesh, prim, RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i)))
                args->valid[i] = 0;
        }
    }

    explicit Impl(const TriangleMesh& m) : mesh(m) {}
    ~Impl() {
        if (countScene) rtcReleaseScene(countScene);
        if (scene) rtcReleaseScene(scene);
        for (RTCScene p : protoScenes) rtcReleaseScene(p);
        if (device) rtcReleaseDevice(device);
    }

    static void OnError(void* user, RTCError code, const char* str) {
        auto* self = static_cast<Impl*>(user);
        std::string message =
            StringPrintf("Embree: %s%s%s", ErrorName(code), str ? ": " : "", str ? str : "");
        LogWarning(message);
        std::lock_guard<std::mutex> lock(self->errorMutex);
        if (self->error.empty()) self->error = message;
    }
    void CheckError(const char* step) {
        std::lock_guard<std::mutex> lock(errorMutex);
        if (!error.empty())
            ThrowError("cannot build the Embree back-end (%s): %s", step, error.c_str());
    }

    static void PrimBounds(const RTCBoundsFunctionArguments* args) {
        const Impl& m = *static_cast<const Impl*>(args->geometryUserPtr);
        Vec3 p[3];
        m.mesh.Corners(args->primID, p);
        Bounds3 b(p[0], p[1]);
        b.Extend(p[2]);
        RTCBounds* o = args->bounds_o;
        o->lower_x = b.lo.x - m.pad;
        o->lower_y = b.lo.y - m.pad;
        o->lower_z = b.lo.z - m.pad;
        o->upper_x = b.hi.x + m.pad;
        o->upper_y = b.hi.y + m.pad;
        o->upper_z = b.hi.z + m.pad;
    }
    // Called for each primitive whose box the ray meets; it never reports occlusion, so
    // traversal visits every box along the ray.
    static void PrimOccluded(const RTCOccludedFunctionNArguments* args) {
        const auto* c = reinterpret_cast<const CountContext*>(args->context);
        for (unsigned i = 0; i < args->N; ++i) {
            if (args->valid[i] == 0) continue;
            const uint32_t prim = args->primID;
            TriangleHit th;
            Vec3 p[3];
            c->mesh->Corners(prim, p);
            if (IntersectTriangle(*c->ray, p[0], p[1], p[2], &th) &&
                (!c->mesh->cutouts || c->mesh->cutouts->Solid(*c->mesh, prim, th.b1, th.b2)))
                c->hits->push_back(prim);
        }
    }
    static void PrimIntersect(const RTCIntersectFunctionNArguments*) {}  // never used

    void BuildCountScene() {
        pad = 1e-5f * extent;
        countScene = rtcNewScene(device);
        rtcSetSceneFlags(countScene, RTC_SCENE_FLAG_ROBUST);
        if (mesh.PrimCount() > 0) {
            RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_USER);
            rtcSetGeometryUserPrimitiveCount(geom, unsigned(mesh.PrimCount()));
            rtcSetGeometryUserData(geom, this);
            rtcSetGeometryBoundsFunction(geom, &PrimBounds, this);
            rtcSetGeometryIntersectFunction(geom, &PrimIntersect);
            rtcSetGeometryOccludedFunction(geom, &PrimOccluded);
            rtcCommitGeometry(geom);
            rtcAttachGeometry(countScene, geom);
            rtcReleaseGeometry(geom);
        }
        rtcCommitScene(countScene);
        CheckError("building the crossing-count scene");
    }
};

EmbreeAccel::EmbreeAccel(const TriangleMesh& mesh) : impl_(std::make_unique<Impl>(mesh)) {
    const auto start = std::chrono::steady_clock::now();
    Impl& m = *impl_;
    // Device: Embree's errors go to our log, and the first one fails the build.
    m.device = rtcNewDevice(nullptr);
    if (!m.device)
        ThrowError("cannot create the Embree device: %s", ErrorName(rtcGetDeviceError(nullptr)));
    rtcSetDeviceErrorFunction(m.device, &Impl::OnError, &m);
    rtcSetDeviceMemoryMonitorFunction(m.device, &Impl::OnMemory, &m);
    m.packets = rtcGetDeviceProperty(m.device, RTC_DEVICE_PROPERTY_NATIVE_RAY4_SUPPORTED) > 0 &&
                rtcGetDeviceProperty(m.device, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED) > 0;
    m.packets16 = m.packets && rtcGetDeviceProperty(m.device, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) > 0;

    // Scene: robust traversal (no precision-reducing shortcuts). Build quality stays
    // Embree's default (medium), what a renderer gets without tuning.
    m.scene = rtcNewScene(m.device);
    rtcSetSceneFlags(m.scene, RTC_SCENE_FLAG_ROBUST);

    // One triangle geometry sharing our buffers: indices straight from the mesh, vertices
    // copied to a 16-byte stride because Embree loads each vertex with one 16-byte read.
    if (!mesh.triangles.empty()) {
        m.vertices.resize(mesh.positions.size() * 4 + 4, 0.0f);
        for (size_t i = 0; i < mesh.positions.size(); ++i) {
            m.vertices[4 * i + 0] = mesh.positions[i].x;
            m.vertices[4 * i + 1] = mesh.positions[i].y;
            m.vertices[4 * i + 2] = mesh.positions[i].z;
        }
        m.cut = mesh.cutouts && mesh.cutouts->Count() > 0 ? mesh.cutouts.get() : nullptr;
        if (m.cut) {
            for (uint32_t i = 0; i < mesh.triangles.size(); ++i) {
                const int g = m.cut->IsCutout(i) ? 1 : 0;
                m.split[g].push_back(mesh.triangles[i]);
                m.ids[g].push_back(i);
            }
        }
        for (unsigned g = 0; g < (m.cut ? 2u : 1u); ++g) {
            const auto& tris = m.cut ? m.split[g] : mesh.triangles;
            RTCGeometry geom = rtcNewGeometry(m.device, RTC_GEOMETRY_TYPE_TRIANGLE);
            rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                       m.vertices.data(), 0, 4 * sizeof(float), mesh.positions.size());
            // (An empty buffer's pointer may be null; Embree wants one anyway.)
            rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                       tris.empty() ? static_cast<const void*>(m.vertices.data()) : tris.data(), 0,
                                       3 * sizeof(uint32_t), tris.size());
            if (g == 1) {
                rtcSetGeometryUserData(geom, &m);
                rtcSetGeometryIntersectFilterFunction(geom, &Impl::CutoutFilter);
                rtcSetGeometryOccludedFilterFunction(geom, &Impl::CutoutFilter);
            }
            rtcCommitGeometry(geom);
            rtcAttachGeometry(m.scene, geom);  // geometry id g
            rtcReleaseGeometry(geom);          // the scene holds it now
        }
    }
    if (mesh.instances) {
        const InstancedMeshes& inst = *mesh.instances;
        m.protos.resize(inst.Prototypes().size());  // not resized again: the filters point into it
        for (size_t pi = 0; pi < inst.Prototypes().size(); ++pi) {
            const TriangleMesh& proto = inst.Prototypes()[pi];
            Impl::Proto& pr = m.protos[pi];
            pr.mesh = &proto;
            pr.cut = proto.cutouts && proto.cutouts->Count() > 0 ? proto.cutouts.get() : nullptr;
            std::vector<float>& v = m.protoVertices.emplace_back(proto.positions.size() * 4 + 4, 0.0f);
            for (size_t i = 0; i < proto.positions.size(); ++i) {
                v[4 * i + 0] = proto.positions[i].x;
                v[4 * i + 1] = proto.positions[i].y;
                v[4 * i + 2] = proto.positions[i].z;
            }
            m.protoBytes += v.size() * sizeof(float);
            RTCScene ps = rtcNewScene(m.device);
            m.protoScenes.push_back(ps);
            rtcSetSceneFlags(ps, RTC_SCENE_FLAG_ROBUST);
            if (pr.cut) {
                for (uint32_t i = 0; i < proto.triangles.size(); ++i) {
                    const int g = pr.cut->IsCutout(i) ? 1 : 0;
                    pr.split[g].push_back(proto.triangles[i]);
                    pr.ids[g].push_back(i);
                }
                m.protoBytes += proto.triangles.size() * (3 * sizeof(uint32_t) + sizeof(uint32_t));
            }
            for (unsigned g = 0; g < (pr.cut ? 2u : 1u); ++g) {
                const auto& tris = pr.cut ? pr.split[g] : proto.triangles;
                RTCGeometry geom = rtcNewGeometry(m.device, RTC_GEOMETRY_TYPE_TRIANGLE);
                rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, v.data(), 0,
                                           4 * sizeof(float), proto.positions.size());
                rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                           tris.empty() ? static_cast<const void*>(v.data()) : tris.data(), 0,
                                           3 * sizeof(uint32_t), tris.size());
                if (g == 1) {
                    rtcSetGeometryUserData(geom, &pr);
                    rtcSetGeometryIntersectFilterFunction(geom, &Impl::ProtoCutoutFilter);
                    rtcSetGeometryOccludedFilterFunction(geom, &Impl::ProtoCutoutFilter);
                }
                rtcCommitGeometry(geom);
                rtcAttachGeometry(ps, geom);  // geometry id g
                rtcReleaseGeometry(geom);
            }
            rtcCommitScene(ps);
        }
        const uint32_t flat = static_cast<uint32_t>(mesh.triangles.size());
        for (size_t i = 0; i < inst.Instances().size(); ++i) {
            const MeshInstance& in = inst.Instances()[i];
            RTCGeometry geom = rtcNewGeometry(m.device, RTC_GEOMETRY_TYPE_INSTANCE);
            rtcSetGeometryInstancedScene(geom, m.protoScenes[in.prototype]);
            rtcSetGeometryTimeStepCount(geom, 1);
            rtcSetGeometryTransform(geom, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, &in.toWorld.m[0][0]);
            rtcCommitGeometry(geom);
            const unsigned id = rtcAttachGeometry(m.scene, geom);
            rtcReleaseGeometry(geom);
            if (i == 0) m.instBase = id;
            m.instFirst.push_back(flat + in.first);
            m.instProto.push_back(in.prototype);
            m.instMirrors.push_back(in.toWorld.Determinant() < 0 ? 1 : 0);
        }
    }
    rtcCommitScene(m.scene);  // builds the BVH
    m.CheckError("building the scene");
    m.bvhBytes = m.embreeBytes.load();

    RTCBounds b;
    rtcGetSceneBounds(m.scene, &b);
    const float ext =
        std::max({b.upper_x - b.lower_x, b.upper_y - b.lower_y, b.upper_z - b.lower_z});
    m.extent = ext > 0 && std::isfinite(ext) ? ext : 1.0f;
    m.buildMs =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

EmbreeAccel::~EmbreeAccel() = default;

bool EmbreeAccel::Intersect(const Ray& ray, Hit* hit) const {
    const EmbreeRayRange r = ToEmbree(ray);
    if (!(r.tnear <= r.tfar)) return false;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit rh;
    SetRay(&rh.ray, r.o, ray.d, r.tnear, r.tfar);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(impl_->scene, &context, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
    *hit = impl_->MakeHit(rh.ray.tfar + r.shift, rh.hit.geomID, rh.hit.primID, rh.hit.instID[0], rh.hit.u, rh.hit.v);
    return true;
}

bool EmbreeAccel::Occluded(const Ray& ray) const {
    const EmbreeRayRange r = ToEmbree(ray);
    if (!(r.tnear <= r.tfar)) return false;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRay er;
    SetRay(&er, r.o, ray.d, r.tnear, r.tfar);
    rtcOccluded1(impl_->scene, &context, &er);
    return er.tfar < 0;  // Embree sets tfar to -inf when something is hit
}

namespace {

// Fills lane k of a packet (RTCRay4 or RTCRay8) from our ray; false if its range is empty.
template <typename Packet>
bool SetLane(Packet* p, int k, const Ray& ray) {
    const EmbreeRayRange r = ToEmbree(ray);
    if (!(r.tnear <= r.tfar)) return false;
    p->org_x[k] = r.o.x, p->org_y[k] = r.o.y, p->org_z[k] = r.o.z;
    p->dir_x[k] = ray.d.x, p->dir_y[k] = ray.d.y, p->dir_z[k] = ray.d.z;
    p->tnear[k] = r.tnear, p->tfar[k] = r.tfar;
    p->time[k] = 0.0f;
    p->mask[k] = 0xFFFFFFFFu;
    p->id[k] = 0;
    p->flags[k] = 0;
    return true;
}

template <int N, typename Packet, typename Trace>
void OccludedPacket(RTCScene scene, const Ray* rays, size_t count, bool* occluded, Trace trace) {
    alignas(64) int valid[N];
    alignas(64) Packet packet;
    for (int k = 0; k < N; ++k) {
        valid[k] = k < static_cast<int>(count) && SetLane(&packet, k, rays[k]) ? -1 : 0;
        if (valid[k] == 0) packet.tfar[k] = 0.0f;  // an empty range is not occluded
    }
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    trace(valid, scene, &context, &packet);
    for (size_t k = 0; k < count; ++k) occluded[k] = packet.tfar[k] < 0;  // -inf where hit
}


// Closest hits of up to N rays as one packet (RTCRayHit4/8/16), into hits[0 … count-1].
template <int N, typename PacketHit, typename Trace, typename Prim>
void IntersectPacket(RTCScene scene, const Ray* rays, size_t count, Hit* hits, Trace trace, const Prim& prim) {
    alignas(64) int valid[N];
    alignas(64) PacketHit packet;
    float shift[N];
    for (int k = 0; k < N; ++k) {
        valid[k] = k < static_cast<int>(count) && SetLane(&packet.ray, k, rays[k]) ? -1 : 0;
        shift[k] = k < static_cast<int>(count) && rays[k].tMin < 0 ? rays[k].tMin : 0.0f;
        packet.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
        packet.hit.primID[k] = RTC_INVALID_GEOMETRY_ID;
        packet.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
    }
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    trace(valid, scene, &context, &packet);
    for (size_t k = 0; k < count; ++k)
        hits[k] = valid[k] && packet.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID
                      ? prim(packet.ray.tfar[k] + shift[k], packet.hit.geomID[k], packet.hit.primID[k],
                             packet.hit.instID[0][k], packet.hit.u[k], packet.hit.v[k])
                      : Hit{};
}
}  // namespace

void EmbreeAccel::IntersectMany(const Ray* rays, size_t count, Hit* hits) const {
    if (!impl_->packets) {
        Accelerator::IntersectMany(rays, count, hits);
        return;
    }
    const Impl& m = *impl_;
    auto prim = [&m](float t, unsigned geomID, unsigned primID, unsigned instID, float u, float v) {
        return m.MakeHit(t, geomID, primID, instID, u, v);
    };
    for (size_t first = 0; first < count;) {
        const size_t n = std::min<size_t>(count - first, impl_->packets16 ? 16 : 8);
        if (n > 8) {
            IntersectPacket<16, RTCRayHit16>(impl_->scene, rays + first, n, hits + first, rtcIntersect16, prim);
        } else if (n == 1) {
            hits[first] = Hit{};
            Intersect(rays[first], &hits[first]);
        } else if (n <= 4) {
            IntersectPacket<4, RTCRayHit4>(impl_->scene, rays + first, n, hits + first, rtcIntersect4, prim);
        } else {
            IntersectPacket<8, RTCRayHit8>(impl_->scene, rays + first, n, hits + first, rtcIntersect8, prim);
        }
        first += n;
    }
}

void EmbreeAccel::OccludedMany(const Ray* rays, size_t count, bool* occluded) const {
    if (!impl_->packets) {
        Accelerator::OccludedMany(rays, count, occluded);
        return;
    }
    for (size_t first = 0; first < count;) {
        const size_t n = std::min<size_t>(count - first, impl_->packets16 ? 16 : 8);
        if (n > 8)
            OccludedPacket<16, RTCRay16>(impl_->scene, rays + first, n, occluded + first, rtcOccluded16);
        else if (n == 1)
            occluded[first] = Occluded(rays[first]);
        else if (n <= 4)
            OccludedPacket<4, RTCRay4>(impl_->scene, rays + first, n, occluded + first, rtcOccluded4);
        else
            OccludedPacket<8, RTCRay8>(impl_->scene, rays + first, n, occluded + first, rtcOccluded8);
        first += n;
    }
}

int EmbreeAccel::CountCrossings(const Ray& ray) const {
    Impl& m = *impl_;
    if (!(ray.tMin < ray.tMax) || LengthSquared(ray.d) == 0) return 0;
    // Built on first use, usually from inside a TBB loop: isolated, so that while Embree's
    // build waits for its tasks this thread cannot pick up another of the caller's tasks,
    // call CountCrossings again and block on the once_flag it holds.
    std::call_once(m.countOnce,
                   [&] { tbb::this_task_arena::isolate([&] { m.BuildCountScene(); }); });
    // Embree walks a slightly longer interval than (tMin, tMax), so rounding at its ends
    // never drops a box; IntersectTriangle applies the exact range.
    const float margin = 1e-5f * m.extent / Length(ray.d);
    Ray wide = ray;
    wide.tMin = ray.tMin - margin;
    wide.tMax = ray.tMax + margin;
    const EmbreeRayRange r = ToEmbree(wide);
    std::vector<uint32_t> hits;
    CountContext c;
    rtcInitIntersectContext(&c.context);
    c.ray = &ray;
    c.mesh = &m.mesh;
    c.hits = &hits;
    RTCRay er;
    SetRay(&er, r.o, ray.d, r.tnear, r.tfar);
    rtcOccluded1(m.countScene, &c.context, &er);
    // A primitive is offered once per BVH leaf that holds it; dedupe to be sure.
    std::sort(hits.begin(), hits.end());
    return int(std::unique(hits.begin(), hits.end()) - hits.begin());
}

AccelFigures EmbreeAccel::Figures() const {
    const Impl& m = *impl_;
    const size_t tris = std::max<size_t>(m.mesh.PrimCount(), 1);
    const size_t bytes = m.vertices.size() * sizeof(float) + m.protoBytes +
                         (m.split[0].size() + m.split[1].size()) * (3 * sizeof(uint32_t) + sizeof(uint32_t));
    AccelFigures f = {
        {"embree version", RTC_VERSION_STRING},
        {"embree scene", m.cut ? StringPrintf("2 triangle geometries (%zu opaque, %zu cut-out with intersection and "
                                              "occlusion filters), robust, default build quality",
                                              m.ids[0].size(), m.ids[1].size())
                               : std::string("1 triangle geometry, robust, default build quality")},
        {"embree bytes", StringPrintf("%lld (%.1f per triangle): BVH and Embree's other allocations %lld, "
                                      "vertex copy%s %zu",
                                      static_cast<long long>(m.bvhBytes + int64_t(bytes)),
                                      double(m.bvhBytes + int64_t(bytes)) / double(tris),
                                      static_cast<long long>(m.bvhBytes),
                                      m.cut ? " and the two geometries' indices" : "", bytes)},
        {"embree build ms", StringPrintf("%.1f", m.buildMs)},
    };
    if (m.mesh.instances)
        f.insert(f.begin() + 2, {"embree instances", StringPrintf("%s instance geometries of %zu prototype scenes, standing for %s "
                                                                  "triangles (and %s flat ones)",
                                                                  FormatCount(m.instFirst.size()).c_str(), m.protoScenes.size(),
                                                                  FormatCount(m.mesh.instances->TriangleCount()).c_str(),
                                                                  FormatCount(m.mesh.triangles.size()).c_str())});
    return f;
}

}  // namespace lm
