#pragma once
// One key segment pair's constraint satisfaction problem (docs/method.md sections 4-6) and its answer.
#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "src/core/amhv.hpp"
#include "src/core/angles.hpp"
#include "src/core/process.hpp"
#include "src/sweep/interaction.hpp"
#include "src/sweep/pose_map.hpp"

namespace amhv {

// The voxels of a grid whose centres lie inside a view cone, stored per vertical column: the cone
// and its range ball are convex, so each column holds one interval of voxels. This keeps the cone
// small where a dense volume would not be (a cone over every pose's reach spans 10^8 voxels at 1 cm).
// One cone for the whole segment (the paper's test), or one per frame (per-frame visibility).
struct ConeVolume {
    VoxelGrid grid;  // dims 0: no cone
    int frames = 1;  // 1: one cone for the segment; else one per normalised frame
    // Per frame, then column y * nx + x: the first and last voxel z inside (first > last: none).
    std::vector<std::array<std::int32_t, 2>> spans;
    bool empty() const { return spans.empty(); }
    std::size_t columns() const { return std::size_t(grid.dims[0]) * std::size_t(grid.dims[1]); }
    const std::array<std::int32_t, 2>& span(int x, int y, int frame = 0) const {
        return spans[std::size_t(frame) * columns() + std::size_t(y) * std::size_t(grid.dims[0]) + std::size_t(x)];
    }
    // The same voxels as an aMHV of `frames` frames (the plain CPU reference reads cones this way).
    Amhv to_amhv() const;
};

// One object's volumes in one key segment, all on the object's segment grid and over the same
// normalised frames; `view_cone` (any grid of the same edge) is the set of voxels whose centre
// lies inside the object's view cone.
struct SweepObject {
    std::string name;
    Amhv interest;  // I: the contact part
    Amhv fidelity;  // N: must never share a voxel with the other's N at the same frame
    Amhv whole;     // W: the whole body, seen by the other's view cone
    // A's side of a multi-party stage only (docs/method.md section 11): the placed objects other
    // than the partner, which must never share a voxel with B's whole body at the same frame.
    // Default-constructed (no frames): no such test.
    Amhv clearance;
    bool has_clearance() const { return clearance.frames() > 0; }
    ConeVolume view_cone;  // empty when visibility is not asked for
    Vec3 root = Vec3::Zero();                        // C: of the whole body's aMHV
    Eigen::Vector2d facing = Eigen::Vector2d::UnitX();  // F: unit, on the floor
};

// Poses (i h, j h, l h, k dtheta) for i in [i_first, i_last], j in [j_first, j_last], k in
// [0, angles) and B raised by l in [z_first, z_last] voxels (z_range; 0 and 0 without it).
struct PoseRange {
    int i_first = 0, i_last = -1, j_first = 0, j_last = -1;
    int angles = 0;
    int z_first = 0, z_last = 0;
    int width() const { return i_last - i_first + 1; }
    int height() const { return j_last - j_first + 1; }
    int depth() const { return z_last - z_first + 1; }
    // Poses of one height.
    std::uint64_t per_level() const { return width() > 0 && height() > 0 ? std::uint64_t(width()) * height() * angles : 0; }
    std::uint64_t size() const { return depth() > 0 ? per_level() * std::uint64_t(depth()) : 0; }
};

struct SweepProblem {
    SweepObject a, b;
    InteractionType type;
    int tolerance = 0;        // epsilon, in frames, for the '+' and '-' labels
    // 0&0 (a): the parts must touch on at least this many frames (contact_frames); 0: on every one.
    int contact_frames = 0;
    bool visibility = false;  // test mutual visibility (both objects need a view cone)
    // Per-frame visibility (both cones have one cone per frame): each cone at frame t must hold a
    // voxel of the other's body at frame t on at least this many frames. 0: the swept-body test.
    int visibility_frames = 0;
    double voxel = 0.01;
    double angle_step_deg = 2.0;
    PoseRange range;
    // The angles this sweep tests, k in [first_angle, first_angle + angle_count) (a shard of the
    // scene's work, `amhv sweep --shard`); the other angles' poses stay FailsContact. -1: all.
    int first_angle = 0, angle_count = -1;

    int angle_end() const { return angle_count < 0 ? range.angles : std::min(range.angles, first_angle + angle_count); }

