// Triangle mesh → ellipsoids (Jiménez de Parga & Gómez Palomo 2018, §3.6.4, eqs. 22–30).
//
// One ellipsoid per triangle (P1, P2, P3):
//   B = (P1 + P2 + P3) / 3                                   (22) barycentre
//   P'i = (Pi − B) · scale + B                               (23) vertices scaled about B
//   radii (a, b, c) = (|B − P'1|, |B − P'2|, |B − P'3|)      (24) along local x, y, z
// With `rotate`, the ellipsoid's longest axis (local x, y or z for a, b or c; the first on ties)
// is turned onto the direction of the farthest scaled vertex, dirTria = P'k − B (25, 26), by the
// Rodrigues rotation R = I + sin θ A + (1 − cos θ) A² about x = dirEllip × dirTria / |…|,
// θ = acos(dirEllip · dirTria / (|dirEllip| |dirTria|)), A = [x]× (27–30).
//
// Degenerate triangles never produce NaN: radii are floored at `min_radius` (a vertex on the
// barycentre would otherwise give a zero radius, an invalid ellipsoid); when dirTria vanishes the
// rotation is the identity; when it is antiparallel to dirEllip (the cross product vanishes) the
// rotation is a half turn about another local axis. The paper's R fixes only the longest axis;
// the other two follow from the minimal rotation, as in the paper.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "cumuli/primitives.hpp"

namespace cumuli {

struct MeshEllipsoidsResult {
  std::vector<Ellipsoid> ellipsoids;  // one per face, in face order
  int floored_faces = 0;              // faces with a radius raised to min_radius
};

// vertices: V × 3 floats (xyz interleaved); faces: F × 3 vertex indices. scale ∈ (0, 2].
// min_radius > 0 (the caller picks it relative to the mesh size). Throws std::invalid_argument
// on empty input, non-finite vertices, indices outside [0, V), or a bad scale/min_radius. Runs on
// `threads` threads (0 = all cores); the result does not depend on the thread count.
MeshEllipsoidsResult ellipsoids_from_mesh(const float* vertices, std::size_t vertex_count,
                                          const std::int64_t* faces, std::size_t face_count,
                                          float scale, bool rotate, float min_radius, int threads);

// The rotation taking unit vector `from` onto the direction of `to` (Rodrigues, eqs. 27–30),
// with the degenerate cases above. Exposed for tests.
glm::mat3 rotation_onto(glm::vec3 from, glm::vec3 to);

}  // namespace cumuli
