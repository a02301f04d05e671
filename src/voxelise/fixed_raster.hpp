#pragma once
// The exact integer crossing test of the solid voxeliser, shared by the CPU reference and the host
// side of the Vulkan path. shaders/voxelise_fixed_raster.glsl mirrors it line for line: keep them in step.
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

// The columns a small triangle covers, exactly (column_crossing's test), found 8 lanes at a time
// for the Vulkan path's planner: bit r << stride_log2 | c is column (x0 + c, y0 + r) of its box,
// whose width rounded up to a power of two is the row stride. For boxes at most kMaskColumns wide
// whose rows fill at most kMaskLanes lanes (93% of the triangles of a capsule body at 10 mm).
// Each edge value is clamped to +-2^30 at the box's corner and the steps to any lane add up to less
// than 2^29 (31 rows and 7 columns of steps below 2^23), so a 32-bit lane keeps the exact value's
// sign, with the top-left rule folded in as in the raster: covered when all three are >= 0.
// It needs AVX2 (target attribute, so the rest of the build stays portable): coverage_masks_supported
// says whether this machine has it; without it the planner finds cross-sections for every triangle.
inline constexpr int kMaskColumns = 8, kMaskLanes = 32;

// log2 of the row stride of a box `width` columns wide: its width rounded up to a power of two.
inline int mask_stride_log2(int width) { return 31 - __builtin_clz((unsigned(width - 1) << 1) | 1u); }
// A bit at the start of every row of a mask of row stride 2^stride_log2.
inline std::uint32_t mask_row_starts(int stride_log2) {
    return stride_log2 == 0 ? 0xffffffffu : stride_log2 == 1 ? 0x55555555u : stride_log2 == 2 ? 0x11111111u : 0x01010101u;
}
inline bool fits_coverage_mask(int width, int height) {
    return width <= kMaskColumns && (height << mask_stride_log2(width)) <= kMaskLanes;
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define AMHV_TARGET_AVX2 __attribute__((target("avx2")))
inline bool coverage_masks_supported() { return __builtin_cpu_supports("avx2"); }
#else
#define AMHV_TARGET_AVX2
inline bool coverage_masks_supported() { return false; }
#endif

namespace detail {
using Lanes8 = std::int32_t __attribute__((vector_size(32)));
// Per row stride (log2) and group of 8 lanes: each lane's row, then its column.
struct MaskLanes {
    alignas(32) Lanes8 lanes[4][kMaskLanes / 8][2];
};
inline const MaskLanes kMaskLanesTable = [] {
    MaskLanes table{};
    for (int stride = 0; stride < 4; ++stride)
        for (int lane = 0; lane < kMaskLanes; ++lane) {
            table.lanes[stride][lane / 8][0][lane % 8] = lane >> stride;
            table.lanes[stride][lane / 8][1][lane % 8] = lane & ((1 << stride) - 1);
        }
    return table;
}();

// 1 in bit i where lane i is negative.
AMHV_TARGET_AVX2 inline std::uint32_t negative_lanes(Lanes8 value) {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
    using Floats8 = float __attribute__((vector_size(32)));
    return std::uint32_t(__builtin_ia32_movmskps256((Floats8)value));
#else
    std::uint32_t bits = 0;
    for (int lane = 0; lane < 8; ++lane) bits |= value[lane] < 0 ? 1u << lane : 0u;
    return bits;
#endif
}
}  // namespace detail

// A triangle's three edge values at its box's corner column (clamped, top-left rule folded in) and
// their steps per row and per column: what coverage_mask's lanes start from.
struct MaskStart {
    std::int32_t corner[3];  // edges b->c, c->a, a->b
    std::int32_t per_row[3], per_column[3];
};

// a, b, c counter-clockwise seen from above (Oriented's order); the box's corner column (x0, y0).
inline MaskStart mask_start(Point2 a, Point2 b, Point2 c, int x0, int y0) {
    const Point2 corner{std::int32_t(x0 * kSubvoxel + kSubvoxel / 2), std::int32_t(y0 * kSubvoxel + kSubvoxel / 2)};
    constexpr std::int64_t limit = std::int64_t(1) << 30;
    auto corner_value = [&](Point2 from, Point2 to) {
        return std::int32_t(std::clamp(edge_function(from, to, corner), -limit, limit)) - (is_top_left(from, to) ? 0 : 1);
    };
    // edge_function(u, v, p) grows by -(v.y - u.y) per unit of p.x and by (v.x - u.x) per unit of p.y.
    const std::int32_t S = std::int32_t(kSubvoxel);
    return {{corner_value(b, c), corner_value(c, a), corner_value(a, b)},
            {(c.x - b.x) * S, (a.x - c.x) * S, (b.x - a.x) * S},
            {(b.y - c.y) * S, (c.y - a.y) * S, (a.y - b.y) * S}};
}

// The covered columns of a box `width` x `height` (fits_coverage_mask) from its MaskStart.
AMHV_TARGET_AVX2 inline std::uint32_t coverage_mask(const MaskStart& start, int width, int height) {
    const int stride = mask_stride_log2(width);
    const int lanes = height << stride;
    std::uint32_t outside = 0;
    for (int group = 0; group < (lanes + 7) / 8; ++group) {
        const detail::Lanes8 row = detail::kMaskLanesTable.lanes[stride][group][0], column = detail::kMaskLanesTable.lanes[stride][group][1];
        const detail::Lanes8 value = (row * start.per_row[0] + column * start.per_column[0] + start.corner[0]) |
                                     (row * start.per_row[1] + column * start.per_column[1] + start.corner[1]) |
                                     (row * start.per_row[2] + column * start.per_column[2] + start.corner[2]);
        outside |= detail::negative_lanes(value) << (8 * group);
    }
    // Only the lanes of the box's rows and columns.
    const std::uint32_t rows = std::uint32_t((std::uint64_t(1) << lanes) - 1u);
    return ~outside & rows & (mask_row_starts(stride) * ((1u << width) - 1u));
}

// a, b, c counter-clockwise seen from above (Oriented's order); the box's corner column (x0, y0),
// its width and height with fits_coverage_mask.
AMHV_TARGET_AVX2 inline std::uint32_t coverage_mask(Point2 a, Point2 b, Point2 c, int x0, int y0, int width, int height) {
    return coverage_mask(mask_start(a, b, c, x0, y0), width, height);
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