    int frames() const { return a.interest.frames(); }
    // Frames the 0&0 (a) parts must touch on.
    int touching_frames_needed() const { return contact_frames > 0 ? contact_frames : frames(); }
    bool per_frame_visibility() const { return visibility && visibility_frames > 0; }
    double angle_deg(int k) const { return k * angle_step_deg; }
    // The angle lattice of the poses (validate() checks that the step and the count agree).
    angles::AngleLattice angle_lattice() const { return {angle_step_deg, range.angles}; }
    posemap::Trig trig(int k) const;
    // Roots in the fixed point of pose_map.hpp.
    std::array<std::int64_t, 2> root_a_q() const;
    std::array<std::int64_t, 2> root_b_q() const;
};

// Checks the invariants the sweep relies on (shared grids, frame counts, lattice alignment, sizes)
// and throws amhv::Error naming what is wrong.
void validate(const SweepProblem& problem);

// Every offset at which B's interest volume can touch A's under some angle (docs/method.md section 4),
// optionally narrowed to [x_min, x_max] x [y_min, y_max] metres.
PoseRange automatic_range(const SweepObject& a, const SweepObject& b, double voxel, int angles);
void narrow_range(PoseRange& range, double voxel, const std::array<double, 2>* x_range, const std::array<double, 2>* y_range);

// Outcome of one pose: how far down the order of tests (contact, dictionary, fidelity, visibility) it got.
enum class PoseOutcome : std::uint8_t { FailsContact = 0, FailsDictionary = 1, FailsFidelity = 2, FailsVisibility = 3, Solution = 4 };

struct Solution {
    int i = 0, j = 0, k = 0, l = 0;           // l: B raised by l voxels (z_range)
    double x = 0, y = 0, theta_deg = 0;       // theta wrapped to (-180, 180]
    double z = 0;                             // l h
    double distance = 0;                      // L = |C^A C'^B|
    double theta_a_deg = 0, theta_b_deg = 0;  // docs/method.md section 6
};

struct SweepResult {
    PoseRange range;
    // One outcome per pose, [l - z_first][k][j - j_first][i - i_first].
    std::vector<PoseOutcome, CallocAllocator<PoseOutcome>> outcomes;  // FailsContact (0) where never written
    std::array<std::uint64_t, 4> rejected{};  // contact, dictionary, fidelity, visibility
    std::uint64_t solutions = 0;

    std::size_t index(int i, int j, int k, int l = 0) const {
        return ((std::size_t(l - range.z_first) * std::size_t(range.angles) + std::size_t(k)) * std::size_t(range.height()) +
                std::size_t(j - range.j_first)) * std::size_t(range.width()) + std::size_t(i - range.i_first);
    }
    PoseOutcome at(int i, int j, int k, int l = 0) const { return outcomes[index(i, j, k, l)]; }
    // The furthest outcome of (i, j, k) over B's heights (a solution at any height is a solution).
    PoseOutcome best_over_heights(int i, int j, int k) const {
        PoseOutcome best = PoseOutcome::FailsContact;
        for (int l = range.z_first; l <= range.z_last; ++l) best = std::max(best, at(i, j, k, l));
        return best;
    }
    void count();  // fills rejected and solutions from outcomes
};

// "contact N, dictionary N, fidelity N, visibility N" for messages.
std::string rejection_counts(const std::array<std::uint64_t, 4>& rejected);

// The paper's descriptors of pose (i, j, k, l).
Solution describe(const SweepProblem& problem, int i, int j, int k, int l = 0);

class Sweeper {
public:
    virtual ~Sweeper() = default;
    // Called with (angles done, angles in all) as the sweep goes on; may be empty.
    std::function<void(int, int)> progress;
    virtual std::string name() const = 0;
    virtual SweepResult sweep(const SweepProblem& problem) = 0;
    // Wall seconds of the last sweep per constraint stage (contact, dictionary, fidelity,
    // visibility), where the backend measures them; empty otherwise.
    virtual std::vector<double> stage_seconds() const { return {}; }
    // Wall seconds of the last sweep spent waiting for a device's submits (the rest of the stages'
    // time is the host's), where there is a device; negative otherwise.
    virtual double device_wait_seconds() const { return -1; }
};

}  // namespace amhv
