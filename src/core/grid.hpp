#pragma once
#include <array>
#include <cmath>
#include <cstdint>
#include <cstddef>

#include "src/core/geometry.hpp"

namespace amhv {

// Largest grid extent along one axis. It keeps every fixed-point product of the exact rasteriser
// inside 64 bits (see fixed_raster.hpp).
inline constexpr int kMaxGridAxis = 2048;

// An axis-aligned voxel grid in an object's capture frame. The origin is a multiple of the voxel
// edge, so grids of the same edge built from different segments share one lattice.
struct VoxelGrid {
    double voxel = 0.01;
    Vec3 origin = Vec3::Zero();  // corner of voxel (0, 0, 0)
    std::array<int, 3> dims{0, 0, 0};

    std::size_t voxel_count() const { return std::size_t(dims[0]) * dims[1] * dims[2]; }
    std::size_t index(int x, int y, int z) const { return (std::size_t(z) * dims[1] + y) * dims[0] + x; }
    Vec3 centre(int x, int y, int z) const {
        return origin + voxel * Vec3(x + 0.5, y + 0.5, z + 0.5);
    }
    // Global lattice index of voxel (0, 0, 0): origin / voxel, a whole number by construction.
    std::array<std::int64_t, 3> lattice_origin() const {
        return {std::llround(origin.x() / voxel), std::llround(origin.y() / voxel), std::llround(origin.z() / voxel)};
    }
};

// The grid covering `bounds` plus a one-voxel margin. Throws amhv::Error naming `what` when the
// grid would exceed kMaxGridAxis along an axis or the edge is not positive and finite.
VoxelGrid grid_covering(const Box3& bounds, double voxel, const std::string& what);

}  // namespace amhv
