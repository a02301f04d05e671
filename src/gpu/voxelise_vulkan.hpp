#pragma once
// The solid voxeliser on Vulkan compute (shaders/voxel_raster.comp + voxel_columns.comp).
#include <cstdint>

#include "core/voxelise.hpp"
#include "gpu/compute.hpp"

namespace amhv::gpu {

struct VoxeliserOptions {
    // Largest single storage buffer to use; 0 = the device's maxStorageBufferRange capped at 256 MiB.
    // Tests set it small to force slab and batch splitting.
    std::uint64_t max_buffer_bytes = 0;
};

class VulkanVoxeliser final : public Voxeliser {
public:
    explicit VulkanVoxeliser(Context& context, VoxeliserOptions options = {});
    std::string name() const override;
    void voxelise_solid(const VoxelisationInput& input, Amhv& out) override;

    // How the last call split the work, for tests and reports.
    struct Plan {
        int frames_per_batch = 0;
        int slab_layers = 0;
        int slabs = 0;
        int batches = 0;
        std::uint64_t work_items = 0;
    };
    const Plan& last_plan() const { return plan_; }

    static constexpr int kTile = 16;            // columns per tile side: <= 256 column tests per raster invocation
    static constexpr int kWorkgroup = 64;
    static constexpr int kColumnLoopBudget = 32768;  // per-invocation loop iterations, half lavapipe's silent cap

private:
    Context& context_;
    VoxeliserOptions options_;
    Kernel raster_;
    Kernel columns_;
    Plan plan_;
};

}  // namespace amhv::gpu
