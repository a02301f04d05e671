#include "src/core/geometry.hpp"

#include <algorithm>
#include <vector>

namespace amhv {

Box3 TriangleMesh::bounds() const {
    Box3 box;
    for (const auto& triangle : triangles)
        for (auto index : triangle) box.extend(vertices[index]);
    return box;
}

bool TriangleMesh::is_closed() const {
    // Every undirected edge must be used as often from its lower vertex to its higher one as back.
    // The edges are bucketed by their lower vertex (a counting sort, linear in the edges: a hash
    // map with a node per edge cost more than the voxelisation this gates, frame after frame); a
    // bucket holds a handful of edges. A face naming a vertex the mesh lacks closes nothing.
    const std::size_t vertex_count = vertices.size();
    for (const auto& t : triangles)
        if (std::max({t[0], t[1], t[2]}) >= vertex_count) return false;
    std::vector<std::uint32_t> first(vertex_count + 1, 0);
    const auto for_each_edge = [&](const auto& visit) {
        for (const auto& t : triangles)
            for (std::size_t e = 0; e < 3; ++e)
                if (t[e] != t[(e + 1) % 3]) visit(t[e], t[(e + 1) % 3]);
    };
    for_each_edge([&](std::uint32_t a, std::uint32_t b) { ++first[std::min(a, b) + 1]; });
    for (std::size_t v = 0; v < vertex_count; ++v) first[v + 1] += first[v];
    // Per edge: its higher vertex, times two, plus one when it runs from the higher to the lower.
    std::vector<std::uint64_t> edges(first.back());
    std::vector<std::uint32_t> next(first.begin(), first.end() - 1);
    for_each_edge([&](std::uint32_t a, std::uint32_t b) { edges[next[std::min(a, b)]++] = std::uint64_t(std::max(a, b)) * 2 + (a > b); });
    for (std::size_t v = 0; v < vertex_count; ++v) {
        const auto begin = edges.begin() + first[v], end = edges.begin() + first[v + 1];
        std::sort(begin, end);
        // Sorted, each higher vertex's downward uses follow its upward ones: the counts must match.
        for (auto at = begin; at != end;) {
            const std::uint64_t to = *at >> 1;
            std::ptrdiff_t balance = 0;
            for (; at != end && (*at >> 1) == to; ++at) balance += (*at & 1) ? -1 : 1;
            if (balance != 0) return false;
        }
    }
    return true;
}

void TriangleMesh::append(const TriangleMesh& other) {
    const auto offset = static_cast<std::uint32_t>(vertices.size());
    vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
    const std::size_t first = triangles.size();
    triangles.insert(triangles.end(), other.triangles.begin(), other.triangles.end());
    for (std::size_t t = first; t < triangles.size(); ++t)
        for (auto& index : triangles[t]) index += offset;
}

Box3 MeshSequence::bounds() const {
    Box3 box;
    for (const auto& frame : frames) box.extend(frame.mesh.bounds());
    return box;
}

std::optional<Vec3> surface_centroid(const TriangleMesh& mesh) {
    Vec3 sum = Vec3::Zero();
    double area = 0;
    for (const auto& t : mesh.triangles) {
        const Vec3 &p = mesh.vertices[t[0]], &q = mesh.vertices[t[1]], &r = mesh.vertices[t[2]];
        const double a = 0.5 * (q - p).cross(r - p).norm();
        sum += a * (p + q + r) / 3.0;
        area += a;
    }
    if (area > 0) return sum / area;
    if (mesh.vertices.empty()) return std::nullopt;
    for (const Vec3& v : mesh.vertices) sum += v;
    return sum / double(mesh.vertices.size());
}

std::optional<Vec3> weighted_surface_centroid(const TriangleMesh& mesh, const std::function<double(const Vec3&)>& weight) {
    Vec3 sum = Vec3::Zero();
    double total = 0;
    for (const auto& t : mesh.triangles) {
        const Vec3 &p = mesh.vertices[t[0]], &q = mesh.vertices[t[1]], &r = mesh.vertices[t[2]];
        const Vec3 centre = (p + q + r) / 3.0;
        const double w = 0.5 * (q - p).cross(r - p).norm() * weight(centre);
        sum += w * centre;
        total += w;
    }
    if (total > 0) return sum / total;
    return std::nullopt;
}

}  // namespace amhv
