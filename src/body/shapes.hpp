#pragma once
// Closed, outward-oriented triangle meshes of simple solids. Bodies built from skeletons are
// unions of these; tests use them as shapes with known volume.
#include "src/core/geometry.hpp"

namespace amhv::shapes {

// Sphere as a surface of revolution with `rings` latitude bands and `segments` around.
TriangleMesh sphere(const Vec3& centre, double radius, int rings = 16, int segments = 24);
// Capsule: a cylinder from a to b with hemispherical caps. Degenerates to a sphere when a == b.
TriangleMesh capsule(const Vec3& a, const Vec3& b, double radius, int cap_rings = 6, int segments = 16);
// The hull of a sphere of radius ra at a and one of radius rb at b: a cone with spherical caps
// (a limb that narrows, such as a forearm towards the wrist). The larger sphere when it holds the other.
TriangleMesh tapered_capsule(const Vec3& a, const Vec3& b, double ra, double rb, int cap_rings = 6, int segments = 16);
// Axis-aligned box.
TriangleMesh box(const Vec3& min, const Vec3& max);
// Torus around the z axis through `centre`.
TriangleMesh torus(const Vec3& centre, double major_radius, double minor_radius, int major_segments = 48,
                   int minor_segments = 24);

// Volume enclosed by a closed mesh (positive for outward orientation).
double signed_volume(const TriangleMesh& mesh);

}  // namespace amhv::shapes
