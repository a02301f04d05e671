#include "gpu/voxelise_vulkan.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <memory>

#include "core/coverage_starts.hpp"
#include "core/error.hpp"
#include "core/grid.hpp"
#include "core/parallel.hpp"
#include "core/uninitialised_allocator.hpp"
#include "voxel_columns.spv.h"
#include "voxel_raster.spv.h"

namespace amhv::gpu {

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
// A triangle with spans goes to the raster as runs: a row's span, in pieces of up to kRunColumns
// columns, each a work item (first column | row << 11 | (columns - 1) << 22).
constexpr int kRunColumns = 64;
static_assert(kMaxGridAxis <= 2048 && kRunColumns <= 1024, "a run fits one word");
inline std::uint32_t run_word(int y, int first, int columns) {
    return std::uint32_t(first) | (std::uint32_t(y) << 11) | (std::uint32_t(columns - 1) << 22);
}

struct RasterParams {
    std::uint32_t work_base, work_count;
    std::int32_t nx, ny, z_begin, slab_layers;
};
struct ColumnParams {
    std::uint32_t column_base, column_count, columns;
    std::int32_t slab_layers, bit_offset;
    std::uint32_t whole_word, mask_base;
};

// One row of a triangle's columns (first > last: none).
struct RowSpan {
    std::uint16_t first, last;
};
static_assert(kMaxGridAxis <= 65536, "column indices fit 16 bits");

// A triangle of a closed frame that covers a column centre, with the columns it may cover and their
// box: a small one's covered columns exactly (fixed::coverage_mask, 93% of them at 10 mm), a larger
// one's rows' spans of columns (each row's cross-section, fixed::CrossSections, which may hold a
// column more where a centre lies on an edge). A bucket's room is the crossables whose mask or
// spans hold its column; the raster takes a mask's columns as they are and tests a span's. Found
// once per call, while planning; the batches' gathering reads them back.
struct Crossable {
    std::uint32_t triangle;  // index in the frame
    // With a mask stride: the coverage mask from the box's corner (x0, y0; rows y0..y1 hold its
    // bits). Else the index of row y0's span in the frame's list; rows y0..y1 follow.
    std::uint32_t coverage;
    std::uint16_t x0, x1, y0, y1;
    std::uint32_t covered;     // the columns its mask or spans hold
    std::uint8_t mask_stride;  // log2 of the mask's row stride, or kSpans
};
constexpr std::uint8_t kSpans = 0xff;

// The raster's slot loop runs as long as its subgroup's most covered lane, so a frame's work items
// go out in classes of equally many covered columns (up to kClassColumns - 1): a masked triangle's,
// or a run's columns. Masked triangles go apart from the runs of those with spans (a subgroup that
// mixes them runs both ways).
constexpr std::uint32_t kClassColumns = 64, kItemClasses = 2 * kClassColumns;
// The class of a work item of a crossable with `covered` columns: the planner counts each class's
// items by it and the gathering places them by it, so the two must agree.
inline std::uint32_t item_class(const Crossable& crossable, std::uint32_t covered) {
    return std::min(covered, kClassColumns - 1) + (crossable.mask_stride == kSpans ? kClassColumns : 0);
}

// The work items of a row span [first, last] of a crossable with spans: visit(first column, columns).
template <class Visit>
void for_each_run(int first, int last, Visit&& visit) {
    for (int x = first; x <= last; x += kRunColumns) visit(x, std::min(kRunColumns, last - x + 1));
}

struct FramePlan {
    std::vector<Crossable, UninitialisedAllocator<Crossable>> crossables;
    std::vector<RowSpan, UninitialisedAllocator<RowSpan>> rows;
    std::uint64_t keys = 0;   // the masks' and spans' columns: an upper bound on the frame's crossings
    std::uint64_t items = 0;  // raster work items: one per masked crossable, and the runs
    std::array<std::uint32_t, kItemClasses> class_items{};  // work items per class

