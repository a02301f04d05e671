#include "src/core/geometry.hpp"

#include <algorithm>
#include <unordered_map>

namespace amhv {

Box3 TriangleMesh::bounds() const {
    Box3 box;
    for (const auto& triangle : triangles)
        for (auto index : triangle) box.extend(vertices[index]);
    return box;
}

bool TriangleMesh::is_closed() const {
    // Count directed edges: +1 for (a, b) with a < b, -1 for (b, a). A closed surface sums to 0
    // on every undirected edge.
    std::unordered_map<std::uint64_t, int> balance;
    balance.reserve(triangles.size() * 3);
    for (const auto& t : triangles) {
        for (int e = 0; e < 3; ++e) {
            std::uint32_t a = t[e];
            std::uint32_t b = t[(e + 1) % 3];
            if (a == b) continue;
            std::uint64_t key = (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
            balance[key] += a < b ? 1 : -1;
        }
    }
    return std::all_of(balance.begin(), balance.end(), [](const auto& kv) { return kv.second == 0; });
}

void TriangleMesh::append(const TriangleMesh& other) {
    auto offset = static_cast<std::uint32_t>(vertices.size());
    vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
    for (auto t : other.triangles) triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
}

Box3 MeshSequence::bounds() const {
    Box3 box;
    for (const auto& frame : frames) box.extend(frame.mesh.bounds());
    return box;
}

}  // namespace amhv
