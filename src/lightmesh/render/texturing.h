// texturing.h -- a material's diffuse colour at a hit: its texture looked up at the hit's
// texture coordinates, at the mip level of the ray's footprint (a ray cone).
#pragma once

#include "lightmesh/accel/accelerator.h"
#include "lightmesh/scene/scene.h"

namespace lm {

/// The diffuse reflectance of `mat` (a material with a texture) at `hit` of `ray`:
/// mat.textureScale × the texel's colour where the mesh has texture coordinates, else
/// mat.kd. The mip level follows the ray's footprint (Akenine-Möller et al., "Texture Level
/// of Detail Strategies for Real-Time Ray Tracing", 2019: a cone of `spread` radians, the
/// angle between neighbouring camera rays): log2 of its width over the texel's size on the
/// triangle, widened by 1 / |cos| of the ray's incidence (Texture::Sample: bilinear on
/// the finer of the two levels it falls between). A reflected ray's cone starts at
/// the mirror (its width there is not carried along): reflections may alias a little.
Color TexturedDiffuse(const Scene& scene, const Material& mat, const Ray& ray, const Hit& hit, float spread);

}  // namespace lm
