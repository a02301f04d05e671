#pragma once
// `amhv probe` and result.json's near misses: one pose of one key segment examined constraint by
// constraint with the plain CPU reference's mapping (lattice_lookup.hpp), so that its verdict is
// the sweep's: which constraint rejects the pose, at which frames, by how much.
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "src/sweep/problem.hpp"

namespace amhv {

struct PoseSides;

struct PoseProbe {
    Solution pose;                      // the pose and its descriptors
    PoseOutcome outcome = PoseOutcome::FailsContact;  // the sweep's: the first constraint failed
    std::array<bool, 4> passes{};       // contact, dictionary, fidelity, visibility, each on its own
    std::uint64_t contact_voxels = 0;   // |K|: voxels where the interest unions meet
    // Dictionary: labelled types and 0&0 (c) count the contact voxels that break the rule; 0&0 (a)
    // and (b) look at the frames where the parts share a voxel.
    std::uint64_t dictionary_violations = 0;
    std::vector<std::uint8_t> touching;  // per frame (0&0 a and b)
    int touching_needed = 0;
    std::vector<std::uint64_t> fidelity_voxels;  // per frame: voxels where the fidelity parts overlap
    // Visibility: one entry for the swept test, one per frame for per-frame visibility.
    std::vector<std::uint8_t> a_sees_b, b_sees_a;
    int visibility_needed = 0;
    // Per frame: the smallest distance between the centres of a voxel of A's interest part and
    // one of B's (moved), in metres; 0 where they share a voxel. A contact_tolerance of at least
    // this much (beyond the one swept) makes them touch at that frame. Infinity: a part is empty.
    std::vector<double> gap_m;
    // Per frame, how deep the bodies interpenetrate (docs/scenes.md, `amhv probe`), in metres:
    // where both whole bodies hold a voxel, d_A + d_B - 2 voxels (d_X: from the voxel's centre to
    // the nearest voxel centre outside X's whole body), so that bodies sharing one layer of voxels
    // (surfaces within a voxel) read 0 and each further layer one voxel. `contact_depth_m`: the
    // deepest such voxel of both interest parts (A's as the sweep holds it: grown by a
    // contact_tolerance); `other_depth_m`: of any other pair of parts.
    std::vector<double> contact_depth_m, other_depth_m;

    // The constraint that rejects the pose ("" for a solution) and the frames it fails on (every
    // frame for the constraints that are not decided frame by frame).
    std::string failed_constraint() const;
    std::vector<int> failed_frames() const;
};

// Examines poses of one problem; the A side's voxel lists are found once.
class PoseProber {
public:
    explicit PoseProber(const SweepProblem& problem);
    ~PoseProber();
    // Pose (i h, j h, l h, k dtheta); `gaps`: also the per-frame gaps and depths (the slowest part).
    PoseProbe probe(int i, int j, int k, int l, bool gaps = true) const;

private:
    const SweepProblem& problem_;
    std::unique_ptr<PoseSides> sides_;
};

// Names of the constraints in the sweep's order, as messages and result.json use them.
inline constexpr std::array<const char*, 4> kConstraintNames{"contact", "dictionary", "fidelity", "visibility"};

namespace detail {
using LatticePoint = std::array<std::int64_t, 3>;
// The smallest squared distance (in voxels squared) between a point of `a` and one of `b`, or
// INT64_MAX when either is empty. Exact: on disjoint sets a nearest pair lies on both sets'
// boundaries (a point with all six neighbours in its set has a neighbour nearer the other point),
// so only boundary points are compared. Sorts both vectors. Exposed for its test against brute force.
std::int64_t smallest_squared_gap(std::vector<LatticePoint>& a, std::vector<LatticePoint>& b);
}  // namespace detail

}  // namespace amhv
