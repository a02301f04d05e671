#pragma once
// The Vulkan voxeliser's planner, on the host: for every triangle of a closed frame, the columns it
// may cover (a small one's exactly, as a coverage mask; a larger one's row spans) and the work items
// the raster gets for it, counted per class. Its plans give every bucket its room in the key list.
#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "src/core/grid.hpp"
#include "src/core/uninitialised_allocator.hpp"
#include "src/voxelise/fixed_raster.hpp"
#include "src/voxelise/voxelise.hpp"

namespace amhv::planner {

// A triangle with spans goes to the raster as runs: a row's span, in pieces of up to kRunColumns
// columns, each a work item.
constexpr int kRunColumns = 64;

// One row of a triangle's columns (first > last: none).
struct RowSpan {
    std::uint16_t first, last;
};
static_assert(kMaxGridAxis <= 65536, "column indices fit 16 bits");

// A triangle of a closed frame that covers a column centre, with the columns it may cover and their
// box: a small one's covered columns exactly (fixed::coverage_mask, 93% of them at 10 mm), a larger
// one's rows' spans of columns (each row's cross-section, fixed::CrossSections, which may hold a
// column more where a centre lies on an edge). A bucket's room is the crossables whose mask or
// spans hold its column; the raster takes a mask's columns as they are and tests a span's. Found
// once per call, while planning; the batches' gathering reads them back.
struct Crossable {
    std::uint32_t triangle;  // index in the frame
    // With a mask stride: the coverage mask from the box's corner (x0, y0; rows y0..y1 hold its
    // bits). Else the index of row y0's span in the frame's list; rows y0..y1 follow.
    std::uint32_t coverage;
    std::uint16_t x0, x1, y0, y1;
    std::uint32_t covered;     // the columns its mask or spans hold
    std::uint8_t mask_stride;  // log2 of the mask's row stride, or kSpans
};
constexpr std::uint8_t kSpans = 0xff;

// The raster's slot loop runs as long as its subgroup's most covered lane, so a frame's work items
// go out in classes of equally many covered columns (up to kClassColumns - 1): a masked triangle's,
// or a run's columns. Masked triangles go apart from the runs of those with spans (a subgroup that
// mixes them runs both ways).
constexpr std::uint32_t kClassColumns = 64, kItemClasses = 2 * kClassColumns;
// The class of a work item of a crossable with `covered` columns: the planner counts each class's
// items by it and the gathering places them by it, so the two must agree.
inline std::uint32_t item_class(const Crossable& crossable, std::uint32_t covered) {
    return std::min(covered, kClassColumns - 1) + (crossable.mask_stride == kSpans ? kClassColumns : 0);
}

// The work items of a row span [first, last] of a crossable with spans: visit(first column, columns).
template <class Visit>
void for_each_run(int first, int last, Visit&& visit) {
    for (int x = first; x <= last; x += kRunColumns) visit(x, std::min(kRunColumns, last - x + 1));
}

struct FramePlan {
    std::vector<Crossable, UninitialisedAllocator<Crossable>> crossables;
    std::vector<RowSpan, UninitialisedAllocator<RowSpan>> rows;
    std::uint64_t keys = 0;   // the masks' and spans' columns: an upper bound on the frame's crossings
    std::uint64_t items = 0;  // raster work items: one per masked crossable, and the runs
    std::array<std::uint32_t, kItemClasses> class_items{};  // work items per class

    // Empty, with the lists' capacity kept for the next frame.
    void clear() {
        crossables.clear();
        rows.clear();
        keys = items = 0;
        class_items = {};
    }
};

// The coverage mask's row r (bits from the box's first column), for a mask of row stride 2^stride.
inline std::uint32_t mask_row(std::uint32_t mask, int stride, int r) { return (mask >> (r << stride)) & ((1u << (1 << stride)) - 1u); }

// Calls visit(y, first, last) for each row of a crossable that holds columns.
template <class Visit>
void for_each_span(const Crossable& c, const std::vector<RowSpan, UninitialisedAllocator<RowSpan>>& rows, Visit&& visit) {
    if (c.mask_stride != kSpans) {
        const int stride = c.mask_stride;
        for (int y = c.y0; y <= c.y1; ++y) {
            const std::uint32_t bits = mask_row(c.coverage, stride, y - c.y0);
            if (bits != 0) visit(y, c.x0 + __builtin_ctz(bits), c.x0 + 31 - __builtin_clz(bits));
        }
        return;
    }
    const RowSpan* span = rows.data() + c.coverage;
    for (int y = c.y0; y <= c.y1; ++y, ++span)
        if (span->first <= span->last) visit(y, int(span->first), int(span->last));
}

// A frame's plan, small triangles as coverage masks (the host needs AVX2: fixed::coverage_masks_supported).
AMHV_TARGET_AVX2 void plan_frame_with_masks(const PreparedFrame& frame, int nx, int ny, FramePlan& plan);
// A frame's plan with row spans for every triangle.
void plan_frame_with_spans(const PreparedFrame& frame, int nx, int ny, FramePlan& plan);

}  // namespace amhv::planner
