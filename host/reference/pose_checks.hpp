#pragma once
// The constraints at one pose (docs/method.md sections 5 and 5a) as the CPU reference decides
// them, in pieces: the reference sweep stops at the first constraint a pose fails, `amhv probe`
// examines every one, and both decide with these same functions.
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "host/reference/lattice_lookup.hpp"

namespace amhv {

// Both objects' volumes as the reference reads them, found once per problem: A's occupied voxels
// with their lattice positions, B's volumes, and the view cones as dense aMHVs.
struct PoseSides {
    explicit PoseSides(const SweepProblem& problem);
    PoseSides(const PoseSides&) = delete;  // `b` refers to `cone_b`
    PoseSides& operator=(const PoseSides&) = delete;

    std::vector<LatticeVoxel> interest, fidelity, whole, cone, clearance;  // A's
    Amhv cone_a, cone_b;  // visibility only
    BSide b;
};

using ContactPairs = std::vector<std::pair<std::size_t, std::size_t>>;  // (A voxel, B voxel) of K

// K = V(I^A) n V(I^B) (eq. 3).
ContactPairs contact_pairs(const PoseSides& s, const PoseLookup& lookup);
// Whether contact voxel pair (va, vb) breaks the rule of a labelled type (eq. 4-11) or of 0&0 (c)
// (B left before A arrived); never for 0&0 (a) and (b), which look at frames.
bool breaks_rule(const SweepProblem& p, std::size_t va, std::size_t vb);
// Per frame: whether the interest parts share a voxel (0&0 a and b).
std::vector<std::uint8_t> touching_frames(const SweepProblem& p, const ContactPairs& contact);

// Fidelity (eq. 15): no voxel of N^A and N^B at the same frame; and in a multi-party stage, no voxel
// of A's clearance volume (the other placed objects) and B's whole body at the same frame.
bool keeps_apart(const SweepProblem& p, const PoseSides& s, const PoseLookup& lookup);

// Mutual visibility (eq. 14): one entry for the swept test, one per frame for per-frame visibility.
struct Sight {
    std::vector<std::uint8_t> a_sees_b, b_sees_a;
    bool passes(const SweepProblem& p) const;
};
Sight sight(const SweepProblem& p, const PoseSides& s, const PoseLookup& lookup);

}  // namespace amhv
