#pragma once
// The aMHV volume file (`mhv.amhv`) that later stages read back. Little-endian, sparse: only
// occupied voxels are stored.
//
//   offset  type       field
//   0       char[8]    magic "AMHVVOL1"
//   8       u32        format version = 1
//   12      u32        frames (tau)
//   16      i32[3]     grid dimensions nx, ny, nz
//   28      u32        words per voxel W = ceil(tau / 32)
//   32      f64        voxel edge h in metres
//   40      f64[3]     grid origin (corner of voxel 0,0,0) in metres, capture frame, z up
//   64      u64        N = number of occupied voxels
//   72      N records, ascending voxel index:
//             u32      voxel index x + nx * (y + ny * z)
//             u32[W]   occupancy: bit (t % 32) of word (t / 32) is frame t
#include <filesystem>

#include "src/core/amhv.hpp"

namespace amhv {

void write_amhv(const Amhv& volume, const std::filesystem::path& path);
Amhv read_amhv(const std::filesystem::path& path);

}  // namespace amhv
