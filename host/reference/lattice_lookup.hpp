#pragma once
// The plain CPU reference's view of one pose (docs/method.md section 4): A's occupied voxels with
// their global lattice positions, and the pull mapping of a pose into B's volumes, raised by l
// voxels. Shared by the reference sweep and the pose probe, so both decide exactly alike.
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "src/sweep/problem.hpp"

namespace amhv {

// An occupied voxel of a volume on the A side, with its global lattice position.
struct LatticeVoxel {
    std::size_t index;
    std::int64_t gx, gy, gz;
};

inline std::vector<LatticeVoxel> occupied_voxels(const Amhv& volume) {
    std::vector<LatticeVoxel> list;
    const VoxelGrid& g = volume.grid();
    auto o = g.lattice_origin();
    for (int z = 0; z < g.dims[2]; ++z)
        for (int y = 0; y < g.dims[1]; ++y)
            for (int x = 0; x < g.dims[0]; ++x) {
                std::size_t v = g.index(x, y, z);
                if (volume.any(v)) list.push_back({v, o[0] + x, o[1] + y, o[2] + z});
            }
    return list;
}

// A volume of B with its lattice origin, found once per sweep.
struct BVolume {
    const Amhv& volume;
    std::array<std::int64_t, 3> origin;
    explicit BVolume(const Amhv& v) : volume(v), origin(v.grid().lattice_origin()) {}
    bool any(std::size_t voxel) const { return volume.any(voxel); }
};

struct BSide {
    BVolume interest, fidelity, whole, cone;
};

// The pull mapping of one pose into one volume of B.
class PoseLookup {
public:
    PoseLookup(const SweepProblem& problem, int i, int j, int k, int l)
        : i_(i), j_(j), l_(l), trig_(problem.trig(k)), root_a_(problem.root_a_q()), root_b_(problem.root_b_q()) {}

    // B's voxel of `volume` under A's lattice voxel `u`, if inside B's grid.
    std::optional<std::size_t> operator()(const BVolume& b, const LatticeVoxel& u) const {
        auto source = posemap::source_column(u.gx - i_, u.gy - j_, trig_, root_a_[0], root_a_[1], root_b_[0], root_b_[1]);
        const VoxelGrid& g = b.volume.grid();
        const auto& o = b.origin;
        std::int64_t x = source.x - o[0], y = source.y - o[1], z = u.gz - l_ - o[2];  // B raised by l voxels
        if (x < 0 || y < 0 || z < 0 || x >= g.dims[0] || y >= g.dims[1] || z >= g.dims[2]) return std::nullopt;
        return g.index(int(x), int(y), int(z));
    }

private:
    int i_, j_, l_;
    posemap::Trig trig_;
    std::array<std::int64_t, 2> root_a_, root_b_;
};

// Whether a contact voxel with these first and last frames meets a '+' or '-' label (eq. 4-11).
inline bool satisfies(SurfaceLabel label, int t_start, int t_end, int last_frame, int tolerance) {
    switch (label) {
        case SurfaceLabel::Plus: return t_end >= last_frame - tolerance;  // t_end = T_end, within epsilon
        case SurfaceLabel::Minus: return t_start <= tolerance;           // t_start = T_start = 0, within epsilon
        default: return true;
    }
}

}  // namespace amhv
