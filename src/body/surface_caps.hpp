#pragma once
// Closing surfaces and cutting them into closed parts (the skinned bodies: src/body/skinned_body.hpp,
// src/body/character_body.hpp): boundary loops capped by fans around their mean points.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "src/body/skeleton_body.hpp"
#include "src/core/geometry.hpp"

namespace amhv {

// The boundary of a triangle set as directed edges (a, b) where (a, b) is used more often than
// (b, a), walked into loops; fails naming `what` when some vertex starts more boundary edges than
// it ends (the boundary is then no union of loops and a cap cannot close it).
std::vector<std::vector<std::uint32_t>> boundary_loops(const std::vector<std::array<std::uint32_t, 3>>& triangles, const std::string& what);

// Caps every loop with a fan around a new vertex (its index `first_new` + loop number): each
// boundary edge (a, b) gets the triangle (b, a, centre), so the surface becomes a closed 2-cycle.
void cap_loops(const std::vector<std::vector<std::uint32_t>>& loops, std::uint32_t first_new, std::vector<std::array<std::uint32_t, 3>>& triangles);

// Drops every triangle that repeats a directed edge of an earlier one (a fin); returns how many.
int drop_fins(std::vector<std::array<std::uint32_t, 3>>& triangles);

// Gives each fan of triangles around a vertex its own copy of the vertex (appended to `sources`),
// so that a vertex two caps of a part only touch becomes two. Fails naming `what` when an edge is
// left between more than two triangles.
void split_fans(std::vector<std::array<std::uint32_t, 3>>& triangles, std::vector<std::uint32_t>& sources, const std::string& what);

Vec3 mean_of(const std::vector<Vec3>& points, const std::vector<std::uint32_t>& ids);

// A closed part of a surface: the extended vertex ids it uses (vertices, then cap centres) and its
// triangles into that list.
struct SurfacePart {
    std::string name;
    std::vector<std::uint32_t> vertices;
    std::vector<std::array<std::uint32_t, 3>> triangles;
};
// Labels every triangle with the part of its vertices (two of three decide, else the first), then
// closes each part across its cuts with fans around new vertices: each cut's loop is appended to
// `derived` (its centre is vertex `vertex_count` + its index in `derived`). Parts come in `order`,
// then any other name in name order; `caps` counts the cuts capped.
std::vector<SurfacePart> split_into_parts(const std::vector<std::array<std::uint32_t, 3>>& triangles, const std::vector<std::string>& vertex_part,
                                          const std::vector<std::string>& order, const std::string& source, std::size_t vertex_count,
                                          std::vector<std::vector<std::uint32_t>>& derived, int& caps);

// The parts at one pose: `points` holds the surface's vertices at that pose; each cap centre is
// appended as the mean of its loop (`derived`); fails naming `source` and `frame` ("frame F gives
// `what`") when a point is not finite.
std::vector<BodyPart> posed_parts(const std::vector<SurfacePart>& parts, std::vector<Vec3> points, const std::vector<std::vector<std::uint32_t>>& derived,
                                  const std::string& source, int frame, const char* what);

}  // namespace amhv
