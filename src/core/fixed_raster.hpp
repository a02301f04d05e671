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
#include <utility>

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
    const std::int32_t half = kSubvoxel / 2;
    static_assert(kSubvoxel == 1 << 6);  // >> 6 is a floor division by it
    return {-((half - lo) >> 6), (hi - half) >> 6};
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

// The columns of each row whose centres a triangle may cover: those in its cross-section with the
// row's centre line. For planning only (buffer room and work), so it may be a little wide but must
// never miss a column column_crossing covers. The cross-section's ends are found in 32.32 fixed
// point from slopes rounded towards zero, whose error stays below 2^-14 units for coordinates under
// 2^17, and widened by 2^-8 units: a column is extra only when its centre lies that close to an
// edge. No branches: it runs for every row of every triangle, and whether a row is empty is as
// good as random.
class CrossSections {
public:
    // Rows from first_row up; their centres must lie within the triangle's height.
    CrossSections(const Triangle& t, int first_row) {
        // By height: the long edge low -> high spans every row, the short ones meet at middle.
        Point3 low = t[0], middle = t[1], high = t[2];
        if (middle.y < low.y) std::swap(middle, low);
        if (high.y < middle.y) std::swap(high, middle);
        if (middle.y < low.y) std::swap(middle, low);
        const std::int64_t centre = std::int64_t(first_row) * kSubvoxel + kSubvoxel / 2;
        long_ = Edge(low, high, centre);
        lower_ = Edge(low, middle, centre);
        upper_ = Edge(middle, high, centre);
        // Rows below the middle vertex follow the lower edge; from it up, the upper one (at it: the
        // vertex itself, which also covers a flat bottom or top).
        rows_below_ = std::max<std::int64_t>(0, -((kSubvoxel / 2 - middle.y) >> 6) - first_row);
    }

    // Row first_row + i's columns (first > last: none).
    IndexRange row(int i) const {
        // x relative to the first column's centre: column c's centre is at c * S, so the first
        // column at or right of the widened left end is ceil(left / S), the last at or left of the
        // right end floor(right / S) (>> is a floor division).
        const std::int64_t on_long = long_.at(i), on_short = i < rows_below_ ? lower_.at(i) : upper_.at(i);
        constexpr int shift = kFraction + 6;
        static_assert(kSubvoxel == 1 << 6);
        return {int(-((kMargin - std::min(on_long, on_short)) >> shift)), int((std::max(on_long, on_short) + kMargin) >> shift)};
    }

private:
    static constexpr int kFraction = 32;
    static constexpr std::int64_t kMargin = std::int64_t(1) << (kFraction - 8);
    // An edge's x at row first_row + i's centre, relative to the first column's centre. Unsigned,
    // so that an edge followed past its own height (a short edge not in use) wraps instead of
    // overflowing; where it is in use the value is in range.
    struct Edge {
        std::uint64_t x = 0, per_row = 0;
        Edge() = default;
        Edge(Point3 from, Point3 to, std::int64_t centre) {
            // dx / dy in 32.32 (0 for a level edge, which no row crosses but at its own height,
            // where the vertex term alone is exact).
            const std::int64_t slope =
                to.y == from.y ? 0 : std::int64_t(double(to.x - from.x) / double(to.y - from.y) * double(std::int64_t(1) << kFraction));
            x = (std::uint64_t(std::int64_t(from.x) - kSubvoxel / 2) << kFraction) + std::uint64_t(centre - from.y) * std::uint64_t(slope);
            per_row = std::uint64_t(slope) * std::uint64_t(kSubvoxel);
        }
        std::int64_t at(int i) const { return std::int64_t(x + std::uint64_t(i) * per_row); }
    };
    Edge long_, lower_, upper_;
    std::int64_t rows_below_ = 0;
};

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
