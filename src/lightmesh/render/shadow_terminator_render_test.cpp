// The shadow terminator on a smooth-shaded low-poly sphere: lit as the smooth sphere its
// normals describe, with no dark band along the facets' edges.
#include <gtest/gtest.h>

#include <cmath>

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/geometry/triangle.h"
#include "lightmesh/render/whitted.h"
#include "lightmesh/scene/shapes.h"
#include "lightmesh/shadow/shadow.h"
#include "lightmesh/util/error.h"

namespace lm {
namespace shadow_terminator_render_test {
namespace {

// A sphere of 8 rings and 12 segments (30° facets) with the true sphere's normals at its
// vertices, a point light level with its centre, and the camera looking across the
// terminator from the front.
Scene LowPolySphere() {
    Scene s;
    s.name = "test:low-poly sphere";
    s.materials = {{"ball", Color(0.8f), Color(0.0f), 1.0f, Color(0.0f)}};
    ShapeBuilder(&s.mesh).Sphere(Vec3(0.0f), 1.0f, 8, 12, 0);
    for (const Vec3& p : s.mesh.positions) s.mesh.normals.push_back(Normalize(p));
    s.lights = {{{30.0f, 0.5f, 2.0f}, Color(900.0f), Falloff::InverseSquare}};
    s.camera = Camera{{0.3f, 0.8f, 4.0f}, {0, 0, 0}, {0, 1, 0}, 35.0f};
    s.ambient = Color(0.05f);
    s.render.width = 160;
    s.render.height = 160;
    return s;
}


Image Render(const Scene& s, const Accelerator& accel, const std::string& method) {
    const auto shadows = CreateShadowMethod(method, s, accel, s.render);
    return WhittedRenderer(s, accel, *shadows, s.render).Render().image;
}

TEST(ShadowTerminator, ALowPolySphereIsLitAsTheSmoothOne) {
    const Scene s = LowPolySphere();
    for (const char* accelName : {"grid", "embree", "brute"}) {
        std::unique_ptr<Accelerator> accel;
        try {
            accel = CreateAccelerator(accelName, s.mesh);
        } catch (const Error&) {
            continue;  // built without Embree
        }
        const Image none = Render(s, *accel, "none"), rt = Render(s, *accel, "rt");
        const CameraRays cam(s.camera, s.render.width, s.render.height);
        int smoothlyLit = 0, facetAway = 0, unlit = 0, selfShadowed = 0;
        for (int y = 0; y < s.render.height; ++y)
            for (int x = 0; x < s.render.width; ++x) {
                const Ray ray = cam.Generate(x + 0.5f, y + 0.5f);
                Hit hit;
                if (!accel->Intersect(ray, &hit)) continue;
                Vec3 ns;
                const ShadingPoint sp = WhittedRenderer::MakeShadingPoint(s.mesh, ray, hit, &ns);
                const Vec3 l = Normalize(s.lights[0].position - sp.p);
                if (!(Dot(ns, l) > 0.02f)) continue;
                ++smoothlyLit;
                if (Dot(sp.n, l) <= 0) ++facetAway;
                // The light's term is there (the shading normal faces the light) ...
                if (!(none.At(x, y).r > s.ambient.r * 0.8f + 1e-3f)) ++unlit;
                // ... and nothing of the sphere shadows it: its ray leaves the mesh.
                if (rt.At(x, y) != none.At(x, y)) ++selfShadowed;
            }
        SCOPED_TRACE(accelName);
        ASSERT_GT(smoothlyLit, 3000) << smoothlyLit;
        // The band where the facets turn away from a light the normals face: a cut on the
        // facet's normal, or a ray from the facet, would darken all of it.
        EXPECT_GT(facetAway, 40) << facetAway;
        EXPECT_EQ(unlit, 0);
        EXPECT_LE(selfShadowed, smoothlyLit / 500) << selfShadowed << " of " << smoothlyLit;
    }
}

// Where the mesh has no normals, rays leave the facet as before: the lifted origin is the
// point pushed off its triangle, and the lit side ends on the facets' edges.
TEST(ShadowTerminator, AFlatShadedSphereKeepsItsFacets) {
    Scene s = LowPolySphere();
    s.mesh.normals.clear();
    const auto accel = CreateAccelerator("brute", s.mesh);
    const CameraRays cam(s.camera, s.render.width, s.render.height);
    int hits = 0;
    for (int y = 0; y < s.render.height; y += 4)
        for (int x = 0; x < s.render.width; x += 4) {
            const Ray ray = cam.Generate(x + 0.5f, y + 0.5f);
            Hit hit;
            if (!accel->Intersect(ray, &hit)) continue;
            ++hits;
            Vec3 ns;
            const ShadingPoint sp = WhittedRenderer::MakeShadingPoint(s.mesh, ray, hit, &ns);
            EXPECT_EQ(ns, sp.n);
            EXPECT_EQ(sp.origin, sp.p + sp.n * SurfaceOffset(s.mesh.Vertex(hit.prim, 0), s.mesh.Vertex(hit.prim, 1),
                                                               s.mesh.Vertex(hit.prim, 2)));
        }
    EXPECT_GT(hits, 500);
}

}  // namespace
}  // namespace shadow_terminator_render_test
}  // namespace lm
