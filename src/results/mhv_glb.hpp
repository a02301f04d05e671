#pragma once
// mhv.glb (`amhv mhv --glb`): the surface of an aMHV's occupied voxels, each voxel coloured by the
// last frame it is occupied in (t_end, blue to red as in the EXR slices and the paper's Fig. 3), for
// a quick 3D look in any glTF viewer. Only the faces between an occupied and an empty voxel are
// written; glTF's y-up axes, metres.
#include <cstdint>
#include <filesystem>

#include "src/core/amhv.hpp"

namespace amhv {

struct MhvGlbReport {
    std::uint64_t faces = 0;  // voxel faces on the surface
    std::uint64_t bytes = 0;
};

// Writes `path`; refuses, before building anything, a surface of more than kMaxMhvGlbFaces faces.
inline constexpr std::uint64_t kMaxMhvGlbFaces = 20'000'000;
MhvGlbReport write_mhv_glb(const Amhv& volume, const std::filesystem::path& path);

}  // namespace amhv
