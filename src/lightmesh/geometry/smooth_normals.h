// smooth_normals.h -- smooth shading normals for a mesh that has none, with a crease angle.
#pragma once

#include "lightmesh/geometry/mesh.h"

namespace lm {

/// Above this many faces around one position, the crease angle is not
/// applied there (every face around it counts): a fan of 100,000 triangles would otherwise
/// cost 10^10 comparisons.
inline constexpr size_t kMaxSmoothedNormalsPerPosition = 4096;

/// Gives `mesh`'s flat triangles smooth vertex normals (mesh->normals must be empty; its
/// instances are left alone): a corner's normal is the mean, weighted by their angles at
/// that position, of the normals of the faces around it (vertices at the same position
/// count as one) that make
/// an angle of at most `creaseDegrees` with its own face's; a vertex is split where its
/// corners' normals differ (its texture coordinates copied). creaseDegrees in [0, 180]: 0
/// keeps faces flat, 180 smooths everything. A degenerate face's corners take the mean
/// of their neighbours', or +z when there is none.
void SmoothNormals(TriangleMesh* mesh, float creaseDegrees);

}  // namespace lm
