#pragma once
// The solid voxeliser on Vulkan compute. Per batch of frames (at most one 32-frame occupancy word):
//   the host         gives every bucket (voxel column, frame) a stretch of one key list, with room
//                    for one key per triangle of that frame that may cover the column (a small
//                    triangle's covered columns exactly, fixed::coverage_mask; a larger one's row
//                    spans, its cross-sections with the rows' centre lines, fixed::CrossSections),
//                    and sends each frame's work items in classes of about equally many covered
//                    columns, so that a subgroup's lanes take their slots together;
//   voxelise_raster.comp writes each crossing's layer and direction into its bucket's next slot;
//   voxelise_columns.comp sorts each bucket, flips the frame's bit wherever its winding number
//                    switches between zero and non-zero, and runs an XOR up each column over the
//                    flips: the occupancy words. Four stages sort buckets by size (in registers
//                    up to 8, 16 and 32 keys, in the key list beyond), a fifth writes.
// Within a column window (VoxelisationInput::window) the volume, the buckets and the host's rooms
// are the window's columns alone: the host clips the planned work items to the window (all-zero
// items, which the raster passes over, keep the classes' places of those it left out), and the
// raster counts its buckets from the window's corner; no kernel sees the other columns.
// GPU work scales with crossings and with the layers a column spans, not with frames x layers.
// Lavapipe runs a storage-buffer access or an atomic as a loop over the lanes, taken or not, and a
// texel fetch as one gather; so read-only inputs are texel views, and buffer accesses sit outside
// branches where the lanes differ.
#include <array>
#include <cstdint>
#include <memory>

#include "src/voxelise/voxelise.hpp"
#include "src/gpu/compute.hpp"

namespace amhv::gpu {

struct VoxeliserOptions {
    // Largest single storage buffer to use; 0 = the device's maxStorageBufferRange capped at 256 MiB.
    // Tests set it small to force slab and batch splitting.
    std::uint64_t max_buffer_bytes = 0;
    // Most crossings one column may have in one batch (voxelise_columns.comp's sorts stay under
    // lavapipe's loop cap); a batch with more is redone with fewer frames, and a single frame with
    // more is an error naming it. Tests lower it.
    std::uint32_t max_column_crossings = 1024;
    // Write the mask straight into the aMHV's memory where the device works in host memory and
    // can import it (VK_EXT_external_memory_host); false: a scratch mask copied in. Tests use both.
    bool write_in_place = true;
    // Plan small triangles' columns as exact coverage masks (fixed::coverage_mask) where the host
    // has AVX2; false: cross-sections for every triangle, as on hosts without it. Tests use both.
    bool coverage_masks = true;
    // Scratch (device buffers, then host lists) kept between calls while it stays under this in
    // all; a Voxeliser::ScratchHold keeps it whatever its size until the hold ends. Tests lower it.
    std::uint64_t kept_bytes = std::uint64_t(512) << 20;
};

class VulkanVoxeliser final : public Voxeliser {
public:
    explicit VulkanVoxeliser(Context& context, VoxeliserOptions options = {});
    ~VulkanVoxeliser() override;
    std::string name() const override;
    void voxelise_solid(const VoxelisationInput& input, Amhv& out) override;

    // How the last call split the work, for tests and reports.
    struct Plan {
        int frames_per_batch = 0;
        int slab_layers = 0;
        int slabs = 0;
        int batches = 0;
        int overflow_retries = 0;         // batches redone with fewer frames: a column had too many crossings
        bool writes_in_place = false;     // the mask went straight into the aMHV
        std::uint64_t work_items = 0;
        std::uint64_t key_capacity = 0;   // crossing keys the largest batch may write (an upper bound)
    };
    const Plan& last_plan() const { return plan_; }
    // The bytes of the device buffers kept for the next call.
    std::uint64_t scratch_bytes() const;

    static constexpr int kWorkgroup = 64;
    static constexpr std::uint32_t kLargeKeys = 32;    // voxelise_columns.comp's LARGE_KEYS
    static constexpr std::uint64_t kKeyPadding = kLargeKeys;
    // Layers per slab at most: with its sorts (about 12k iterations for 1024 crossings)
    // voxelise_columns.comp stays under half lavapipe's silent loop cap of about 65k.
    static constexpr int kMaxSlabLayers = 16384;

private:
    class Call;  // one call of voxelise_solid, as named steps
    // Buffers, then host lists, beyond options_.kept_bytes go back.
    void release_scratch_over_limit() override;
    // `kernels`: kernel_specs(options), built.
    VulkanVoxeliser(Context& context, VoxeliserOptions options, std::vector<Kernel> kernels);
    static std::vector<KernelSpec> kernel_specs(const VoxeliserOptions& options);
    Context& context_;
    VoxeliserOptions options_;
    Kernel raster_;
    Kernel flip_small_;     // voxelise_columns.comp, stage FLIP_SMALL
    Kernel flip_medium_;    // voxelise_columns.comp, stage FLIP_MEDIUM
    Kernel flip_large_;     // voxelise_columns.comp, stage FLIP_LARGE
    Kernel flip_huge_;      // voxelise_columns.comp, stage FLIP_HUGE
    Kernel write_columns_;  // voxelise_columns.comp, stage WRITE
    Plan plan_;
    struct Buffers {
        std::unique_ptr<Buffer> mask, toggles, bucket_start, bucket_cursor, keys, overflow, column_frames, spans, large_buckets, huge_buckets, lists;
        std::unique_ptr<Buffer> medium_buckets, work_items;
        // Every buffer (const or not, as the Buffers are).
        template <typename Self>
        static auto all_of(Self& b) {
            return std::array{&b.mask,          &b.toggles,       &b.bucket_start, &b.bucket_cursor, &b.keys,           &b.overflow,  &b.column_frames,
                              &b.spans,         &b.large_buckets, &b.huge_buckets, &b.lists,         &b.medium_buckets, &b.work_items};
        }
        auto all() { return all_of(*this); }
        auto all() const { return all_of(*this); }
    };
    Buffers buffers_;
    // The host's lists (each frame's plan, the bucket rooms), kept between calls like the buffers:
    // freeing them let glibc hand their pages back and fault them in again on the next call.
    struct HostScratch;
    std::unique_ptr<HostScratch> host_;
};

}  // namespace amhv::gpu
