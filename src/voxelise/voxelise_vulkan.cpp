#include "src/voxelise/voxelise_vulkan.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <memory>

#include "src/voxelise/planner.hpp"
#include "src/core/error.hpp"
#include "src/core/grid.hpp"
#include "src/core/parallel.hpp"
#include "src/core/uninitialised_allocator.hpp"
#include "shaders/voxelise_columns.spv.h"
#include "shaders/voxelise_raster.spv.h"

namespace amhv::gpu {

using namespace planner;

namespace {

// One raster work item, two 128-bit texels: a triangle whose vertices take 54 bits each (x, y, z
// fixed point in 18 bits: at most kMaxGridAxis * kSubvoxel = 2^17), vertex a's spare bits holding
// the item's kind (frame slot in the batch | kMaskedTriangle | mask stride (log2) << 6); then with a
// mask, the whole triangle: the mask and its corner column x0 | y0 << 16. Else one run of it:
// run_word(...). The triangle travels with each item, so the raster reads its items in order (an
// index into a list of triangles had every subgroup's lanes miss the caches apart: the items go in
// classes), and packed: as three texels (48 bytes) it cost half as much again to write and fetch.
struct GpuItem {
    std::uint32_t a[2], b[2], c[2];
    std::uint32_t data[2];  // the mask and its corner, or the run
};
static_assert(sizeof(GpuItem) == 32);
static_assert(std::int64_t(kMaxGridAxis) * fixed::kSubvoxel < (1 << 18), "a coordinate fits 18 bits");
constexpr std::uint32_t kMaskedTriangle = 1u << 5;
// Vertex p's 54 bits as two words (x | y << 18, y >> 14 | z << 4), and 10 more bits in the second.
inline void pack_vertex(const fixed::Point3& p, std::uint32_t extra, std::uint32_t (&out)[2]) {
    const auto x = std::uint32_t(p.x), y = std::uint32_t(p.y), z = std::uint32_t(p.z);
    out[0] = x | (y << 18);
    out[1] = (y >> 14) | (z << 4) | (extra << 22);
}
inline GpuItem pack_item(const fixed::Triangle& t, std::uint32_t kind, std::uint32_t data0, std::uint32_t data1) {
    GpuItem item;
    pack_vertex(t[0], kind, item.a);
    pack_vertex(t[1], 0, item.b);
    pack_vertex(t[2], 0, item.c);
    item.data[0] = data0;
    item.data[1] = data1;
    return item;
}
// A run's work item: first column | row << 11 | (columns - 1) << 22 (planner.hpp's kRunColumns at most).
static_assert(kMaxGridAxis <= 2048 && kRunColumns <= 1024, "a run fits one word");
inline std::uint32_t run_word(int y, int first, int columns) {
    return std::uint32_t(first) | (std::uint32_t(y) << 11) | (std::uint32_t(columns - 1) << 22);
}

struct RasterParams {
    std::uint32_t work_base, work_count;
    std::int32_t nx, ny, z_begin, slab_layers, window_x0, window_y0;
};
struct ColumnParams {
    std::uint32_t column_base, column_count, columns;
    std::int32_t slab_layers, bit_offset;
    std::uint32_t whole_word, mask_base;
};


// voxelise_columns.comp's bindings: keys, bucket starts, bucket ends, overflow, flips, mask, keys
// again (as texels), frames with room per column, spans, large and huge buckets, the lists of
// larger buckets, medium buckets.
std::vector<Binding> column_bindings() {
    return {Binding::Storage, Binding::Texels32, Binding::Texels32, Binding::Storage, Binding::Storage, Binding::Storage,
            Binding::Texels128, Binding::Texels32, Binding::Storage, Binding::Storage, Binding::Storage, Binding::Storage,
            Binding::Storage};
}

}  // namespace

struct VulkanVoxeliser::HostScratch {
    std::vector<FramePlan> frame_plans;
    std::vector<std::int32_t> room_edges;
    std::uint64_t bytes() const {
        std::uint64_t total = room_edges.capacity() * sizeof(std::int32_t);
        for (const FramePlan& plan : frame_plans)
            total += plan.crossables.capacity() * sizeof(Crossable) + plan.rows.capacity() * sizeof(RowSpan);
        return total;
    }
};

VulkanVoxeliser::~VulkanVoxeliser() = default;

VulkanVoxeliser::VulkanVoxeliser(Context& context, VoxeliserOptions options)
    : VulkanVoxeliser(context, options, make_kernels(context, kernel_specs(options))) {}

// In the members' order: the raster, then voxelise_columns.comp's stages FLIP_SMALL (0),
// FLIP_MEDIUM (4), FLIP_LARGE (1), FLIP_HUGE (2) and WRITE (3).
std::vector<KernelSpec> VulkanVoxeliser::kernel_specs(const VoxeliserOptions& options) {
    std::vector<KernelSpec> specs{{voxelise_raster_spv, {Binding::Texels128, Binding::Storage, Binding::Storage}, sizeof(RasterParams), {kWorkgroup}}};
    for (const std::uint32_t stage : {0u, 4u, 1u, 2u, 3u})
        specs.push_back({voxelise_columns_spv, column_bindings(), sizeof(ColumnParams), {kWorkgroup, options.max_column_crossings, stage}});
    return specs;
}

VulkanVoxeliser::VulkanVoxeliser(Context& context, VoxeliserOptions options, std::vector<Kernel> kernels)
    : context_(context),
      options_(options),
      raster_(std::move(kernels.at(0))),
      flip_small_(std::move(kernels.at(1))),
      flip_medium_(std::move(kernels.at(2))),
      flip_large_(std::move(kernels.at(3))),
      flip_huge_(std::move(kernels.at(4))),
      write_columns_(std::move(kernels.at(5))),
      host_(std::make_unique<HostScratch>()) {}

std::string VulkanVoxeliser::name() const { return "vulkan:" + context_.selected().name; }

// One call of voxelise_solid, as named steps over its shared state.
class VulkanVoxeliser::Call {
public:
    Call(VulkanVoxeliser& voxeliser, const VoxelisationInput& input, Amhv& out);
    ~Call();
    void run();

private:
    // The batch starting at `first` (inside its word): its frames and their keys.
    struct Batch {
        int frames = 0;
        std::uint64_t keys = 0, items = 0;
    };
    std::uint64_t storage_budget() const;
    void plan_frames();
    void split_batches();
    void prepare_buffers();
    Batch batch_at(int first, int word_last) const;
    std::uint32_t gather(int batch_first, int batch_frames);
    std::uint32_t coverage_in_window(const Crossable& crossable) const;
    void bucket_starts(int batch_first, int batch_frames, int slab_layers);
    bool dispatch_batch(Buffer& mask, int batch_first, int batch_frames, int word_first, int word_last, int z_begin, int slab_layers,
                        std::uint32_t mask_base);
    void voxelise_slab(int word, int z_begin);
    std::uint64_t frame_keys(std::size_t f) const { return frame_plans_[f].keys; }
    std::uint64_t frame_items(std::size_t f) const { return frame_plans_[f].items; }

