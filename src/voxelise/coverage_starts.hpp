#pragma once
// The Vulkan path's planner's first look at each triangle of a frame, 8 triangles at a time (AVX2):
// its column box, whether a coverage mask fits it, and the mask's start, exactly as
// fixed::centre_range, fits_coverage_mask and mask_start find them one by one (the edge values in
// double precision, where every product of two coordinate differences, below 2^18, is exact).
#include <cstdint>
#include <span>
#include <vector>

#include "src/voxelise/fixed_raster.hpp"
#include "src/core/uninitialised_allocator.hpp"

namespace amhv::fixed {

// One array per field, as the lanes write them: the planner reads triangle i's fields at [i].
// Lists keep their capacity between frames; new places are not zeroed (every one is written).
struct TriangleStarts {
    using Ints = std::vector<std::int32_t, UninitialisedAllocator<std::int32_t>>;
    // The columns whose centres its bounding box holds, inside the grid.
    Ints x0, x1, y0, y1;
    // kSkipped: seen edge-on from above, or no column centre in its box; kMasked: the box fits a
    // coverage mask, whose start the other fields hold (MaskStart's); kSpanned: larger.
    Ints kind;
    Ints corner[3], per_row[3], per_column[3];
    static constexpr std::int32_t kSkipped = 0, kMasked = 1, kSpanned = 2;

    MaskStart start(std::size_t i) const {
        return {{corner[0][i], corner[1][i], corner[2][i]}, {per_row[0][i], per_row[1][i], per_row[2][i]},
                {per_column[0][i], per_column[1][i], per_column[2][i]}};
    }
};

// For a grid nx x ny columns. Needs AVX2 where coverage_masks_supported says so.
AMHV_TARGET_AVX2 void find_starts(std::span<const Triangle> triangles, int nx, int ny, TriangleStarts& out);

}  // namespace amhv::fixed
