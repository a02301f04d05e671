#include "src/voxelise/coverage_starts.hpp"

#include <algorithm>
#include <cstring>

namespace amhv::fixed {

namespace {
using Ints8 = std::int32_t __attribute__((vector_size(32)));
using Ints4 = std::int32_t __attribute__((vector_size(16)));
using Doubles4 = double __attribute__((vector_size(32)));
struct Halves {
    Doubles4 low, high;
};

AMHV_TARGET_AVX2 inline Halves halves(Ints8 v) {
    return {__builtin_convertvector(Ints4{v[0], v[1], v[2], v[3]}, Doubles4), __builtin_convertvector(Ints4{v[4], v[5], v[6], v[7]}, Doubles4)};
}
// (v - u) x (p - u), exactly, as double halves.
AMHV_TARGET_AVX2 inline Halves edge(Ints8 ux, Ints8 uy, Ints8 vx, Ints8 vy, Ints8 px, Ints8 py) {
    const Halves dx = halves(vx - ux), dy = halves(vy - uy), qx = halves(px - ux), qy = halves(py - uy);
    return {dx.low * qy.low - dy.low * qx.low, dx.high * qy.high - dy.high * qx.high};
}
// A lane-wise condition on double halves (64-bit -1 or 0) as 32-bit lanes.
template <class Condition>
AMHV_TARGET_AVX2 inline Ints8 pack(Condition low, Condition high) {
    return __builtin_shufflevector((Ints8)low, (Ints8)high, 0, 2, 4, 6, 8, 10, 12, 14);
}
AMHV_TARGET_AVX2 inline Ints8 select(Ints8 condition, Ints8 yes, Ints8 no) { return (yes & condition) | (no & ~condition); }
AMHV_TARGET_AVX2 inline Ints8 min8(Ints8 a, Ints8 b) { return a < b ? a : b; }
AMHV_TARGET_AVX2 inline Ints8 max8(Ints8 a, Ints8 b) { return a > b ? a : b; }
// mask_start's corner value of edge u -> v at p: clamped to +-2^30, less 1 unless top-left.
AMHV_TARGET_AVX2 inline Ints8 corner_value(Ints8 ux, Ints8 uy, Ints8 vx, Ints8 vy, Ints8 px, Ints8 py) {
    constexpr double limit = double(std::int64_t(1) << 30);
    const Halves value = edge(ux, uy, vx, vy, px, py);
    const Doubles4 low = value.low < -limit ? -limit : value.low > limit ? limit : value.low;
    const Doubles4 high = value.high < -limit ? -limit : value.high > limit ? limit : value.high;
    const Ints8 clamped = __builtin_shufflevector(__builtin_convertvector(low, Ints4), __builtin_convertvector(high, Ints4), 0, 1, 2, 3, 4, 5, 6, 7);
    const Ints8 top_left = (vy - uy < 0) | ((vy - uy == 0) & (vx - ux < 0));  // -1 where top-left
    return clamped - (top_left + 1);                                          // less 1 where not
}
}  // namespace

AMHV_TARGET_AVX2 void find_starts(std::span<const Triangle> triangles, int nx, int ny, TriangleStarts& out) {
    const std::size_t count = triangles.size(), padded = (count + 7) / 8 * 8;
    for (auto* field : {&out.x0, &out.x1, &out.y0, &out.y1, &out.kind}) field->resize(padded);
    for (int e = 0; e < 3; ++e)
        for (auto* field : {&out.corner[e], &out.per_row[e], &out.per_column[e]}) field->resize(padded);
    if (count == 0) return;
    static_assert(sizeof(Triangle) == 9 * sizeof(std::int32_t));
    const std::int32_t* coordinates = &triangles[0][0].x;
    const std::int32_t S = std::int32_t(kSubvoxel), half = S / 2;
    for (std::size_t first = 0; first < padded; first += 8) {
        // Lanes past the end repeat the last triangle; their fields are never read. Copied lane by
        // lane: AVX2's gathers cost more here than the scalar loads.
        alignas(32) std::int32_t soa[6][8];  // a.x, a.y, b.x, b.y, c.x, c.y
        for (int lane = 0; lane < 8; ++lane) {
            const std::int32_t* t = coordinates + std::min(first + std::size_t(lane), count - 1) * 9;
            soa[0][lane] = t[0], soa[1][lane] = t[1], soa[2][lane] = t[3], soa[3][lane] = t[4], soa[4][lane] = t[6], soa[5][lane] = t[7];
        }
        Ints8 vertex[6];
        std::memcpy(vertex, soa, sizeof soa);
        const Ints8 ax = vertex[0], ay = vertex[1];
        const Halves area = edge(ax, ay, vertex[2], vertex[3], vertex[4], vertex[5]);
        // Counter-clockwise seen from above.
        const Ints8 flip = pack(area.low < 0, area.high < 0), flat = pack(area.low == 0, area.high == 0);
        const Ints8 bx = select(flip, vertex[4], vertex[2]), by = select(flip, vertex[5], vertex[3]);
        const Ints8 cx = select(flip, vertex[2], vertex[4]), cy = select(flip, vertex[3], vertex[5]);
        // centre_range of the bounding box, inside the grid.
        const Ints8 x0 = max8(-((half - min8(ax, min8(bx, cx))) >> 6), Ints8{} + 0);
        const Ints8 x1 = min8((max8(ax, max8(bx, cx)) - half) >> 6, Ints8{} + (nx - 1));
        const Ints8 y0 = max8(-((half - min8(ay, min8(by, cy))) >> 6), Ints8{} + 0);
        const Ints8 y1 = min8((max8(ay, max8(by, cy)) - half) >> 6, Ints8{} + (ny - 1));
        const Ints8 width = x1 - x0 + 1, height = y1 - y0 + 1;
        const Ints8 valid = ~flat & (x0 <= x1) & (y0 <= y1);
        const Ints8 stride = -((width > 1) + (width > 2) + (width > 4));  // mask_stride_log2
        const Ints8 fits = valid & (width <= kMaskColumns) & ((height << stride) <= kMaskLanes);
        const Ints8 kind = select(valid, select(fits, Ints8{} + TriangleStarts::kMasked, Ints8{} + TriangleStarts::kSpanned),
                                  Ints8{} + TriangleStarts::kSkipped);
        // mask_start at the box's corner column.
        const Ints8 px = x0 * S + half, py = y0 * S + half;
        const Ints8 fields[14] = {x0,
                                  x1,
                                  y0,
                                  y1,
                                  kind,
                                  corner_value(bx, by, cx, cy, px, py),
                                  corner_value(cx, cy, ax, ay, px, py),
                                  corner_value(ax, ay, bx, by, px, py),
                                  (cx - bx) * S,
                                  (ax - cx) * S,
                                  (bx - ax) * S,
                                  (by - cy) * S,
                                  (cy - ay) * S,
                                  (ay - by) * S};
        TriangleStarts::Ints* outputs[14] = {&out.x0,         &out.x1,         &out.y0,         &out.y1,           &out.kind,
                                             &out.corner[0],  &out.corner[1],  &out.corner[2],  &out.per_row[0],   &out.per_row[1],
                                             &out.per_row[2], &out.per_column[0], &out.per_column[1], &out.per_column[2]};
        for (int f = 0; f < 14; ++f) std::memcpy(outputs[f]->data() + first, &fields[f], sizeof(Ints8));
    }
}

}  // namespace amhv::fixed
