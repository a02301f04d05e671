#pragma once
// The augmented Motion History Volume of one object over one segment (METHOD.md section 3):
// per voxel, the full occupancy mask over the segment's frames.
#include <bit>
#include <cstdint>
#include <vector>

#include "core/grid.hpp"

namespace amhv {

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
    const std::vector<std::uint32_t>& mask() const { return mask_; }

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
    std::vector<std::uint32_t> mask_;
};

struct AmhvSummary {
    std::size_t occupied_voxels = 0;
    std::size_t gap_voxels = 0;
    Vec3 root = Vec3::Zero();  // mean of the occupied voxel centres (METHOD.md: root C)
    Box3 bounds;               // of the occupied voxels (their full cubes)
    std::vector<std::size_t> occupied_per_frame;
};

AmhvSummary summarise(const Amhv& volume);

}  // namespace amhv
