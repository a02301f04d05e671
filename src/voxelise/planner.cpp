#include "src/voxelise/planner.hpp"

#include <bit>

#include "src/voxelise/coverage_starts.hpp"

namespace amhv::planner {

// `Masks`: small triangles get coverage masks (only in plan_frame_with_masks, which is built for
// AVX2). The plan's lists keep their capacity from an earlier call.
template <bool Masks>
[[gnu::always_inline]] inline void plan_frame(const PreparedFrame& frame, int nx, int ny, FramePlan& plan) {
    plan.clear();
    // Written by index and trimmed at the end: a triangle's place is taken whether or not it is kept,
    // and a kept one advances the counts (without branches, as below).
    plan.crossables.resize(frame.triangles.size());
    plan.rows.resize(frame.triangles.size() * 3);
    std::size_t crossables = 0, rows_used = 0;
    // With Masks: find_starts's, kept by the planning thread for its next frame (released when they
    // were for more than kKeptStartTriangles).
    thread_local fixed::TriangleStarts starts;
    constexpr std::size_t kKeptStartTriangles = std::size_t(1) << 18;  // 14 MiB of fields
    if constexpr (Masks) fixed::find_starts(frame.triangles, nx, ny, starts);
    struct ReleaseStarts {
        ~ReleaseStarts() {
            if (starts.kind.capacity() > kKeptStartTriangles) starts = {};
        }
    } release_starts;
    for (std::size_t i = 0; i < frame.triangles.size(); ++i) {
        const fixed::Triangle& t = frame.triangles[i];
        int x0, x1, y0, y1;
        if constexpr (Masks) {
            if (starts.kind[i] == fixed::TriangleStarts::kSkipped) continue;
            x0 = starts.x0[i], x1 = starts.x1[i], y0 = starts.y0[i], y1 = starts.y1[i];
        } else {
            const fixed::Point2 a = t[0].xy(), b = t[1].xy(), c = t[2].xy();
            const fixed::IndexRange columns_x = fixed::centre_range(std::min({a.x, b.x, c.x}), std::max({a.x, b.x, c.x}));
            const fixed::IndexRange columns_y = fixed::centre_range(std::min({a.y, b.y, c.y}), std::max({a.y, b.y, c.y}));
            x0 = std::max(columns_x.first, 0), x1 = std::min(columns_x.last, nx - 1);
            y0 = std::max(columns_y.first, 0), y1 = std::min(columns_y.last, ny - 1);
            // Seen edge-on from above, or no column centre in its bounding box.
            if ((fixed::edge_function(a, b, c) == 0) | (x0 > x1) | (y0 > y1)) continue;
        }
        const int width = x1 - x0 + 1, height = y1 - y0 + 1;
        if (Masks && starts.kind[i] == fixed::TriangleStarts::kMasked) {
            const std::uint32_t mask = fixed::coverage_mask(starts.start(i), width, height);
            const int stride = fixed::mask_stride_log2(width);
            // The rows from the lowest to the highest bit (the mask then taken from the first), the
            // columns of the bounding box.
            const int first_row = std::countr_zero(std::uint64_t(mask) | (std::uint64_t(1) << 32)) >> stride;
            const std::uint32_t keys = std::uint32_t(__builtin_popcount(mask));
            plan.crossables[crossables] = {std::uint32_t(i),
                                           std::uint32_t(std::uint64_t(mask) >> (first_row << stride)),
                                           std::uint16_t(x0),
                                           std::uint16_t(x1),
                                           std::uint16_t(y0 + first_row),
                                           std::uint16_t(y0 + ((31 - __builtin_clz(mask | 1u)) >> stride)),
                                           keys,
                                           std::uint8_t(stride)};
            plan.keys += keys;
            crossables += keys != 0 ? 1 : 0;
            continue;
        }
        if (rows_used + std::size_t(height) > plan.rows.size())
            plan.rows.resize(std::max(plan.rows.size() * 2, rows_used + std::size_t(height)));
        RowSpan* rows = plan.rows.data() + rows_used;
        // Each row's span inside the bounding box, and the box of the non-empty ones. Without
        // branches: whether a row is empty is as good as random.
        const fixed::CrossSections sections(t, y0);
        int box_x0 = nx, box_x1 = -1, box_y0 = ny, box_y1 = -1;
        std::uint64_t keys = 0;
        for (int row = 0; row < height; ++row) {
            const fixed::IndexRange span = sections.row(row);
            const int first = std::max(span.first, x0), last = std::min(span.last, x1);
            const bool empty = first > last;
            rows[row] = empty ? RowSpan{1, 0} : RowSpan{std::uint16_t(first), std::uint16_t(last)};
            keys += empty ? 0u : std::uint64_t(last - first + 1);
            box_x0 = empty ? box_x0 : std::min(box_x0, first);
            box_x1 = empty ? box_x1 : std::max(box_x1, last);
            box_y0 = empty ? box_y0 : std::min(box_y0, y0 + row);
            box_y1 = empty ? box_y1 : y0 + row;
        }
        // Kept when it covers a column centre: its rows from the first to the last non-empty one.
        const bool kept = keys != 0;
        plan.crossables[crossables] = {std::uint32_t(i), std::uint32_t(rows_used + std::size_t(std::max(box_y0 - y0, 0))),
                                       std::uint16_t(box_x0), std::uint16_t(box_x1), std::uint16_t(box_y0), std::uint16_t(box_y1),
                                       std::uint32_t(keys), kSpans};
        plan.keys += keys;
        crossables += kept ? 1 : 0;
        rows_used += kept ? std::size_t(box_y1 - y0 + 1) : 0;
    }
    plan.crossables.resize(crossables);
    plan.rows.resize(rows_used);
    for (const Crossable& crossable : plan.crossables) {
        if (crossable.mask_stride == kSpans) {
            for_each_span(crossable, plan.rows, [&](int, int first, int last) {
                for_each_run(first, last, [&](int, int columns) { ++plan.class_items[item_class(crossable, std::uint32_t(columns))]; });
            });
            continue;
        }
        ++plan.class_items[item_class(crossable, crossable.covered)];
    }
    for (const std::uint32_t items : plan.class_items) plan.items += items;
}

AMHV_TARGET_AVX2 void plan_frame_with_masks(const PreparedFrame& frame, int nx, int ny, FramePlan& plan) {
    plan_frame<true>(frame, nx, ny, plan);
}
void plan_frame_with_spans(const PreparedFrame& frame, int nx, int ny, FramePlan& plan) {
    plan_frame<false>(frame, nx, ny, plan);
}

}  // namespace amhv::planner
