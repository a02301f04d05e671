#pragma once
// segment_N/group.vdb: a key segment's solution group as OpenVDB BoolGrids (docs/scenes.md, "The
// solution group as a volume"). The group is a set on the sweep's own lattice: active voxel
// (i, j, k) of grid `solutions` is the pose x = i h, y = j h, theta = k step (k in [0, angles));
// with z_range, grid `solutions_z{l}` holds B raised by l voxels, one grid per height swept. Each
// grid carries voxel_m, angle_step_deg, angles, segment, z_voxels and scene_hash. A few solid
// blobs compress to megabytes where the same set as decimal text takes gigabytes.
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "src/results/result_json.hpp"
#include "src/scene/scene.hpp"
#include "src/sweep/solution_group.hpp"

namespace amhv::results {

struct GroupLattice {
    double voxel = 0.01;
    double angle_step_deg = 2;
    int angles = 180;
    int segment = 1;
    int z_first = 0, z_last = 0;
    std::string scene_hash;
};

// The lattice of key segment `segment`'s sweep.
GroupLattice group_lattice(const Scene& scene, int segment, const PoseRange& range);
// 64-bit FNV-1a of the resolved scene (resolved_toml, its inputs' paths relative to the scene's
// folder), as 16 hex digits: which scene a group is of, wherever the project folder lies.
std::string scene_hash(const Scene& scene);

// Writes the group (each solution's i, j, k, l) to `path`.
void write_group_vdb(const std::filesystem::path& path, const SolutionGroup& group, const GroupLattice& lattice);
// Reads `path` back as the group it holds. Throws amhv::Error naming the file when it is not a
// group of `expected` (another lattice, segment or scene, a missing grid, an angle off the lattice).
SolutionGroup read_group_vdb(const std::filesystem::path& path, const GroupLattice& expected);

// The lattice a group file says it is on (its grids' metadata), for readers without the scene.
// Throws amhv::Error naming the file when it is not an amhv solution group.
GroupLattice read_group_lattice(const std::filesystem::path& path);

// segment_N/group_summary.json: the count and the bounding box of x and y per angle (angles with
// members only), the heights, and the total: small for pages and scripts.
Json group_summary(const SolutionGroup& group, const GroupLattice& lattice);

}  // namespace amhv::results