    // Empty, with the lists' capacity kept for the next frame.
    void clear() {
        crossables.clear();
        rows.clear();
        keys = items = 0;
        class_items = {};
    }
};

// The coverage mask's row r (bits from the box's first column), for a mask of row stride 2^stride.
inline std::uint32_t mask_row(std::uint32_t mask, int stride, int r) { return (mask >> (r << stride)) & ((1u << (1 << stride)) - 1u); }

// Calls visit(y, first, last) for each row of a crossable that holds columns.
template <class Visit>
void for_each_span(const Crossable& c, const std::vector<RowSpan, UninitialisedAllocator<RowSpan>>& rows, Visit&& visit) {
    if (c.mask_stride != kSpans) {
        const int stride = c.mask_stride;
        for (int y = c.y0; y <= c.y1; ++y) {
            const std::uint32_t bits = mask_row(c.coverage, stride, y - c.y0);
            if (bits != 0) visit(y, c.x0 + __builtin_ctz(bits), c.x0 + 31 - __builtin_clz(bits));
        }
        return;
    }
    const RowSpan* span = rows.data() + c.coverage;
    for (int y = c.y0; y <= c.y1; ++y, ++span)
        if (span->first <= span->last) visit(y, int(span->first), int(span->last));
}

// `Masks`: small triangles get coverage masks (only in plan_frame_with_masks, which is built for
// AVX2). The plan's lists keep their capacity from an earlier call.
template <bool Masks>
[[gnu::always_inline]] inline void plan_frame(const PreparedFrame& frame, int nx, int ny, FramePlan& plan) {
    plan.clear();
    // Written by index and trimmed at the end: a triangle's place is taken whether or not it is kept,
    // and a kept one advances the counts (without branches, as below).
    plan.crossables.resize(frame.triangles.size());
    plan.rows.resize(frame.triangles.size() * 3);
    std::size_t crossables = 0, rows_used = 0;
    // With Masks: find_starts's, kept by the planning thread for its next frame (released when they
    // were for more than kKeptStartTriangles).
    thread_local fixed::TriangleStarts starts;
    constexpr std::size_t kKeptStartTriangles = std::size_t(1) << 18;  // 14 MiB of fields
    if constexpr (Masks) fixed::find_starts(frame.triangles, nx, ny, starts);
    struct ReleaseStarts {
        ~ReleaseStarts() {
            if (starts.kind.capacity() > kKeptStartTriangles) starts = {};
        }
    } release_starts;
    for (std::size_t i = 0; i < frame.triangles.size(); ++i) {
        const fixed::Triangle& t = frame.triangles[i];
        int x0, x1, y0, y1;
        if constexpr (Masks) {
            if (starts.kind[i] == fixed::TriangleStarts::kSkipped) continue;
            x0 = starts.x0[i], x1 = starts.x1[i], y0 = starts.y0[i], y1 = starts.y1[i];
        } else {
            const fixed::Point2 a = t[0].xy(), b = t[1].xy(), c = t[2].xy();
            const fixed::IndexRange columns_x = fixed::centre_range(std::min({a.x, b.x, c.x}), std::max({a.x, b.x, c.x}));
            const fixed::IndexRange columns_y = fixed::centre_range(std::min({a.y, b.y, c.y}), std::max({a.y, b.y, c.y}));
            x0 = std::max(columns_x.first, 0), x1 = std::min(columns_x.last, nx - 1);
            y0 = std::max(columns_y.first, 0), y1 = std::min(columns_y.last, ny - 1);
            // Seen edge-on from above, or no column centre in its bounding box.
            if ((fixed::edge_function(a, b, c) == 0) | (x0 > x1) | (y0 > y1)) continue;
        }
        const int width = x1 - x0 + 1, height = y1 - y0 + 1;
        if (Masks && starts.kind[i] == fixed::TriangleStarts::kMasked) {
            const std::uint32_t mask = fixed::coverage_mask(starts.start(i), width, height);
            const int stride = fixed::mask_stride_log2(width);
            // The rows from the lowest to the highest bit (the mask then taken from the first), the
            // columns of the bounding box.
            const int first_row = std::countr_zero(std::uint64_t(mask) | (std::uint64_t(1) << 32)) >> stride;
            const std::uint32_t keys = std::uint32_t(__builtin_popcount(mask));
            plan.crossables[crossables] = {std::uint32_t(i),
                                           std::uint32_t(std::uint64_t(mask) >> (first_row << stride)),
                                           std::uint16_t(x0),
                                           std::uint16_t(x1),
                                           std::uint16_t(y0 + first_row),
                                           std::uint16_t(y0 + ((31 - __builtin_clz(mask | 1u)) >> stride)),
                                           keys,
                                           std::uint8_t(stride)};
            plan.keys += keys;
            crossables += keys != 0 ? 1 : 0;
            continue;
        }
        if (rows_used + std::size_t(height) > plan.rows.size())
            plan.rows.resize(std::max(plan.rows.size() * 2, rows_used + std::size_t(height)));
        RowSpan* rows = plan.rows.data() + rows_used;
        // Each row's span inside the bounding box, and the box of the non-empty ones. Without
        // branches: whether a row is empty is as good as random.
        const fixed::CrossSections sections(t, y0);
        int box_x0 = nx, box_x1 = -1, box_y0 = ny, box_y1 = -1;
        std::uint64_t keys = 0;
        for (int row = 0; row < height; ++row) {
            const fixed::IndexRange span = sections.row(row);
            const int first = std::max(span.first, x0), last = std::min(span.last, x1);
            const bool empty = first > last;
            rows[row] = empty ? RowSpan{1, 0} : RowSpan{std::uint16_t(first), std::uint16_t(last)};
            keys += empty ? 0u : std::uint64_t(last - first + 1);
            box_x0 = empty ? box_x0 : std::min(box_x0, first);
            box_x1 = empty ? box_x1 : std::max(box_x1, last);
            box_y0 = empty ? box_y0 : std::min(box_y0, y0 + row);
            box_y1 = empty ? box_y1 : y0 + row;
        }
        // Kept when it covers a column centre: its rows from the first to the last non-empty one.
        const bool kept = keys != 0;
        plan.crossables[crossables] = {std::uint32_t(i), std::uint32_t(rows_used + std::size_t(std::max(box_y0 - y0, 0))),
                                       std::uint16_t(box_x0), std::uint16_t(box_x1), std::uint16_t(box_y0), std::uint16_t(box_y1),
                                       std::uint32_t(keys), kSpans};
        plan.keys += keys;
        crossables += kept ? 1 : 0;
        rows_used += kept ? std::size_t(box_y1 - y0 + 1) : 0;
    }
    plan.crossables.resize(crossables);
    plan.rows.resize(rows_used);
    for (const Crossable& crossable : plan.crossables) {
        if (crossable.mask_stride == kSpans) {
            for_each_span(crossable, plan.rows, [&](int, int first, int last) {
                for_each_run(first, last, [&](int, int columns) { ++plan.class_items[item_class(crossable, std::uint32_t(columns))]; });
            });
            continue;
        }
        ++plan.class_items[item_class(crossable, crossable.covered)];
    }
    for (const std::uint32_t items : plan.class_items) plan.items += items;
}

AMHV_TARGET_AVX2 void plan_frame_with_masks(const PreparedFrame& frame, int nx, int ny, FramePlan& plan) {
    plan_frame<true>(frame, nx, ny, plan);
}
void plan_frame_with_spans(const PreparedFrame& frame, int nx, int ny, FramePlan& plan) {
    plan_frame<false>(frame, nx, ny, plan);
}

// voxel_columns.comp's bindings: keys, bucket starts, bucket ends, overflow, flips, mask, keys
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
    : context_(context),
      options_(options),
      raster_(context, voxel_raster_spv, {Binding::Texels128, Binding::Storage, Binding::Storage}, sizeof(RasterParams),
              {kWorkgroup}),
      flip_small_(context, voxel_columns_spv, column_bindings(), sizeof(ColumnParams), {kWorkgroup, options.max_column_crossings, 0u}),
      flip_medium_(context, voxel_columns_spv, column_bindings(), sizeof(ColumnParams), {kWorkgroup, options.max_column_crossings, 4u}),
      flip_large_(context, voxel_columns_spv, column_bindings(), sizeof(ColumnParams), {kWorkgroup, options.max_column_crossings, 1u}),
      flip_huge_(context, voxel_columns_spv, column_bindings(), sizeof(ColumnParams), {kWorkgroup, options.max_column_crossings, 2u}),
      write_columns_(context, voxel_columns_spv, column_bindings(), sizeof(ColumnParams), {kWorkgroup, options.max_column_crossings, 3u}),
      host_(std::make_unique<HostScratch>()) {}

std::string VulkanVoxeliser::name() const { return "vulkan:" + context_.selected().name; }

void VulkanVoxeliser::voxelise_solid(const VoxelisationInput& input, Amhv& out) {
    const auto& grid = input.grid;
    const int nx = grid.dims[0], ny = grid.dims[1], nz = grid.dims[2];
    const int frames = int(input.frames.size());
    const std::uint32_t columns = std::uint32_t(nx) * std::uint32_t(ny);
    const std::uint64_t layer_bytes = std::uint64_t(columns) * 4;

    std::uint64_t budget = options_.max_buffer_bytes;
    if (budget == 0) {
        budget = std::min<std::uint64_t>(context_.selected().max_storage_buffer_range, 256ull << 20);
        if (context_.selected().max_allocation_size) budget = std::min<std::uint64_t>(budget, context_.selected().max_allocation_size);
        // Keys, bucket starts and ends are read as 32-bit texels, triangles as 128-bit ones.
        if (context_.selected().max_texel_buffer_elements)
            budget = std::min<std::uint64_t>(budget, std::uint64_t(context_.selected().max_texel_buffer_elements) * 4);
    }
    if (layer_bytes > budget)
        throw Error(fmt::format("one {}x{} layer of the grid needs {:.1f} MiB, more than the {:.1f} MiB storage buffer limit",
                                nx, ny, double(layer_bytes) / (1 << 20), double(budget) / (1 << 20)));

    // Upper bound on the crossing keys of each frame: the columns its triangles' boxes cover.
    // The key list ends in kKeyPadding spare slots: the column pass fetches a small bucket's keys
    // as a whole register set, past the bucket's end.
    const std::uint64_t key_limit = budget / 4 - kKeyPadding;
    // A batch's work items (two 16-byte texels each) must also fit one buffer.
    const std::uint64_t item_limit = budget / sizeof(GpuItem);
    // After the call, lists beyond kKeptBytes go back.
    struct ReleaseHost {
        HostScratch& host;
        ~ReleaseHost() {
            if (host.bytes() > kKeptBytes) host = {};
        }
    } release_host{*host_};
    std::vector<FramePlan>& frame_plans = host_->frame_plans;
    frame_plans.resize(static_cast<std::size_t>(frames));
    const bool masks = options_.coverage_masks && fixed::coverage_masks_supported();
    parallel_for(std::size_t(frames), [&](std::size_t f) {
        const PreparedFrame& frame = input.frames[f];
        FramePlan& plan = frame_plans[f];
        if (!frame.closed) {  // the host's surface rule handles it
            plan.clear();
            return;
        }
        if (masks)
            plan_frame_with_masks(frame, nx, ny, plan);
        else
            plan_frame_with_spans(frame, nx, ny, plan);
    });
    auto frame_keys = [&](std::size_t f) { return frame_plans[f].keys; };
    auto frame_items = [&](std::size_t f) { return frame_plans[f].items; };
    for (int f = 0; f < frames; ++f) {
        const PreparedFrame& frame = input.frames[std::size_t(f)];
        if (frame_items(std::size_t(f)) > item_limit)
            throw Error(fmt::format("{}: the frame's {} triangles make {} work items, more than one {:.1f} MiB buffer holds "
                                    "({}); use --backend cpu",
                                    frame.source, frame_plans[std::size_t(f)].crossables.size(), frame_items(std::size_t(f)),
                                    double(budget) / (1 << 20), item_limit));
        if (frame_keys(std::size_t(f)) > key_limit)
            throw Error(fmt::format("{}: the frame's triangles cover up to {} voxel columns, more crossings than one "
                                    "{:.1f} MiB storage buffer holds ({}); use a coarser voxel or --backend cpu",
                                    frame.source, frame_keys(std::size_t(f)), double(budget) / (1 << 20), key_limit));
    }

    // Split: z into slabs as tall as one mask buffer allows (usually the whole grid, so every frame
    // is rasterised once), and each occupancy word's frames into batches whose keys and buckets
    // (one counter per frame and column) fit one buffer each.
    plan_ = {};
    // Where the device works in host memory (a CPU driver such as lavapipe, or an integrated GPU),
    // the column pass writes each slab of the mask straight into the aMHV, imported page by page:
    // no copy and no clear (a new aMHV is zero). The import covers whole pages around the slab.
    const auto& device = context_.selected();
    const vk::DeviceSize import_alignment = device.host_import_alignment;
    const bool in_place = options_.write_in_place && device.shares_host_memory();
    const std::uint64_t mask_budget = in_place ? budget - std::min<std::uint64_t>(budget / 2, 2 * import_alignment) : budget;
    plan_.writes_in_place = in_place;
    plan_.slab_layers = int(std::min<std::uint64_t>({std::uint64_t(nz), mask_budget / layer_bytes, std::uint64_t(kMaxSlabLayers)}));
    plan_.slabs = (nz + plan_.slab_layers - 1) / plan_.slab_layers;
    // Halved when a column has more crossings in a batch than the column pass sorts.
    int frames_limit = int(std::min<std::uint64_t>(32, budget / layer_bytes));
    // Keys one batch may have: one buffer while planning, then the key buffer allocated for the
    // plan (which holds every single frame), so a batch redone with fewer frames also fits.
    std::uint64_t key_room = key_limit;
    // The batch starting at `first` (inside its word): its frames and their keys.
    struct Batch {
        int frames = 0;
        std::uint64_t keys = 0, items = 0;
    };
    auto batch_at = [&](int first, int word_last) {
        Batch batch;
        while (first + batch.frames < word_last && batch.frames < frames_limit) {
            const auto next = std::size_t(first + batch.frames);
            if (batch.frames > 0 && (batch.keys + frame_keys(next) > key_room || batch.items + frame_items(next) > item_limit)) break;
            batch.keys += frame_keys(next);
            batch.items += frame_items(next);
            ++batch.frames;
        }
        return batch;
    };
    for (int first = 0; first < frames;) {
        const Batch batch = batch_at(first, std::min(frames, (first / 32 + 1) * 32));
        plan_.key_capacity = std::max(plan_.key_capacity, batch.keys);
        plan_.frames_per_batch = std::max(plan_.frames_per_batch, batch.frames);
        first += batch.frames;
    }
    key_room = plan_.key_capacity;

    const std::uint64_t slab_bytes = layer_bytes * std::uint64_t(plan_.slab_layers);
    const std::uint64_t bucket_bytes = layer_bytes * std::uint64_t(plan_.frames_per_batch);
    // The buffers stay with the voxeliser between calls (grown as needed, released when large):
    // fresh memory costs page faults on every call, and the MHV and root stages make many.
    Buffers& b = buffers_;
    struct Release {  // after the call, buffers beyond kKeptBytes go back
        Buffers& b;
        ~Release() {
            std::uint64_t total = 0;
            for (auto* buffer : b.all()) total += *buffer ? (*buffer)->size() : 0;
            if (total > kKeptBytes)
                for (auto* buffer : b.all()) buffer->reset();
        }
    } release{b};
    if (!in_place) ensure_capacity(context_, b.mask, slab_bytes, Buffer::Memory::Host);
    // Where the device works in host memory, the flips are host-visible and, after the call's first
    // batch, the host clears only the columns the batch before flipped (on its threads; lavapipe
    // clears a buffer on one). Elsewhere they stay in device memory and are cleared by the device.
    const bool host_clears_flips = device.shares_host_memory();
    const Buffer::Memory flips_memory = host_clears_flips ? Buffer::Memory::Host : Buffer::Memory::Device;
    // The flips the last call left, if the buffers that say where they are stay (see flips_left_).
    auto kept = [](const std::unique_ptr<Buffer>& buffer, std::uint64_t bytes, Buffer::Memory memory) {
        return buffer && buffer->size() >= bytes && buffer->memory() == memory;
    };
    const FlipsLeft flips_left = std::exchange(flips_left_, FlipsLeft{});  // unknown until this call ends
    const bool flips_left_kept = host_clears_flips && flips_left.layers != 0 && flips_left.columns == columns &&
                                 kept(b.toggles, slab_bytes, flips_memory) && kept(b.column_frames, layer_bytes, Buffer::Memory::Host);
    ensure_capacity(context_, b.toggles, slab_bytes, flips_memory);
    // One start more than there are buckets: the end of the last one, so every column's room is
    // the difference of two starts.
    ensure_capacity(context_, b.bucket_start, bucket_bytes + 4, Buffer::Memory::Host);
    ensure_capacity(context_, b.bucket_cursor, bucket_bytes, Buffer::Memory::Host);
    ensure_capacity(context_, b.keys, (plan_.key_capacity + kKeyPadding) * 4, Buffer::Memory::Device);
    ensure_capacity(context_, b.overflow, 4, Buffer::Memory::Host);
    ensure_capacity(context_, b.column_frames, layer_bytes, Buffer::Memory::Host);
    ensure_capacity(context_, b.spans, layer_bytes * 2, Buffer::Memory::Device);
    ensure_capacity(context_, b.large_buckets, bucket_bytes, Buffer::Memory::Device);
    ensure_capacity(context_, b.huge_buckets, bucket_bytes, Buffer::Memory::Device);
    ensure_capacity(context_, b.medium_buckets, bucket_bytes, Buffer::Memory::Device);
    ensure_capacity(context_, b.lists, 48, Buffer::Memory::Host);
    Buffer &toggles = *b.toggles, &bucket_start = *b.bucket_start, &bucket_cursor = *b.bucket_cursor, &keys = *b.keys;
    Buffer& overflow = *b.overflow;
    Buffer& column_frames = *b.column_frames;
    Buffer &spans = *b.spans, &large_buckets = *b.large_buckets, &huge_buckets = *b.huge_buckets, &lists = *b.lists;
    Buffer& medium_buckets = *b.medium_buckets;
    std::uint32_t& most_column_crossings = overflow.mapped<std::uint32_t>()[0];
    most_column_crossings = 0;
    std::unique_ptr<Buffer>& work_items = b.work_items;
    Sequence sequence(context_);
    // The flips per column ([column][z]) of the slab of the batch before, which the host clears; 0
    // where the device clears them, and before the call's first batch unless the last call's are
    // known (then they are the columns with room in its last batch, as column_frames still says).
    std::size_t dirty_column_flips = flips_left_kept ? flips_left.layers : 0;

    // Host side of a batch: its triangles, one work item per masked triangle and per run, and
    // each bucket's stretch of the key list: a bucket (column, frame) gets room for one key per
    // crossable of that frame whose mask or row span holds the column, an upper bound on its
    // crossings, so the raster fills the buckets in one pass (each crossing takes the next slot of
    // its bucket). Each frame's rooms are first a difference array along the rows, (nx + 1) x ny: a
    // row of a mask or span adds one with two updates, and the starts loop sums them up.
    const std::size_t room_row = std::size_t(nx + 1), room_edges_per_frame = room_row * std::size_t(ny);
    std::vector<std::int32_t>& room_edges = host_->room_edges;
    std::vector<std::uint32_t> slot_base;
    // Work items go straight into the mapped buffer, frame by frame on the host's threads: the
    // planning counts give every frame its place, and every class its place in the frame.
    std::vector<std::uint32_t> frame_base;
    auto gather = [&](int batch_first, int batch_frames) {
        std::uint32_t total = 0;
        frame_base.resize(std::size_t(batch_frames));
        for (int slot = 0; slot < batch_frames; ++slot) {
            frame_base[std::size_t(slot)] = total;
            total += std::uint32_t(frame_items(std::size_t(batch_first + slot)));
        }
        if (total == 0) return total;
        room_edges.resize(room_edges_per_frame * std::size_t(batch_frames));  // each frame clears its own
        ensure_host_capacity(context_, work_items, std::uint64_t(total) * sizeof(GpuItem));
        GpuItem* item_out = work_items->mapped<GpuItem>().data();
        parallel_for(std::size_t(batch_frames), [&](std::size_t slot) {
            const PreparedFrame& frame = input.frames[std::size_t(batch_first) + slot];
            std::int32_t* edges = room_edges.data() + slot * room_edges_per_frame;
            std::fill_n(edges, room_edges_per_frame, 0);
            if (!frame.closed) return;
            // Where each class's items begin.
            std::array<GpuItem*, kItemClasses> class_item;
            GpuItem* next_item = item_out + frame_base[slot];
            const FramePlan& plan = frame_plans[std::size_t(batch_first) + slot];
            for (std::size_t c = 0; c < kItemClasses; ++c) {
                class_item[c] = next_item;
                next_item += plan.class_items[c];
            }
            auto add_room = [&](int y, int first, int last) {
                ++edges[std::size_t(y) * room_row + std::size_t(first)];
                --edges[std::size_t(y) * room_row + std::size_t(last) + 1];
            };
            for (const Crossable& crossable : plan.crossables) {
                const fixed::Triangle& t = frame.triangles[crossable.triangle];
                if (crossable.mask_stride == kSpans) {
                    for_each_span(crossable, plan.rows, [&](int y, int first, int last) {
                        add_room(y, first, last);
                        for_each_run(first, last, [&](int x, int run) {
                            *class_item[item_class(crossable, std::uint32_t(run))]++ = pack_item(t, std::uint32_t(slot), run_word(y, x, run), 0);
                        });
                    });
                    continue;
                }
                *class_item[item_class(crossable, crossable.covered)]++ =
                    pack_item(t, std::uint32_t(slot) | kMaskedTriangle | (std::uint32_t(crossable.mask_stride) << 6), crossable.coverage,
                              std::uint32_t(crossable.x0) | (std::uint32_t(crossable.y0) << 16));
                for_each_span(crossable, plan.rows, add_room);
            }
        });
        return total;
    };

    for (int word = 0; word < out.words(); ++word) {
        const int word_first = word * 32;
        const int word_last = std::min(frames, word_first + 32);
        for (int z_begin = 0; z_begin < nz; z_begin += plan_.slab_layers) {
            const int slab_layers = std::min(plan_.slab_layers, nz - z_begin);
            // The word's bits accumulate in the mask over its batches: the aMHV's own pages, or the
            // scratch mask cleared once per slab and copied into the aMHV after it.
            std::uint32_t* destination = out.plane(word) + std::size_t(z_begin) * columns;
            const std::size_t destination_bytes = std::size_t(slab_layers) * columns * sizeof(std::uint32_t);
            std::unique_ptr<Buffer> imported;
            std::uint32_t mask_base = 0;  // the slab's first word in the mask buffer
            if (in_place) {
                const auto first = reinterpret_cast<std::uintptr_t>(destination);
                const std::uintptr_t begin = first / import_alignment * import_alignment;
                const std::uintptr_t end = (first + destination_bytes + import_alignment - 1) / import_alignment * import_alignment;
                imported = Buffer::import_host(context_, reinterpret_cast<void*>(begin), end - begin);
                mask_base = std::uint32_t((first - begin) / sizeof(std::uint32_t));
            } else {
                sequence.fill(*b.mask, destination_bytes, 0u);
            }
            Buffer& mask = in_place ? *imported : *b.mask;
            bool any_work = false;
            for (int batch_first = word_first; batch_first < word_last;) {
                const int batch_frames = batch_at(batch_first, word_last).frames;
                const std::uint32_t items = gather(batch_first, batch_frames);
                ++plan_.batches;
                plan_.work_items += items;
                if (items == 0) {  // no closed surface in this batch: its bits stay 0
                    batch_first += batch_frames;
                    continue;
                }
                any_work = true;
                {
                    // Stretches in bucket order; every cursor starts at its bucket's start. A frame's
                    // rooms add up to its planned keys, so every frame knows where its stretches
                    // begin and the frames go on the host's threads.
                    std::uint32_t* starts = bucket_start.mapped<std::uint32_t>().data();
                    std::uint32_t* cursors = bucket_cursor.mapped<std::uint32_t>().data();
                    slot_base.resize(std::size_t(batch_frames) + 1);
                    slot_base[0] = 0;
                    for (std::size_t slot = 0; slot < std::size_t(batch_frames); ++slot)
                        slot_base[slot + 1] = slot_base[slot] + std::uint32_t(frame_keys(std::size_t(batch_first) + slot));
                    parallel_for(std::size_t(batch_frames), [&](std::size_t slot) {
                        const std::int32_t* edges = room_edges.data() + slot * room_edges_per_frame;
                        std::uint32_t next = slot_base[slot];
                        std::size_t bucket = slot * columns;
                        for (std::size_t y = 0; y < std::size_t(ny); ++y) {
                            std::int32_t room = 0;
                            for (std::size_t x = 0; x < std::size_t(nx); ++x, ++bucket) {
                                room += edges[y * room_row + x];
                                starts[bucket] = cursors[bucket] = next;
                                next += std::uint32_t(room);
                            }
                        }
                    });
                    starts[std::size_t(batch_frames) * columns] = slot_base[std::size_t(batch_frames)];
                    // Each column's frames with room (bucket rooms are differences of starts), in
                    // stretches of columns on the host's threads. Before that, after the call's first
                    // batch, the flips of the batch before are cleared: only the columns where it
                    // had room have any (a skipped column's too), and their words lie together.
                    std::uint32_t* frames_with_room = column_frames.mapped<std::uint32_t>().data();
                    std::uint32_t* flips = host_clears_flips ? toggles.mapped<std::uint32_t>().data() : nullptr;
                    constexpr std::size_t kStretches = 16;
                    parallel_for(kStretches, [&](std::size_t stretch) {
                        const std::size_t first = columns * stretch / kStretches, last = columns * (stretch + 1) / kStretches;
                        if (dirty_column_flips != 0)
                            for (std::size_t column = first; column < last; ++column)
                                if (frames_with_room[column] != 0) std::fill_n(flips + column * dirty_column_flips, dirty_column_flips, 0u);
                        std::fill(frames_with_room + first, frames_with_room + last, 0u);
                        for (std::size_t slot = 0; slot < std::size_t(batch_frames); ++slot) {
                            const std::uint32_t* start = starts + slot * columns;
                            for (std::size_t column = first; column < last; ++column)
                                frames_with_room[column] |= start[column + 1] != start[column] ? 1u << slot : 0u;
                        }
                    });
                    // Every list empty: indirect dispatches of (0, 1, 1) workgroups, length 0.
                    std::uint32_t* list_heads = lists.mapped<std::uint32_t>().data();
                    for (int list = 0; list < 3; ++list) {
                        list_heads[4 * list] = 0;
                        list_heads[4 * list + 1] = list_heads[4 * list + 2] = 1;
                        list_heads[4 * list + 3] = 0;
                    }
                }
                auto raster_set = raster_.bind({work_items.get(), &bucket_cursor, &keys});
                auto columns_set = flip_small_.bind({&keys, &bucket_start, &bucket_cursor, &overflow, &toggles, &mask, &keys, &column_frames, &spans,
                                                  &large_buckets, &huge_buckets, &lists, &medium_buckets});
                const RasterParams raster{0, 0, nx, ny, z_begin, slab_layers};

                // The previous batch's last reads of the flips and keys must be done before they
                // are cleared and rewritten (the host wrote the cursors after the fence).
                sequence.barrier();
                if (dirty_column_flips == 0) sequence.fill(toggles, slab_bytes, 0u);  // see host_clears_flips
                if (host_clears_flips) dirty_column_flips = std::size_t(slab_layers);
                sequence.dispatch(raster_, raster_set, raster, items);
                // Every key and final cursor must be in place before the columns sort them.
                sequence.barrier();
                const ColumnParams column_params{0, 0, columns, slab_layers, batch_first - word_first,
                                                 std::uint32_t(batch_first == word_first && batch_frames == word_last - word_first), mask_base};
                sequence.dispatch(flip_small_, columns_set, column_params, columns);
                // The small buckets' flips and spans, and the lists of larger ones, must be in place
                // before the larger ones' atomics add theirs (the three lists' buckets are apart).
                sequence.barrier();
                sequence.dispatch_indirect(flip_medium_, columns_set, column_params, lists, 32);
                sequence.dispatch_indirect(flip_large_, columns_set, column_params, lists, 0);
                sequence.dispatch_indirect(flip_huge_, columns_set, column_params, lists, 16);
                // Every flip and span must be in place before the columns are written.
                sequence.barrier();
                sequence.dispatch(write_columns_, columns_set, column_params, columns);
                // The host reads the overflow value after the fence; the next batch reuses the
                // host-written triangle buffers, so this one must finish first.
                sequence.barrier_to_host();
                sequence.submit_and_wait();
                if (most_column_crossings == 0) {
                    batch_first += batch_frames;
                    continue;
                }
                // A column had more crossings than the column pass may sort. It was skipped; every
                // other column's bits are right and will be ORed again, so the batch is simply
                // redone with fewer frames.
                if (batch_frames == 1)
                    throw Error(fmt::format("{}: a voxel column crosses the surface {} times, more than the {} the Vulkan "
                                            "voxeliser sorts per column (use --backend cpu)",
                                            input.frames[std::size_t(batch_first)].source, most_column_crossings,
                                            options_.max_column_crossings));
                most_column_crossings = 0;
                frames_limit = std::max(1, batch_frames / 2);
                ++plan_.overflow_retries;
            }
            if (!any_work || in_place) continue;  // written in place after each batch's fence
            // The host reads the mask right after the fence.
            sequence.barrier_to_host();
            sequence.submit_and_wait();
            std::memcpy(destination, mask.mapped<std::uint32_t>().data(), destination_bytes);
        }
    }
    flips_left_ = {dirty_column_flips, columns};
}

}  // namespace amhv::gpu
