#pragma once
// OpenVDB export for Blender and Houdini: float grids `density` (occupied-frame fraction),
// `t_start` and `t_end` (frames), voxel centres at origin + (i + 1/2) h.
#include <filesystem>
#include <string>
#include <string_view>

#include "src/core/amhv.hpp"

namespace amhv {

void write_vdb(const Amhv& volume, const std::filesystem::path& path);

// Checks the layout of an OpenVDB file (`bytes`, named `where` in messages) before OpenVDB reads
// it: OpenVDB trusts every length and count in a file and allocates what they say (a 100-byte file
// can ask for gigabytes of metadata). Accepted: file versions 222-225 written with grid offsets (as
// io::File writes them, and amhv does), at most 64 metadata entries per map of at most 1 MiB each,
// 1-4096 grids whose descriptors' strings, offsets and metadata all lie within the file, in order.
// The grids' trees are left to OpenVDB: their allocations are per node, bounded by the file's size.
void check_vdb_layout(std::string_view bytes, const std::string& where);

}  // namespace amhv
