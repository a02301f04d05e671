#include "src/core/grid.hpp"

#include <cmath>

#include "src/core/error.hpp"

namespace amhv {

VoxelGrid grid_covering(const Box3& bounds, double voxel, const std::string& what) {
    if (!(voxel > 0.0) || !std::isfinite(voxel)) fail(what, "voxel size must be a positive number, got {}", voxel);
    if (bounds.empty()) fail(what, "nothing to voxelise (empty bounding box)");
    VoxelGrid grid;
    grid.voxel = voxel;
    static constexpr const char* kAxis = "xyz";
    for (int axis = 0; axis < 3; ++axis) {
        double first = std::floor(bounds.min[axis] / voxel) - 1.0;
        double last = std::floor(bounds.max[axis] / voxel) + 1.0;
        double count = last - first + 1.0;
        if (count > kMaxGridAxis)
            fail(what, "the grid would be {:.0f} voxels along {} ({:.3f} m at {} m voxels); at most {} are supported: "
                 "use a larger voxel or a shorter segment",
                 count, kAxis[axis], bounds.max[axis] - bounds.min[axis], voxel, kMaxGridAxis);
        grid.origin[axis] = first * voxel;
        grid.dims[axis] = static_cast<int>(count);
    }
    return grid;
}

}  // namespace amhv
