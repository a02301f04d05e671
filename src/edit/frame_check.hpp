#pragma once
// The check of every output frame of the edited scene (docs/method.md section 8a): both performers'
// whole bodies, moved into the scene, voxelised as solids on one grid of the scene's voxel by the
// chosen backend (Vulkan, or the plain CPU reference: identical volumes), and the voxels inside
// both counted. The sweep certifies the key segments (their fidelity parts never share a voxel);
// this check covers the transitional segments, where the path optimisation moves the performers.
#include <vector>

#include "src/edit/edit.hpp"
#include "src/voxelise/voxelise.hpp"

namespace amhv {

// Checks output frames `frames` of `edit` at edge `voxel`.
std::vector<FrameCheck> check_frames(const EditResult& edit, const std::vector<int>& frames, ObjectSource& a, ObjectSource& b, double voxel,
                                     Voxeliser& voxeliser);

}  // namespace amhv
