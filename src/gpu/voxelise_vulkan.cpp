#include "gpu/voxelise_vulkan.hpp"

#include <algorithm>
#include <cstring>
#include <memory>

#include "core/error.hpp"
#include "voxel_columns.spv.h"
#include "voxel_raster.spv.h"

namespace amhv::gpu {

namespace {

struct GpuTriangle {
    std::int32_t a[4], b[4], c[4];  // xyz fixed point; a[3] = frame slot in the batch
};
static_assert(sizeof(GpuTriangle) == 48);

struct RasterParams {
    std::uint32_t work_base, work_count;
    std::int32_t nx, ny, z_begin, slab_layers;
};
struct ColumnParams {
    std::uint32_t column_base, column_count;
    std::int32_t nx, ny, slab_layers, frames, bit_offset, padding;
};

}  // namespace

VulkanVoxeliser::VulkanVoxeliser(Context& context, VoxeliserOptions options)
    : context_(context),
      options_(options),
      raster_(context, voxel_raster_spv, 5, sizeof(RasterParams), {kWorkgroup, kTile}),
      columns_(context, voxel_columns_spv, 4, sizeof(ColumnParams), {kWorkgroup}) {}

std::string VulkanVoxeliser::name() const { return "vulkan:" + context_.selected().name; }

void VulkanVoxeliser::voxelise_solid(const VoxelisationInput& input, Amhv& out) {
    const auto& grid = input.grid;
    const int nx = grid.dims[0], ny = grid.dims[1], nz = grid.dims[2];
    const int frames = int(input.frames.size());
    const std::uint64_t layer_bytes = std::uint64_t(nx) * ny * 4;

    std::uint64_t budget = options_.max_buffer_bytes;
    if (budget == 0) {
        budget = std::min<std::uint64_t>(context_.selected().max_storage_buffer_range, 256ull << 20);
        if (context_.selected().max_allocation_size) budget = std::min<std::uint64_t>(budget, context_.selected().max_allocation_size);
    }
    if (layer_bytes > budget)
        throw Error(fmt::format("one {}x{} layer of the grid needs {:.1f} MiB, more than the {:.1f} MiB storage buffer limit",
                                nx, ny, double(layer_bytes) / (1 << 20), double(budget) / (1 << 20)));

    // Split: z into slabs as tall as one buffer allows (usually the whole grid, so every frame is
    // rasterised once), then as many frames per batch as the delta volume can hold (at most one
    // occupancy word, and few enough that the column loop stays under the loop budget).
    plan_ = {};
    plan_.slab_layers = int(std::min<std::uint64_t>(
        {std::uint64_t(nz), budget / layer_bytes, std::uint64_t(kColumnLoopBudget / 2)}));
    plan_.frames_per_batch = int(std::min<std::uint64_t>(
        {32, std::uint64_t(frames), budget / (layer_bytes * plan_.slab_layers),
         std::uint64_t(kColumnLoopBudget / plan_.slab_layers - 1)}));
    plan_.frames_per_batch = std::max(plan_.frames_per_batch, 1);
    plan_.slabs = (nz + plan_.slab_layers - 1) / plan_.slab_layers;

    Buffer deltas(context_, layer_bytes * plan_.slab_layers * plan_.frames_per_batch, Buffer::Memory::Device);
    Buffer mask(context_, layer_bytes * plan_.slab_layers, Buffer::Memory::Host);
    Buffer first_layer(context_, layer_bytes, Buffer::Memory::Device);
    Buffer last_layer(context_, layer_bytes, Buffer::Memory::Device);
    std::unique_ptr<Buffer> triangles, work_items;
    Sequence sequence(context_);
    const std::uint32_t columns = std::uint32_t(nx) * std::uint32_t(ny);
    // Cleared once: afterwards the column pass resets every delta and range marker it consumed.
    sequence.fill(deltas, deltas.size(), 0u);
    sequence.fill(first_layer, first_layer.size(), 0x7fffffffu);
    sequence.fill(last_layer, last_layer.size(), 0xffffffffu);

    // Host side of a batch: its triangles and one work item per (triangle, covered tile).
    std::vector<GpuTriangle> batch_triangles;
    std::vector<std::uint32_t> batch_items;  // pairs (triangle, tile x | tile y << 16)
    auto gather = [&](int batch_first, int batch_frames) {
        batch_triangles.clear();
        batch_items.clear();
        for (int slot = 0; slot < batch_frames; ++slot) {
            const PreparedFrame& frame = input.frames[std::size_t(batch_first + slot)];
            if (!frame.closed) continue;  // the host's surface rule handles it
            for (const auto& t : frame.triangles) {
                fixed::Oriented oriented;
                if (!fixed::orient(t, oriented)) continue;
                int x0 = std::max(oriented.columns_x.first, 0), x1 = std::min(oriented.columns_x.last, nx - 1);
                int y0 = std::max(oriented.columns_y.first, 0), y1 = std::min(oriented.columns_y.last, ny - 1);
                if (x0 > x1 || y0 > y1) continue;  // covers no column centre
                auto index = std::uint32_t(batch_triangles.size());
                batch_triangles.push_back({{t[0].x, t[0].y, t[0].z, slot}, {t[1].x, t[1].y, t[1].z, 0}, {t[2].x, t[2].y, t[2].z, 0}});
                for (int ty = y0 / kTile; ty <= y1 / kTile; ++ty)
                    for (int tx = x0 / kTile; tx <= x1 / kTile; ++tx) {
                        batch_items.push_back(index);
                        batch_items.push_back(std::uint32_t(tx) | (std::uint32_t(ty) << 16));
                    }
            }
        }
    };

    for (int word = 0; word < out.words(); ++word) {
        const int word_first = word * 32;
        const int word_last = std::min(frames, word_first + 32);
        for (int z_begin = 0; z_begin < nz; z_begin += plan_.slab_layers) {
            const int slab_layers = std::min(plan_.slab_layers, nz - z_begin);
            // The word's bits accumulate in `mask` over its batches; it is cleared once per slab.
            sequence.fill(mask, layer_bytes * slab_layers, 0u);
            bool any_work = false;
            for (int batch_first = word_first; batch_first < word_last; batch_first += plan_.frames_per_batch) {
                const int batch_frames = std::min(plan_.frames_per_batch, word_last - batch_first);
                gather(batch_first, batch_frames);
                ++plan_.batches;
                plan_.work_items += batch_items.size() / 2;
                if (batch_items.empty()) continue;  // no closed surface in this batch: its bits stay 0
                any_work = true;
                ensure_host_capacity(context_, triangles, batch_triangles.size() * sizeof(GpuTriangle));
                ensure_host_capacity(context_, work_items, batch_items.size() * sizeof(std::uint32_t));
                std::memcpy(triangles->mapped<GpuTriangle>().data(), batch_triangles.data(), batch_triangles.size() * sizeof(GpuTriangle));
                std::memcpy(work_items->mapped<std::uint32_t>().data(), batch_items.data(), batch_items.size() * sizeof(std::uint32_t));
                auto raster_set = raster_.bind({triangles.get(), work_items.get(), &deltas, &first_layer, &last_layer});
                auto columns_set = columns_.bind({&deltas, &mask, &first_layer, &last_layer});

                // The clears above, or the previous column pass's resets of the deltas and range
                // markers, must land before the raster kernel adds into them.
                sequence.barrier();
                sequence.dispatch(raster_, raster_set, RasterParams{0, 0, nx, ny, z_begin, slab_layers},
                                  std::uint32_t(batch_items.size() / 2));
                // Every crossing and range marker must be in place before the column pass reads them.
                sequence.barrier();
                sequence.dispatch(columns_, columns_set,
                                  ColumnParams{0, 0, nx, ny, slab_layers, batch_frames, batch_first - word_first, 0}, columns);
                // The next batch reuses the host-written triangle buffers: finish this one first.
                sequence.submit_and_wait();
            }
            if (!any_work) continue;
            // The host reads the mask right after the fence.
            sequence.barrier_to_host();
            sequence.submit_and_wait();
            const std::uint32_t* slab = mask.mapped<std::uint32_t>().data();
            std::memcpy(out.plane(word) + std::size_t(z_begin) * columns, slab, std::size_t(slab_layers) * columns * sizeof(std::uint32_t));
        }
    }
}

}  // namespace amhv::gpu
