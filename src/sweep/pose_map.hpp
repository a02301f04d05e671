#pragma once
// The pull mapping of the placement sweep (docs/method.md section 4), in integer arithmetic so the CPU
// reference and the compute shaders (shaders/sweep_pose_map.glsl mirrors this line for line) map every
// column to the same source column, even when a point lands exactly on a voxel boundary.
//
// Pose p = (x, y, theta) = (i h, j h, k dtheta): B is rotated by theta about the vertical axis
// through its root C^B, then moved so its root sits at C^A + (x, y); z is kept. A column u of A's
// lattice takes the value of B's column containing p^-1(centre of u) =
// R(-theta) (centre(u) - C^A - (x, y)) + C^B. Because (x, y) is a whole number of voxels, pose
// (i, j, theta) at column u is pose (0, 0, theta) at column u - (i, j).
#include <cmath>
#include <cstdint>

namespace amhv::posemap {

// Fixed-point formats: positions in 1/2^kPositionBits of a voxel, cos/sin in 1/2^kTrigBits.
inline constexpr int kPositionBits = 12;
inline constexpr int kTrigBits = 24;
// Largest |global lattice index| the mapping accepts; keeps every product below 2^59.
inline constexpr std::int64_t kMaxLatticeIndex = std::int64_t(1) << 20;

struct Trig {
    std::int64_t cos_q = 0, sin_q = 0;
};

// Quantised rotation by `radians`, computed once on the host and handed to every backend.
inline Trig quantise_rotation(double radians) {
    const double scale = double(std::int64_t(1) << kTrigBits);
    return {std::llround(std::cos(radians) * scale), std::llround(std::sin(radians) * scale)};
}

// A root (in voxel units of the lattice, i.e. position / h) in fixed point.
inline std::int64_t quantise_root(double voxel_units) {
    return std::llround(voxel_units * double(std::int64_t(1) << kPositionBits));
}

struct Column {
    std::int64_t x, y;  // global lattice column index in B's capture frame
};

// The pull mapping's products at A column (gx, gy). Along a row, those of column gx + 1 are those of
// gx plus exact constant increments: stepping gives the same columns without the multiplications.
struct Step {
    std::int64_t px = 0, py = 0, dpx = 0, dpy = 0;
    void advance() { px += dpx, py += dpy; }
    // Arithmetic shift: floor division by 2^(position + trig bits) for negative values too.
    Column column() const { return {px >> (kPositionBits + kTrigBits), py >> (kPositionBits + kTrigBits)}; }
};

inline Step source_step(std::int64_t gx, std::int64_t gy, const Trig& trig, std::int64_t root_a_x, std::int64_t root_a_y,
                        std::int64_t root_b_x, std::int64_t root_b_y) {
    constexpr std::int64_t half_voxel = std::int64_t(1) << (kPositionBits - 1);
    const std::int64_t dx = gx * (std::int64_t(1) << kPositionBits) + half_voxel - root_a_x;
    const std::int64_t dy = gy * (std::int64_t(1) << kPositionBits) + half_voxel - root_a_y;
    return {trig.cos_q * dx + trig.sin_q * dy + root_b_x * (std::int64_t(1) << kTrigBits),
            -trig.sin_q * dx + trig.cos_q * dy + root_b_y * (std::int64_t(1) << kTrigBits),
            trig.cos_q * (std::int64_t(1) << kPositionBits), -trig.sin_q * (std::int64_t(1) << kPositionBits)};
}

// B's column under A's column (gx, gy) (global lattice indices, already shifted by -(i, j)).
inline Column source_column(std::int64_t gx, std::int64_t gy, const Trig& trig, std::int64_t root_a_x,
                            std::int64_t root_a_y, std::int64_t root_b_x, std::int64_t root_b_y) {
    return source_step(gx, gy, trig, root_a_x, root_a_y, root_b_x, root_b_y).column();
}

}  // namespace amhv::posemap
