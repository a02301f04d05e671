#pragma once
// OpenVDB export for Blender and Houdini: float grids `density` (occupied-frame fraction),
// `t_start` and `t_end` (frames), voxel centres at origin + (i + 1/2) h.
#include <filesystem>

#include "src/core/amhv.hpp"

namespace amhv {

void write_vdb(const Amhv& volume, const std::filesystem::path& path);

}  // namespace amhv
