#pragma once
// The plain CPU reference of the solid voxelisation kernels: the definition of docs/method.md section 3
// written out directly. For every voxel, the winding number is the sum of the signed crossings of
// the surface strictly below its centre on the vertical line through it; the voxel is occupied
// when that sum is non-zero. Single-threaded and obviously correct rather than fast.
#include "src/voxelise/voxelise.hpp"

namespace amhv {

class ReferenceVoxeliser final : public Voxeliser {
public:
    std::string name() const override { return "cpu-reference"; }
    void voxelise_solid(const VoxelisationInput& input, Amhv& out) override;
};

}  // namespace amhv
