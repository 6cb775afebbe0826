// texturing.cpp -- a material's diffuse colour at a hit (texturing.h).
#include "lightmesh/render/texturing.h"

#include <cmath>
#include <cstdint>
#include <cstring>

namespace lm {

Color TexturedDiffuse(const Scene& scene, const Material& mat, const Ray& ray, const Hit& hit, float spread) {
    const TriangleMesh& mesh = scene.mesh;
    TexCoord uv[3];
    if (mat.texture < 0 || !mesh.UvsOf(hit.prim, uv)) return mat.kd;
    const Texture& tex = *scene.textures[static_cast<size_t>(mat.texture)];
    const TexCoord &t0 = uv[0], &t1 = uv[1], &t2 = uv[2];
    const float b0 = 1.0f - hit.b1 - hit.b2;
    const float u = t0.u * b0 + t1.u * hit.b1 + t2.u * hit.b2;
    const float v = t0.v * b0 + t1.v * hit.b1 + t2.v * hit.b2;

    // The footprint: texels per unit of surface (the triangle's texture area over its
    // world area), times the cone's width at the hit over the incidence's cosine.
    const bool flat = hit.prim < mesh.TriangleCount();
    Vec3 placed[3];
    if (!flat) mesh.Corners(hit.prim, placed);
    const Vec3 &p0 = flat ? mesh.Vertex(hit.prim, 0) : placed[0], &p1 = flat ? mesh.Vertex(hit.prim, 1) : placed[1],
               &p2 = flat ? mesh.Vertex(hit.prim, 2) : placed[2];
    const Vec3 normal = Cross(p1 - p0, p2 - p0);
    const float worldArea = Length(normal);
    const float texArea = std::abs((t1.u - t0.u) * (t2.v - t0.v) - (t2.u - t0.u) * (t1.v - t0.v)) *
                          static_cast<float>(tex.Width()) * static_cast<float>(tex.Height());
    // lod = ½·log2(texArea / worldArea) + log2(width / cos), as one log2: with
    // width = t·|d|·spread and cos = |n·d| / (|n|·|d|) (|n| = worldArea),
    // (width / cos)² = (t·spread·|d|²·|n|)² / (n·d)².
    const float d2 = Dot(ray.d, ray.d), nd = Dot(normal, ray.d);
    const float ts = hit.t * spread * d2 * worldArea;
    const float cos2 = std::max(nd * nd, 1e-6f * d2 * worldArea * worldArea);  // |cos| ≥ 1e-3
    // Sample reads level floor(lod) = floor(½·log2 ratio): the exponent of ratio halved
    // (rounded down), read from its bits instead of a log2 call.
    const float ratio = texArea / worldArea * ts * ts / cos2;
    float lod = 0;
    if (ratio > 1 && ratio <= 3.4e38f) {
        uint32_t bits;
        std::memcpy(&bits, &ratio, 4);
        lod = static_cast<float>((static_cast<int>(bits >> 23) - 127) >> 1);
    }
    return mat.textureScale * tex.Sample(u, v, lod, mat.wrapU, mat.wrapV).Rgb();
}

}  // namespace lm
