#pragma once
// The augmented Motion History Volume of one object over one segment (docs/method.md section 3):
// per voxel, the full occupancy mask over the segment's frames.
#include <array>
#include <bit>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <new>
#include <optional>
#include <utility>
#include <vector>

#include "src/core/budget.hpp"
#include "src/core/grid.hpp"
#include "src/core/process.hpp"

namespace amhv {

namespace detail {
// Zeroed memory for volumes. A new block comes from calloc: a large one straight from the kernel's
// zero pages, so a new volume costs nothing until its pages are written (voxelisers write only the
// voxels some frame occupies, and untouched pages of a mostly empty volume are never faulted in).
// The last large block freed (1 MiB to kRecycledBytes) is kept and given to the next volume it
// fits, cleared on all cores: glibc would serve it from fresh heap pages for the next few calls
// (about 3 900 page faults each for a 30 MiB volume at 10 mm, up to 10 ms) and then clear it on
// one thread inside calloc (1.5 ms). The block kept is released by release_recycled_volume.
inline constexpr std::size_t kRecycledBytes = std::size_t(256) << 20;
void* allocate_zeroed(std::size_t bytes);
void free_zeroed(void* block, std::size_t bytes);
}  // namespace detail

// Frees the block kept for the next volume (see detail::allocate_zeroed), if any.
void release_recycled_volume();

namespace detail {
struct RecycledVolumeBlocks {
    static void* allocate(std::size_t bytes) { return allocate_zeroed(bytes); }
    static void free(void* block, std::size_t bytes) { free_zeroed(block, bytes); }
};
}  // namespace detail

// Zeroed memory from detail::allocate_zeroed (the aMHV's mask), value-initialised elements left as
// they are (ZeroFilledAllocator).
template <typename T>
using ZeroedAllocator = ZeroFilledAllocator<T, detail::RecycledVolumeBlocks>;

class Amhv {
public:
    Amhv() = default;
    Amhv(VoxelGrid grid, int frames);

    const VoxelGrid& grid() const { return grid_; }
    int frames() const { return frames_; }
    int words() const { return words_; }
    std::size_t voxel_count() const { return grid_.voxel_count(); }

    // Word-plane layout: word w of every voxel is contiguous ([word][z][y][x]), so a kernel that
    // handles 32 frames writes one plane.
    std::uint32_t* plane(int word) { return mask_.data() + std::size_t(word) * voxel_count(); }
    const std::uint32_t* plane(int word) const { return mask_.data() + std::size_t(word) * voxel_count(); }
    std::uint32_t word(int w, std::size_t voxel) const { return mask_[std::size_t(w) * voxel_count() + voxel]; }
    bool occupied(std::size_t voxel, int frame) const { return (word(frame / 32, voxel) >> (frame % 32)) & 1u; }
    void set(std::size_t voxel, int frame) { mask_[std::size_t(frame / 32) * voxel_count() + voxel] |= 1u << (frame % 32); }
    using Mask = std::vector<std::uint32_t, ZeroedAllocator<std::uint32_t>>;
    const Mask& mask() const { return mask_; }

    // Derived per-voxel quantities; t_start/t_end are -1 for an empty voxel. Inline: the sweep's
    // host stages call them for every voxel of large volumes.
    int t_start(std::size_t voxel) const {
        for (int w = 0; w < words_; ++w)
            if (auto bits = word(w, voxel)) return w * 32 + std::countr_zero(bits);
        return -1;
    }
    int t_end(std::size_t voxel) const {
        for (int w = words_ - 1; w >= 0; --w)
            if (auto bits = word(w, voxel)) return w * 32 + 31 - std::countl_zero(bits);
        return -1;
    }
    int frame_count(std::size_t voxel) const {
        int count = 0;
        for (int w = 0; w < words_; ++w) count += std::popcount(word(w, voxel));
        return count;
    }
    bool any(std::size_t voxel) const {
        for (int w = 0; w < words_; ++w)
            if (word(w, voxel)) return true;
        return false;
    }
    // True when the voxel's occupied frames are not one interval.
    bool has_gap(std::size_t voxel) const;
    // Surface label (paper Fig. 4): +1 on the ending surface (t_end = T_end), -1 on the starting
    // surface (t_start = 0), 0 lateral. A voxel on both surfaces is labelled +1. Empty: 0.
    int label(std::size_t voxel) const;

private:
    VoxelGrid grid_;
    int frames_ = 0;
    int words_ = 0;
    budget::Reservation reservation_;  // the mask's bytes, against the run's memory budget
    Mask mask_;
};

struct AmhvSummary {
    std::size_t occupied_voxels = 0;
    std::size_t gap_voxels = 0;
    Vec3 root = Vec3::Zero();  // mean of the occupied voxel centres (docs/method.md section 3: root C)
    Box3 bounds;               // of the occupied voxels (their full cubes)
    std::vector<std::size_t> occupied_per_frame;
};

AmhvSummary summarise(const Amhv& volume);
// Parts of the summary on their own, for callers that need only one (each costs a fraction of the
// whole): whether any voxel is occupied (stops at the first), summarise(volume).bounds, and
// summarise(volume).root, the same values to the bit.
bool any_occupied(const Amhv& volume);
Box3 occupied_bounds(const Amhv& volume);
Vec3 occupied_root(const Amhv& volume);

// Whether words[0..7] are all zero (four 64-bit reads): scans of a mostly empty plane skip eight
// voxels at once.
inline bool eight_words_zero(const std::uint32_t* words) {
    std::array<std::uint64_t, 4> four;
    std::memcpy(four.data(), words, sizeof four);
    return (four[0] | four[1] | four[2] | four[3]) == 0;
}

// Per z slice, the indices (y * nx + x) of its occupied voxels in increasing order, found on every
// core: a caller that must visit them in (z, y, x) order, such as a floating-point sum, then visits
// the occupied ones alone.
std::vector<std::vector<std::uint32_t>> occupied_by_slice(const Amhv& volume);
// The lowest and the highest index of the occupied voxels along each axis (none: empty volume).
std::optional<std::array<std::array<int, 3>, 2>> occupied_index_bounds(const Amhv& volume);

}  // namespace amhv