    VulkanVoxeliser& v_;
    const VoxelisationInput& input_;
    Amhv& out_;
    const ColumnWindow window_;  // the input grid's columns voxelised (input_.columns()): the output's
    const int grid_nx_, grid_ny_;  // the input grid's columns, where the frames are planned
    const int nx_, ny_, nz_, frames_;  // the output's: the window's columns
    const std::uint32_t columns_;
    const std::uint64_t layer_bytes_;
    std::uint64_t budget_ = 0, key_limit_ = 0, item_limit_ = 0;
    std::vector<FramePlan>& frame_plans_;
    bool in_place_ = false, host_clears_flips_ = false;
    vk::DeviceSize import_alignment_ = 0;
    int frames_limit_ = 32;
    std::uint64_t key_room_ = 0, slab_bytes_ = 0;
    Sequence sequence_;
    // Each frame's bucket rooms as a difference array along the rows, (nx + 1) x ny.
    const std::size_t room_row_, room_edges_per_frame_;
    std::vector<std::uint32_t> slot_base_, frame_base_;
    std::uint32_t batch_items_ = 0;  // the work items gather() wrote for the batch
};

VulkanVoxeliser::Call::Call(VulkanVoxeliser& voxeliser, const VoxelisationInput& input, Amhv& out)
    : v_(voxeliser),
      input_(input),
      out_(out),
      window_(input.columns()),
      grid_nx_(input.grid.dims[0]),
      grid_ny_(input.grid.dims[1]),
      nx_(window_.x1 - window_.x0 + 1),
      ny_(window_.y1 - window_.y0 + 1),
      nz_(input.grid.dims[2]),
      frames_(int(input.frames.size())),
      columns_(std::uint32_t(nx_) * std::uint32_t(ny_)),
      layer_bytes_(std::uint64_t(columns_) * 4),
      frame_plans_(voxeliser.host_->frame_plans),
      sequence_(voxeliser.context_),
      room_row_(std::size_t(nx_ + 1)),
      room_edges_per_frame_(room_row_ * std::size_t(ny_)) {}

// After the call, unless a ScratchHold keeps them for the next one.
VulkanVoxeliser::Call::~Call() {
    if (!v_.scratch_held()) v_.release_scratch_over_limit();
}

std::uint64_t VulkanVoxeliser::scratch_bytes() const {
    std::uint64_t total = 0;
    for (const auto* buffer : buffers_.all()) total += *buffer ? (*buffer)->size() : 0;
    return total;
}

void VulkanVoxeliser::release_scratch_over_limit() {
    if (scratch_bytes() > options_.kept_bytes)
        for (auto* buffer : buffers_.all()) buffer->reset();
    if (host_->bytes() > options_.kept_bytes) *host_ = {};
}

// The largest single buffer the call uses.
std::uint64_t VulkanVoxeliser::Call::storage_budget() const {
    std::uint64_t budget = v_.options_.max_buffer_bytes;
    if (budget != 0) return budget;
    const auto& device = v_.context_.selected();
    budget = std::min<std::uint64_t>(device.max_storage_buffer_range, 256ull << 20);
    if (device.max_allocation_size) budget = std::min<std::uint64_t>(budget, device.max_allocation_size);
    // Keys, bucket starts and ends are read as 32-bit texels, triangles as 128-bit ones.
    if (device.max_texel_buffer_elements) budget = std::min<std::uint64_t>(budget, std::uint64_t(device.max_texel_buffer_elements) * 4);
    return budget;
}

void VulkanVoxeliser::Call::run() {
    budget_ = storage_budget();
    if (layer_bytes_ > budget_)
        throw Error(fmt::format("one {}x{} layer of the grid needs {:.1f} MiB, more than the {:.1f} MiB storage buffer limit",
                                nx_, ny_, double(layer_bytes_) / (1 << 20), double(budget_) / (1 << 20)));
    // Upper bound on the crossing keys of each frame: the columns its triangles' boxes cover.
    // The key list ends in kKeyPadding spare slots: the column pass fetches a small bucket's keys
    // as a whole register set, past the bucket's end.
    key_limit_ = budget_ / 4 - kKeyPadding;
    // A batch's work items (two 16-byte texels each) must also fit one buffer.
    item_limit_ = budget_ / sizeof(GpuItem);
    plan_frames();
    split_batches();
    prepare_buffers();
    for (int word = 0; word < out_.words(); ++word)
        for (int z_begin = 0; z_begin < nz_; z_begin += v_.plan_.slab_layers) voxelise_slab(word, z_begin);
}

// Every closed frame's plan, on the host's threads; a frame too large for one buffer is an error
// that names it.
void VulkanVoxeliser::Call::plan_frames() {
    frame_plans_.resize(static_cast<std::size_t>(frames_));
    const bool masks = v_.options_.coverage_masks && fixed::coverage_masks_supported();
    parallel_for(std::size_t(frames_), [&](std::size_t f) {
        const PreparedFrame& frame = input_.frames[f];
        FramePlan& plan = frame_plans_[f];
        if (!frame.closed) {  // the host's surface rule handles it
            plan.clear();
            return;
        }
        if (masks)
            plan_frame_with_masks(frame, grid_nx_, grid_ny_, plan);
        else
            plan_frame_with_spans(frame, grid_nx_, grid_ny_, plan);
    });
    for (int f = 0; f < frames_; ++f) {
        const PreparedFrame& frame = input_.frames[std::size_t(f)];
        if (frame_items(std::size_t(f)) > item_limit_)
            throw Error(fmt::format("{}: the frame's {} triangles make {} work items, more than one {:.1f} MiB buffer holds "
                                    "({}); use --backend cpu",
                                    frame.source, frame_plans_[std::size_t(f)].crossables.size(), frame_items(std::size_t(f)),
                                    double(budget_) / (1 << 20), item_limit_));
        if (frame_keys(std::size_t(f)) > key_limit_)
            throw Error(fmt::format("{}: the frame's triangles cover up to {} voxel columns, more crossings than one "
                                    "{:.1f} MiB storage buffer holds ({}); use a coarser voxel or --backend cpu",
                                    frame.source, frame_keys(std::size_t(f)), double(budget_) / (1 << 20), key_limit_));
    }
}

// Split: z into slabs as tall as one mask buffer allows (usually the whole grid, so every frame is
// rasterised once), and each occupancy word's frames into batches whose keys and buckets (one
// counter per frame and column) fit one buffer each.
void VulkanVoxeliser::Call::split_batches() {
    Plan& plan = v_.plan_;
    plan = {};
    // Where the device works in host memory (a CPU driver such as lavapipe, or an integrated GPU),
    // the column pass writes each slab of the mask straight into the aMHV, imported page by page:
    // no copy and no clear (a new aMHV is zero). The import covers whole pages around the slab.
    const auto& device = v_.context_.selected();
    import_alignment_ = device.host_import_alignment;
    in_place_ = v_.options_.write_in_place && device.shares_host_memory();
    const std::uint64_t mask_budget = in_place_ ? budget_ - std::min<std::uint64_t>(budget_ / 2, 2 * import_alignment_) : budget_;
    plan.writes_in_place = in_place_;
    plan.slab_layers = int(std::min<std::uint64_t>({std::uint64_t(nz_), mask_budget / layer_bytes_, std::uint64_t(kMaxSlabLayers)}));
    plan.slabs = (nz_ + plan.slab_layers - 1) / plan.slab_layers;
    // Halved when a column has more crossings in a batch than the column pass sorts.
    frames_limit_ = int(std::min<std::uint64_t>(32, budget_ / layer_bytes_));
    // Keys one batch may have: one buffer while planning, then the key buffer allocated for the
    // plan (which holds every single frame), so a batch redone with fewer frames also fits.
    key_room_ = key_limit_;
    for (int first = 0; first < frames_;) {
        const Batch batch = batch_at(first, std::min(frames_, (first / 32 + 1) * 32));
        plan.key_capacity = std::max(plan.key_capacity, batch.keys);
        plan.frames_per_batch = std::max(plan.frames_per_batch, batch.frames);
        first += batch.frames;
    }
    key_room_ = plan.key_capacity;
    slab_bytes_ = layer_bytes_ * std::uint64_t(plan.slab_layers);
}

VulkanVoxeliser::Call::Batch VulkanVoxeliser::Call::batch_at(int first, int word_last) const {
    Batch batch;
    while (first + batch.frames < word_last && batch.frames < frames_limit_) {
        const auto next = std::size_t(first + batch.frames);
        if (batch.frames > 0 && (batch.keys + frame_keys(next) > key_room_ || batch.items + frame_items(next) > item_limit_)) break;
        batch.keys += frame_keys(next);
        batch.items += frame_items(next);
        ++batch.frames;
    }
    return batch;
}

// The buffers stay with the voxeliser between calls (grown as needed, released when large): fresh
// memory costs page faults on every call, and the MHV and root stages make many.
void VulkanVoxeliser::Call::prepare_buffers() {
    Context& context = v_.context_;
    Buffers& b = v_.buffers_;
    const std::uint64_t bucket_bytes = layer_bytes_ * std::uint64_t(v_.plan_.frames_per_batch);
    if (!in_place_) ensure_capacity(context, b.mask, slab_bytes_, Buffer::Memory::Host);
    // Where the device works in host memory, the flips are host-visible and the host clears, before
    // each batch, only the columns that batch has room in: the only flips it writes or reads (on
    // its threads; lavapipe filled the whole buffer, a grid's worth, on one). Elsewhere they stay in
    // device memory and the device clears them.
    host_clears_flips_ = context.selected().shares_host_memory();
    const Buffer::Memory flips_memory = host_clears_flips_ ? Buffer::Memory::Host : Buffer::Memory::Device;
    ensure_capacity(context, b.toggles, slab_bytes_, flips_memory);
    // One start more than there are buckets: the end of the last one, so every column's room is
    // the difference of two starts.
    ensure_capacity(context, b.bucket_start, bucket_bytes + 4, Buffer::Memory::Host);
    ensure_capacity(context, b.bucket_cursor, bucket_bytes, Buffer::Memory::Host);
    ensure_capacity(context, b.keys, (v_.plan_.key_capacity + kKeyPadding) * 4, Buffer::Memory::Device);
    ensure_capacity(context, b.overflow, 4, Buffer::Memory::Host);
    ensure_capacity(context, b.column_frames, layer_bytes_, Buffer::Memory::Host);
    ensure_capacity(context, b.spans, layer_bytes_ * 2, Buffer::Memory::Device);
    ensure_capacity(context, b.large_buckets, bucket_bytes, Buffer::Memory::Device);
    ensure_capacity(context, b.huge_buckets, bucket_bytes, Buffer::Memory::Device);
    ensure_capacity(context, b.medium_buckets, bucket_bytes, Buffer::Memory::Device);
    ensure_capacity(context, b.lists, 48, Buffer::Memory::Host);
    b.overflow->mapped<std::uint32_t>()[0] = 0;
}

// Host side of a batch: one work item per masked triangle and per run, written straight into the
// mapped buffer frame by frame on the host's threads (the planning counts give every frame its
// place, and every class its place in the frame), and each frame's bucket rooms: a bucket (column,
// frame) gets room for one key per crossable of that frame whose mask or row span holds the
// column, an upper bound on its crossings, so the raster fills the buckets in one pass. A row of
// a mask or span adds one room with two updates of the frame's difference array. Returns the items.
std::uint32_t VulkanVoxeliser::Call::gather(int batch_first, int batch_frames) {
    std::uint32_t total = 0;
    frame_base_.resize(std::size_t(batch_frames));
    for (int slot = 0; slot < batch_frames; ++slot) {
        frame_base_[std::size_t(slot)] = total;
        total += std::uint32_t(frame_items(std::size_t(batch_first + slot)));
    }
    if (total == 0) return total;
    std::vector<std::int32_t>& room_edges = v_.host_->room_edges;
    room_edges.resize(room_edges_per_frame_ * std::size_t(batch_frames));  // each frame clears its own
    ensure_host_capacity(v_.context_, v_.buffers_.work_items, std::uint64_t(total) * sizeof(GpuItem));
    GpuItem* item_out = v_.buffers_.work_items->mapped<GpuItem>().data();
    parallel_for(std::size_t(batch_frames), [&](std::size_t slot) {
        const PreparedFrame& frame = input_.frames[std::size_t(batch_first) + slot];
        std::int32_t* edges = room_edges.data() + slot * room_edges_per_frame_;
        std::fill_n(edges, room_edges_per_frame_, 0);
        if (!frame.closed) return;
        // Where each class's items begin and end.
        std::array<GpuItem*, kItemClasses> class_item, class_end;
        GpuItem* next_item = item_out + frame_base_[slot];
        const FramePlan& plan = frame_plans_[std::size_t(batch_first) + slot];
        for (std::size_t c = 0; c < kItemClasses; ++c) {
            class_item[c] = next_item;
            next_item += plan.class_items[c];
            class_end[c] = next_item;
        }
        // Rooms and runs within the window's columns alone (the planned counts hold the whole grid);
        // the rooms, like the buckets, by the window's columns.
        auto add_room = [&](int y, int first, int last) {
            if (y < window_.y0 || y > window_.y1) return;
            first = std::max(first, window_.x0), last = std::min(last, window_.x1);
            if (first > last) return;
            const std::size_t row = std::size_t(y - window_.y0) * room_row_;
            ++edges[row + std::size_t(first - window_.x0)];
            --edges[row + std::size_t(last - window_.x0) + 1];
        };
        for (const Crossable& crossable : plan.crossables) {
            const fixed::Triangle& t = frame.triangles[crossable.triangle];
            if (crossable.mask_stride == kSpans) {
                for_each_span(crossable, plan.rows, [&](int y, int first, int last) {
                    add_room(y, first, last);
                    if (y < window_.y0 || y > window_.y1) return;
                    // Each planned run in its planned class, less its columns outside the window.
                    for_each_run(first, last, [&](int x, int run) {
                        const int from = std::max(x, window_.x0), to = std::min(x + run - 1, window_.x1);
                        if (from <= to)
                            *class_item[item_class(crossable, std::uint32_t(run))]++ =
                                pack_item(t, std::uint32_t(slot), run_word(y, from, to - from + 1), 0);
                    });
                });
                continue;
            }
            if (const std::uint32_t coverage = coverage_in_window(crossable))
                *class_item[item_class(crossable, crossable.covered)]++ =
                    pack_item(t, std::uint32_t(slot) | kMaskedTriangle | (std::uint32_t(crossable.mask_stride) << 6), coverage,
                              std::uint32_t(crossable.x0) | (std::uint32_t(crossable.y0) << 16));
            for_each_span(crossable, plan.rows, add_room);
        }
        // The items a window left out: the raster passes over an all-zero item (a triangle of no area).
        for (std::size_t c = 0; c < kItemClasses; ++c) std::fill(class_item[c], class_end[c], GpuItem{});
    });
    return total;
}

// A masked triangle's coverage less the columns outside the window.
std::uint32_t VulkanVoxeliser::Call::coverage_in_window(const Crossable& crossable) const {
    if (window_.contains(crossable.x0, crossable.y0) && window_.contains(crossable.x1, crossable.y1)) return crossable.coverage;
    const int stride = crossable.mask_stride, column_mask = (1 << stride) - 1;
    std::uint32_t kept = 0;
    for (std::uint32_t pending = crossable.coverage; pending != 0u; pending &= pending - 1u) {
        const int bit = std::countr_zero(pending);
        if (window_.contains(crossable.x0 + (bit & column_mask), crossable.y0 + (bit >> stride))) kept |= 1u << bit;
    }
    return kept;
}

// Stretches in bucket order; every cursor starts at its bucket's start. A frame's rooms add up to
// its planned keys, so every frame knows where its stretches begin and the frames go on the host's
// threads. Then each column's frames with room, and every list of larger buckets empty.
void VulkanVoxeliser::Call::bucket_starts(int batch_first, int batch_frames, int slab_layers) {
    Buffers& b = v_.buffers_;
    const std::vector<std::int32_t>& room_edges = v_.host_->room_edges;
    std::uint32_t* starts = b.bucket_start->mapped<std::uint32_t>().data();
    std::uint32_t* cursors = b.bucket_cursor->mapped<std::uint32_t>().data();
    slot_base_.resize(std::size_t(batch_frames) + 1);
    slot_base_[0] = 0;
    for (std::size_t slot = 0; slot < std::size_t(batch_frames); ++slot)
        slot_base_[slot + 1] = slot_base_[slot] + std::uint32_t(frame_keys(std::size_t(batch_first) + slot));
    parallel_for(std::size_t(batch_frames), [&](std::size_t slot) {
        const std::int32_t* edges = room_edges.data() + slot * room_edges_per_frame_;
        std::uint32_t next = slot_base_[slot];
        std::size_t bucket = slot * columns_;
        for (std::size_t y = 0; y < std::size_t(ny_); ++y) {
            std::int32_t room = 0;
            for (std::size_t x = 0; x < std::size_t(nx_); ++x, ++bucket) {
                room += edges[y * room_row_ + x];
                starts[bucket] = cursors[bucket] = next;
                next += std::uint32_t(room);
            }
        }
    });
    starts[std::size_t(batch_frames) * columns_] = slot_base_[std::size_t(batch_frames)];
    // Each column's frames with room (bucket rooms are differences of starts), in stretches of
    // columns on the host's threads; then, where the host clears them, the flips of the columns
    // with room, whatever an earlier batch or call left there: the batch's kernels write and read
    // the flips of those columns alone (a skipped column's are left, and cleared again before a
    // batch that has room in it), and each column's words lie together.
    std::uint32_t* frames_with_room = b.column_frames->mapped<std::uint32_t>().data();
    std::uint32_t* flips = host_clears_flips_ ? b.toggles->mapped<std::uint32_t>().data() : nullptr;
    constexpr std::size_t kStretches = 16;
    const std::size_t columns = columns_, layers = std::size_t(slab_layers);
    parallel_for(kStretches, [&](std::size_t stretch) {
        const std::size_t first = columns * stretch / kStretches, last = columns * (stretch + 1) / kStretches;
        std::fill(frames_with_room + first, frames_with_room + last, 0u);
        for (std::size_t slot = 0; slot < std::size_t(batch_frames); ++slot) {
            const std::uint32_t* start = starts + slot * columns;
            for (std::size_t column = first; column < last; ++column)
                frames_with_room[column] |= start[column + 1] != start[column] ? 1u << slot : 0u;
        }
        if (flips)
            for (std::size_t column = first; column < last; ++column)
                if (frames_with_room[column] != 0) std::fill_n(flips + column * layers, layers, 0u);
    });
    // Every list empty: indirect dispatches of (0, 1, 1) workgroups, length 0.
    std::uint32_t* list_heads = b.lists->mapped<std::uint32_t>().data();
    for (int list = 0; list < 3; ++list) {
        list_heads[4 * list] = 0;
        list_heads[4 * list + 1] = list_heads[4 * list + 2] = 1;
        list_heads[4 * list + 3] = 0;
    }
}

// The raster and the column stages of one batch, submitted and waited for. Returns false when a
// column had more crossings than the column pass sorts (the batch must go again with fewer frames).
bool VulkanVoxeliser::Call::dispatch_batch(Buffer& mask, int batch_first, int batch_frames, int word_first, int word_last, int z_begin,
                                           int slab_layers, std::uint32_t mask_base) {
    Buffers& b = v_.buffers_;
    Buffer &toggles = *b.toggles, &bucket_start = *b.bucket_start, &bucket_cursor = *b.bucket_cursor, &keys = *b.keys;
    Buffer &overflow = *b.overflow, &column_frames = *b.column_frames, &spans = *b.spans;
    Buffer &large_buckets = *b.large_buckets, &huge_buckets = *b.huge_buckets, &lists = *b.lists, &medium_buckets = *b.medium_buckets;
    auto raster_set = v_.raster_.bind({b.work_items.get(), &bucket_cursor, &keys});
    auto columns_set = v_.flip_small_.bind({&keys, &bucket_start, &bucket_cursor, &overflow, &toggles, &mask, &keys, &column_frames, &spans,
                                            &large_buckets, &huge_buckets, &lists, &medium_buckets});
    const RasterParams raster{0, 0, nx_, ny_, z_begin, slab_layers, window_.x0, window_.y0};
    // The previous batch's last reads of the flips and keys must be done before they are cleared
    // and rewritten (the host wrote the cursors after the fence).
    sequence_.barrier();
    if (!host_clears_flips_) sequence_.fill(toggles, slab_bytes_, 0u);
    sequence_.dispatch(v_.raster_, raster_set, raster, batch_items_);
    // Every key and final cursor must be in place before the columns sort them.
    sequence_.barrier();
    const ColumnParams column_params{0, 0, columns_, slab_layers, batch_first - word_first,
                                     std::uint32_t(batch_first == word_first && batch_frames == word_last - word_first), mask_base};
    sequence_.dispatch(v_.flip_small_, columns_set, column_params, columns_);
    // The small buckets' flips and spans, and the lists of larger ones, must be in place before the
    // larger ones' atomics add theirs (the three lists' buckets are apart).
    sequence_.barrier();
    // The three lists' buckets lie apart, but the stages share the key list and the flips, and the
    // synchronisation validation (like a real GPU's caches) wants each stage's writes made visible
    // before the next one reads the same buffers.
    sequence_.dispatch_indirect(v_.flip_medium_, columns_set, column_params, lists, 32);
    sequence_.barrier();
    sequence_.dispatch_indirect(v_.flip_large_, columns_set, column_params, lists, 0);
    sequence_.barrier();
    sequence_.dispatch_indirect(v_.flip_huge_, columns_set, column_params, lists, 16);
    // Every flip and span must be in place before the columns are written.
    sequence_.barrier();
    sequence_.dispatch(v_.write_columns_, columns_set, column_params, columns_);
    // The host reads the overflow value after the fence; the next batch reuses the host-written
    // triangle buffers, so this one must finish first.
    sequence_.barrier_to_host();
    sequence_.submit_and_wait();
    return overflow.mapped<std::uint32_t>()[0] == 0;
}

// One occupancy word's frames over one slab of layers, batch by batch. The word's bits accumulate
// in the mask over its batches: the aMHV's own pages, or the scratch mask cleared once per slab and
// copied into the aMHV after it.
void VulkanVoxeliser::Call::voxelise_slab(int word, int z_begin) {
    Plan& plan = v_.plan_;
    const int word_first = word * 32;
    const int word_last = std::min(frames_, word_first + 32);
    const int slab_layers = std::min(plan.slab_layers, nz_ - z_begin);
    std::uint32_t* destination = out_.plane(word) + std::size_t(z_begin) * columns_;
    const std::size_t destination_bytes = std::size_t(slab_layers) * columns_ * sizeof(std::uint32_t);
    std::unique_ptr<Buffer> imported;
    std::uint32_t mask_base = 0;  // the slab's first word in the mask buffer
    if (in_place_) {
        const auto first = reinterpret_cast<std::uintptr_t>(destination);
        const std::uintptr_t begin = first / import_alignment_ * import_alignment_;
        const std::uintptr_t end = (first + destination_bytes + import_alignment_ - 1) / import_alignment_ * import_alignment_;
        imported = Buffer::import_host(v_.context_, reinterpret_cast<void*>(begin), end - begin);
        mask_base = std::uint32_t((first - begin) / sizeof(std::uint32_t));
    } else {
        sequence_.fill(*v_.buffers_.mask, destination_bytes, 0u);
    }
    Buffer& mask = in_place_ ? *imported : *v_.buffers_.mask;
    std::uint32_t& most_column_crossings = v_.buffers_.overflow->mapped<std::uint32_t>()[0];
    bool any_work = false;
    for (int batch_first = word_first; batch_first < word_last;) {
        const int batch_frames = batch_at(batch_first, word_last).frames;
        batch_items_ = gather(batch_first, batch_frames);
        ++plan.batches;
        plan.work_items += batch_items_;
        if (batch_items_ == 0) {  // no closed surface in this batch: its bits stay 0
            batch_first += batch_frames;
            continue;
        }
        any_work = true;
        bucket_starts(batch_first, batch_frames, slab_layers);
        if (dispatch_batch(mask, batch_first, batch_frames, word_first, word_last, z_begin, slab_layers, mask_base)) {
            batch_first += batch_frames;
            continue;
        }
        // A column had more crossings than the column pass may sort. It was skipped; every other
        // column's bits are right and will be ORed again, so the batch is simply redone with fewer
        // frames.
        if (batch_frames == 1)
            throw Error(fmt::format("{}: a voxel column crosses the surface {} times, more than the {} the Vulkan "
                                    "voxeliser sorts per column (use --backend cpu)",
                                    input_.frames[std::size_t(batch_first)].source, most_column_crossings, v_.options_.max_column_crossings));
        most_column_crossings = 0;
        frames_limit_ = std::max(1, batch_frames / 2);
        ++plan.overflow_retries;
    }
    if (!any_work || in_place_) return;  // written in place after each batch's fence
    // The host reads the mask right after the fence.
    sequence_.barrier_to_host();
    sequence_.submit_and_wait();
    // On every core: one core's copy out of the mapped buffer and first touch of the aMHV's fresh
    // pages were 5.7 s of the 5 mm paper scene's edit on an H200 machine (perf, 8000ddb).
    copy_on_threads(destination, mask.mapped<std::uint32_t>().data(), destination_bytes);
}

void VulkanVoxeliser::voxelise_solid(const VoxelisationInput& input, Amhv& out) {
    Call call(*this, input, out);
    call.run();
}

}  // namespace amhv::gpu
