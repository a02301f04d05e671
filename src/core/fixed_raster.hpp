#pragma once
// The exact integer crossing test of the solid voxeliser, shared by the CPU reference and the host
// side of the Vulkan path. shaders/fixed_raster.glsl mirrors it line for line: keep them in step.
//
// Coordinates are integers in units of 1/kSubvoxel voxel relative to the grid origin. With at most
// kMaxGridAxis voxels per axis they stay below 2^17, edge functions below 2^35 and the crossing
// numerator below 2^53: every product fits in int64, so there is no rounding anywhere.
#include <algorithm>
#include <array>
#include <cstdint>

namespace amhv::fixed {

inline constexpr std::int64_t kSubvoxel = 64;

struct Point2 {
    std::int32_t x, y;
};
struct Point3 {
    std::int32_t x, y, z;
    Point2 xy() const { return {x, y}; }
};
using Triangle = std::array<Point3, 3>;

inline std::int64_t edge_function(Point2 a, Point2 b, Point2 p) {
    return std::int64_t(b.x - a.x) * std::int64_t(p.y - a.y) - std::int64_t(b.y - a.y) * std::int64_t(p.x - a.x);
}

// Top-left rule: a sample on an edge shared by two triangles belongs to exactly one of them.
inline bool is_top_left(Point2 a, Point2 b) {
    int dy = b.y - a.y;
    int dx = b.x - a.x;
    return dy < 0 || (dy == 0 && dx < 0);
}

inline bool covers(std::int64_t w, Point2 a, Point2 b) { return w > 0 || (w == 0 && is_top_left(a, b)); }

inline std::int64_t floor_div(std::int64_t n, std::int64_t d) {  // d > 0
    return n >= 0 ? n / d : -((-n + d - 1) / d);
}

// Column indices whose centres (i + 1/2 voxel) lie in [lo, hi]; empty when first > last.
struct IndexRange {
    int first, last;
};
inline IndexRange centre_range(std::int32_t lo, std::int32_t hi) {
    const std::int64_t half = kSubvoxel / 2;
    return {int(-floor_div(-(std::int64_t(lo) - half), kSubvoxel)), int(floor_div(std::int64_t(hi) - half, kSubvoxel))};
}

// A triangle ready for column tests: counter-clockwise seen from above, with the winding change it
// causes for voxels above its crossing (-1 for upward-facing, +1 for downward-facing faces).
struct Oriented {
    Point3 a, b, c;
    std::int64_t area;  // twice the projected area, > 0
    int winding_change;
    IndexRange columns_x, columns_y;
};

// False for triangles seen edge-on from above: a vertical ray never crosses them.
inline bool orient(const Triangle& t, Oriented& out) {
    Point3 a = t[0], b = t[1], c = t[2];
    std::int64_t area = edge_function(a.xy(), b.xy(), c.xy());
    if (area == 0) return false;
    out.winding_change = area > 0 ? -1 : 1;
    if (area < 0) {
        std::swap(b, c);
        area = -area;
    }
    out.a = a;
    out.b = b;
    out.c = c;
    out.area = area;
    out.columns_x = centre_range(std::min({a.x, b.x, c.x}), std::max({a.x, b.x, c.x}));
    out.columns_y = centre_range(std::min({a.y, b.y, c.y}), std::max({a.y, b.y, c.y}));
    return true;
}

// Does the triangle cover the centre of column (x, y)? If so, `first_above` is the first voxel
// layer whose centre lies strictly above the crossing.
inline bool column_crossing(const Oriented& t, int x, int y, std::int64_t& first_above) {
    const std::int64_t half = kSubvoxel / 2;
    Point2 p{std::int32_t(x * kSubvoxel + half), std::int32_t(y * kSubvoxel + half)};
    std::int64_t wa = edge_function(t.b.xy(), t.c.xy(), p);
    std::int64_t wb = edge_function(t.c.xy(), t.a.xy(), p);
    std::int64_t wc = edge_function(t.a.xy(), t.b.xy(), p);
    if (!(covers(wa, t.b.xy(), t.c.xy()) && covers(wb, t.c.xy(), t.a.xy()) && covers(wc, t.a.xy(), t.b.xy())))
        return false;
    std::int64_t numerator = wa * t.a.z + wb * t.b.z + wc * t.c.z;
    first_above = floor_div(numerator - half * t.area, kSubvoxel * t.area) + 1;
    return true;
}

}  // namespace amhv::fixed
