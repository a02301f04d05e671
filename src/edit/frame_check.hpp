#pragma once
// The check of every output frame of the edited scene (docs/method.md section 8a): both performers'
// whole bodies, moved into the scene, voxelised as solids on one grid of the scene's voxel by the
// chosen backend (Vulkan, or the plain CPU reference: identical volumes), and the voxels inside
// both counted. The sweep certifies the key segments (their fidelity parts never share a voxel);
// this check covers the transitional segments, where the path optimisation moves the performers.
#include <array>
#include <vector>

#include "src/edit/edit.hpp"
#include "src/voxelise/voxelise.hpp"

namespace amhv {

// Which frames get their gap measured. A separation round's check that finds the bodies inside
// each other is followed by another round (or the transition is stuck): its gaps are never
// reported, so once one frame overlaps the others' gaps may be left unmeasured (empty).
enum class Gaps { Every, UntilAnOverlap };

// Checks output frames `frames` of `edit` at edge `voxel`.
std::vector<FrameCheck> check_frames(const EditResult& edit, const std::vector<int>& frames, ObjectSource& a, ObjectSource& b, double voxel,
                                     Voxeliser& voxeliser, Gaps gaps = Gaps::Every);

namespace detail {
// The smallest distance, in voxels, between a voxel centre of `boundary_a` and one of `boundary_b`
// (voxel coordinates of two bodies that share no voxel), among the voxels within the check's reach
// of the other body's box; infinity when there are none. Exposed for its test against brute force.
double nearest_voxels(const VoxelGrid& grid, const std::vector<std::array<double, 3>>& boundary_a,
                      const std::vector<std::array<double, 3>>& boundary_b, const Box3& box_a, const Box3& box_b);
}  // namespace detail

}  // namespace amhv
