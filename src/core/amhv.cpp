#include "src/core/amhv.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <mutex>
#include <optional>

#include "src/core/budget.hpp"
#include "src/core/error.hpp"
#include "src/core/parallel.hpp"
#include "src/core/process.hpp"

namespace amhv {

namespace {

struct Recycled {
    std::mutex mutex;
    void* block = nullptr;
    std::size_t bytes = 0;
};
// Never destroyed: volumes freed during static destruction still find it.
Recycled& recycled() {
    static Recycled* instance = new Recycled;
    return *instance;
}

constexpr std::size_t kRecycledMinBytes = std::size_t(1) << 20;

}  // namespace

namespace detail {

void* allocate_zeroed(std::size_t bytes) {
    if (bytes >= kRecycledMinBytes && bytes <= kRecycledBytes) {
        Recycled& kept = recycled();
        void* block = nullptr;
        {
            std::lock_guard lock(kept.mutex);
            // Not a block much larger than asked for: it would stay in use, unfreed, for less.
            if (kept.block && kept.bytes >= bytes && kept.bytes / 2 <= bytes) {
                block = std::exchange(kept.block, nullptr);
                kept.bytes = 0;
            }
        }
        if (block) {
            constexpr std::size_t kChunk = std::size_t(1) << 20;
            parallel_for((bytes + kChunk - 1) / kChunk, [&](std::size_t chunk) {
                const std::size_t first = chunk * kChunk;
                std::memset(static_cast<char*>(block) + first, 0, std::min(kChunk, bytes - first));
            });
            return block;
        }
    }
    void* block = std::calloc(bytes, 1);
    advise_huge_pages(block, bytes);
    return block;
}

void free_zeroed(void* block, std::size_t bytes) {
    if (block && bytes >= kRecycledMinBytes && bytes <= kRecycledBytes) {
        Recycled& kept = recycled();
        std::lock_guard lock(kept.mutex);
        std::swap(block, kept.block);
        kept.bytes = bytes;
    }
    std::free(block);  // the one kept before, or one not kept
}

}  // namespace detail

void release_recycled_volume() {
    Recycled& kept = recycled();
    void* block = nullptr;
    {
        std::lock_guard lock(kept.mutex);
        block = std::exchange(kept.block, nullptr);
        kept.bytes = 0;
    }
    std::free(block);
}

Amhv::Amhv(VoxelGrid grid, int frames) : grid_(grid), frames_(frames), words_((frames + 31) / 32) {
    const std::uint64_t bytes = std::uint64_t(words_) * grid_.voxel_count() * sizeof(std::uint32_t);
    reservation_ = budget::Reservation(
        bytes, fmt::format("an aMHV of {} x {} x {} voxels of {} m over {} frames", grid_.dims[0], grid_.dims[1], grid_.dims[2], grid_.voxel, frames),
        fmt::format("use a voxel of at least {} mm or fewer frames", budget::voxel_that_fits(grid_.voxel, 6 * bytes, budget::memory_limit()) * 1000));
    if (frames <= 0) throw Error(fmt::format("an aMHV needs at least one frame, got {}", frames));
    mask_.resize(std::size_t(words_) * grid_.voxel_count());  // zero, see ZeroedAllocator
}

bool Amhv::has_gap(std::size_t voxel) const {
    int first = t_start(voxel);
    if (first < 0) return false;
    return t_end(voxel) - first + 1 != frame_count(voxel);
}

int Amhv::label(std::size_t voxel) const {
    int first = t_start(voxel);
    if (first < 0) return 0;
    if (t_end(voxel) == frames_ - 1) return 1;
    if (first == 0) return -1;
    return 0;
}

AmhvSummary summarise(const Amhv& volume) {
    AmhvSummary summary;
    summary.occupied_per_frame.assign(std::size_t(volume.frames()), 0);
    const auto& grid = volume.grid();
    Vec3 sum = Vec3::Zero();
    for (int z = 0; z < grid.dims[2]; ++z)
        for (int y = 0; y < grid.dims[1]; ++y)
            for (int x = 0; x < grid.dims[0]; ++x) {
                std::size_t v = grid.index(x, y, z);
                if (!volume.any(v)) continue;
                ++summary.occupied_voxels;
                if (volume.has_gap(v)) ++summary.gap_voxels;
                Vec3 c = grid.centre(x, y, z);
                sum += c;
                summary.bounds.extend(c - Vec3::Constant(grid.voxel / 2));
                summary.bounds.extend(c + Vec3::Constant(grid.voxel / 2));
                for (int w = 0; w < volume.words(); ++w) {
                    auto bits = volume.word(w, v);
                    while (bits) {
                        ++summary.occupied_per_frame[std::size_t(w * 32 + std::countr_zero(bits))];
                        bits &= bits - 1;
                    }
                }
            }
    if (summary.occupied_voxels) summary.root = sum / double(summary.occupied_voxels);
    return summary;
}

bool any_occupied(const Amhv& volume) {
    // Blocks of words ORed whole (a loop the compiler vectorises), stopping at the first block with
    // a bit: a part of a body starts deep in its grid, and a word-by-word search ran at a fraction
    // of the memory's speed (a second and a half of a 5 mm edit on the H200 machine's cores).
    const std::uint32_t* words = volume.mask().data();
    const std::size_t count = volume.mask().size();
    constexpr std::size_t kBlock = 1024;
    for (std::size_t first = 0; first < count; first += kBlock) {
        std::uint32_t any = 0;
        const std::size_t last = std::min(count, first + kBlock);
        for (std::size_t w = first; w < last; ++w) any |= words[w];
        if (any) return true;
    }
    return false;
}

namespace {

// Appends to `out` the voxels first .. first + count - 1 (count <= 8) of a slice starting at voxel
// `base` that hold a set bit in any word plane, as indices within the slice.
void append_occupied(const Amhv& volume, std::size_t base, std::uint32_t first, std::uint32_t count, std::vector<std::uint32_t>& out) {
    std::array<std::uint32_t, 8> any{};
    for (int w = 0; w < volume.words(); ++w) {
        const std::uint32_t* words = volume.plane(w) + base + first;
        for (std::uint32_t k = 0; k < count; ++k) any[k] |= words[k];
    }
    for (std::uint32_t k = 0; k < count; ++k)
        if (any[k]) out.push_back(first + k);
}

// Whether voxels base .. base + 7 are all empty in every word plane.
bool eight_empty(const Amhv& volume, std::size_t base) {
    for (int w = 0; w < volume.words(); ++w)
        if (!eight_words_zero(volume.plane(w) + base)) return false;
    return true;
}

}  // namespace

std::vector<std::vector<std::uint32_t>> occupied_by_slice(const Amhv& volume) {
    const auto& grid = volume.grid();
    std::vector<std::vector<std::uint32_t>> slices(std::size_t(std::max(grid.dims[2], 0)));
    const std::size_t per_slice = std::size_t(grid.dims[0]) * std::size_t(grid.dims[1]);
    // Eight voxels at a time: a body fills a few percent of its grid, so most groups are skipped
    // by a few wide reads.
    parallel_for(slices.size(), [&](std::size_t z) {
        const std::size_t base = z * per_slice;
        std::uint32_t v = 0;
        for (; v + 8 <= per_slice; v += 8)
            if (!eight_empty(volume, base + v)) append_occupied(volume, base, v, 8, slices[z]);
        append_occupied(volume, base, v, std::uint32_t(per_slice - v), slices[z]);
    });
    return slices;
}

std::optional<std::array<std::array<int, 3>, 2>> occupied_index_bounds(const Amhv& volume) {
    const auto& grid = volume.grid();
    const auto slices = occupied_by_slice(volume);
    std::array<int, 3> low{grid.dims[0], grid.dims[1], grid.dims[2]}, high{-1, -1, -1};
    for (std::size_t z = 0; z < slices.size(); ++z)
        for (const std::uint32_t v : slices[z]) {
            const int x = int(v % std::uint32_t(grid.dims[0])), y = int(v / std::uint32_t(grid.dims[0]));
            low = {std::min(low[0], x), std::min(low[1], y), std::min(low[2], int(z))};
            high = {std::max(high[0], x), std::max(high[1], y), std::max(high[2], int(z))};
        }
    if (high[0] < 0) return std::nullopt;
    return std::array<std::array<int, 3>, 2>{low, high};
}

// A voxel centre grows with each of its indices (voxel > 0; rounding keeps the order), so the
// bounds of the occupied cubes are those of the extreme indices' cubes.
Box3 occupied_bounds(const Amhv& volume) {
    const auto& grid = volume.grid();
    Box3 bounds;
    const auto extremes = occupied_index_bounds(volume);
    if (!extremes) return bounds;
    const auto& [low, high] = *extremes;
    bounds.extend(grid.centre(low[0], low[1], low[2]) - Vec3::Constant(grid.voxel / 2));
    bounds.extend(grid.centre(high[0], high[1], high[2]) + Vec3::Constant(grid.voxel / 2));
    return bounds;
}

// The centres summed in summarise's order, so the mean is the same to the bit: the occupied
// voxels are found on every core, the sum runs over them alone.
Vec3 occupied_root(const Amhv& volume) {
    const auto& grid = volume.grid();
    const auto slices = occupied_by_slice(volume);
    Vec3 sum = Vec3::Zero();
    std::size_t occupied = 0;
    for (std::size_t z = 0; z < slices.size(); ++z)
        for (const std::uint32_t v : slices[z]) {
            ++occupied;
            sum += grid.centre(int(v % std::uint32_t(grid.dims[0])), int(v / std::uint32_t(grid.dims[0])), int(z));
        }
    return occupied ? Vec3(sum / double(occupied)) : Vec3(Vec3::Zero());
}

}  // namespace amhv
