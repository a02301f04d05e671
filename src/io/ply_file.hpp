#pragma once
// Binary PLY output, written directly rather than through OpenMesh: its half-edge mesh drops
// non-manifold faces, and what amhv writes must hold exactly the triangles it was given.
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "src/core/geometry.hpp"

namespace amhv {

// `mesh` as binary little-endian PLY: float x y z per vertex (plus uchar red green blue when
// `colours` has one entry per vertex), and int vertex_indices per triangle. `comments` go into the
// header, one line each.
void write_ply(const std::filesystem::path& path, const TriangleMesh& mesh, const std::vector<std::array<std::uint8_t, 3>>& colours,
               const std::vector<std::string>& comments);

}  // namespace amhv
