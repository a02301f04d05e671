#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace amhv {

using Vec3 = Eigen::Vector3d;

struct Box3 {
    Vec3 min = Vec3::Constant(std::numeric_limits<double>::infinity());
    Vec3 max = Vec3::Constant(-std::numeric_limits<double>::infinity());

    bool empty() const { return !(min.array() <= max.array()).all(); }
    void extend(const Vec3& p) {
        min = min.cwiseMin(p);
        max = max.cwiseMax(p);
    }
    void extend(const Box3& b) {
        if (b.empty()) return;
        extend(b.min);
        extend(b.max);
    }
};

// A triangle mesh in metres, z up. Meshes may change topology every frame.
struct TriangleMesh {
    std::vector<Vec3> vertices;
    std::vector<std::array<std::uint32_t, 3>> triangles;

    Box3 bounds() const;
    // True when every directed edge (a, b) is matched by as many (b, a): the surface is a closed
    // 2-cycle and its winding number is defined everywhere off the surface.
    bool is_closed() const;
    void append(const TriangleMesh& other);
};

// The area-weighted centroid of a mesh's triangles (the vertex mean when it has no area; none when
// it has no vertex).
std::optional<Vec3> surface_centroid(const TriangleMesh& mesh);
// The same with each triangle's area also weighted by weight(its centroid) (at least 0); none when
// the weights sum to 0.
std::optional<Vec3> weighted_surface_centroid(const TriangleMesh& mesh, const std::function<double(const Vec3&)>& weight);

struct MeshFrame {
    TriangleMesh mesh;
    std::string source;  // file path (or generator description) for messages
};

struct MeshSequence {
    std::vector<MeshFrame> frames;
    std::string source;  // folder, pattern or file the sequence came from

    Box3 bounds() const;
};

}  // namespace amhv
