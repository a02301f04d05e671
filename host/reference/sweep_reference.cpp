#include "host/reference/sweep_reference.hpp"

#include "host/reference/lattice_lookup.hpp"

#include <cmath>
#include <optional>

namespace amhv {

namespace {

struct ASide {
    std::vector<LatticeVoxel> interest, fidelity, whole, cone;
    Amhv cone_volume;  // A's cone as an aMHV (visibility only)
};

// Visibility (eq. 14): A's cone holds a voxel of W^B and B's moved cone a voxel of W^A; per frame
// (visibility_frames), each at frame t with the other's body at frame t, on enough frames.
bool sees_each_other(const SweepProblem& p, const ASide& a, const BSide& b, const PoseLookup& lookup) {
    if (!p.per_frame_visibility()) {
        bool a_sees_b = false, b_sees_a = false;
        for (const LatticeVoxel& u : a.cone)
            if (auto vb = lookup(b.whole, u); vb && b.whole.any(*vb)) {
                a_sees_b = true;
                break;
            }
        for (const LatticeVoxel& u : a.whole)
            if (auto vb = lookup(b.cone, u); vb && b.cone.any(*vb)) {
                b_sees_a = true;
                break;
            }
        return a_sees_b && b_sees_a;
    }
    const Amhv& cone_a = a.cone_volume;
    int a_frames = 0, b_frames = 0;
    for (int t = 0; t < p.frames(); ++t) {
        bool a_sees_b = false, b_sees_a = false;
        for (const LatticeVoxel& u : a.cone)
            if (auto vb = lookup(b.whole, u); vb && cone_a.occupied(u.index, t) && b.whole.volume.occupied(*vb, t)) {
                a_sees_b = true;
                break;
            }
        for (const LatticeVoxel& u : a.whole)
            if (auto vb = lookup(b.cone, u); vb && p.a.whole.occupied(u.index, t) && b.cone.volume.occupied(*vb, t)) {
                b_sees_a = true;
                break;
            }
        a_frames += a_sees_b;
        b_frames += b_sees_a;
    }
    return a_frames >= p.visibility_frames && b_frames >= p.visibility_frames;
}

PoseOutcome evaluate(const SweepProblem& p, const ASide& a, const BSide& b, int i, int j, int k, int l) {
    PoseLookup lookup(p, i, j, k, l);
    const int frames = p.frames();
    const int last = frames - 1;

    // Contact (eq. 3): K = V(I^A) n V(I^B) is not empty.
    std::vector<std::pair<std::size_t, std::size_t>> contact;  // (A voxel, B voxel) of K
    for (const LatticeVoxel& u : a.interest)
        if (auto vb = lookup(b.interest, u); vb && b.interest.any(*vb)) contact.emplace_back(u.index, *vb);
    if (contact.empty()) return PoseOutcome::FailsContact;

    // Interaction dictionary (eq. 4-11).
    const Amhv& ia = p.a.interest;
    const Amhv& ib = p.b.interest;
    if (!p.type.lateral_pair()) {
        for (auto [va, vb] : contact)
            if (!satisfies(p.type.a, ia.t_start(va), ia.t_end(va), last, p.tolerance) ||
                !satisfies(p.type.b, ib.t_start(vb), ib.t_end(vb), last, p.tolerance))
                return PoseOutcome::FailsDictionary;
    } else if (p.type.variant == 'a' || p.type.variant == 'b') {
        // (a): the parts share a voxel at every frame (at contact_frames of them); (b): at some frame.
        int frames_touching = 0;
        for (int t = 0; t < frames; ++t) {
            bool touching = false;
            for (auto [va, vb] : contact)
                if (ia.occupied(va, t) && ib.occupied(vb, t)) {
                    touching = true;
                    break;
                }
            frames_touching += touching;
        }
        bool ok = p.type.variant == 'a' ? frames_touching >= p.touching_frames_needed() : frames_touching > 0;
        if (!ok) return PoseOutcome::FailsDictionary;
    } else {
        // (c): on every contact voxel B left before A arrived.
        for (auto [va, vb] : contact)
            if (!(ia.t_start(va) > ib.t_end(vb))) return PoseOutcome::FailsDictionary;
    }

    // Fidelity (eq. 15): no voxel of N^A and N^B at the same frame.
    for (const LatticeVoxel& u : a.fidelity) {
        auto vb = lookup(b.fidelity, u);
        if (!vb) continue;
        for (int t = 0; t < frames; ++t)
            if (p.a.fidelity.occupied(u.index, t) && p.b.fidelity.occupied(*vb, t)) return PoseOutcome::FailsFidelity;
    }

    if (p.visibility && !sees_each_other(p, a, b, lookup)) return PoseOutcome::FailsVisibility;
    return PoseOutcome::Solution;
}

}  // namespace

SweepResult ReferenceSweeper::sweep(const SweepProblem& problem) { return sweep_angles(problem, 0, problem.range.angles); }

SweepResult ReferenceSweeper::sweep_angles(const SweepProblem& problem, int first_angle, int angle_count) {
    validate(problem);
    SweepResult result;
    const PoseRange& r = problem.range;
    result.range = r;
    result.outcomes.assign(r.size(), PoseOutcome::FailsContact);
    ASide a{occupied_voxels(problem.a.interest), occupied_voxels(problem.a.fidelity), occupied_voxels(problem.a.whole), {}, {}};
    // The plain reference reads the cones as dense volumes (one frame, or one per frame).
    const Amhv cone_b = problem.visibility ? problem.b.view_cone.to_amhv() : Amhv();
    if (problem.visibility) {
        a.cone_volume = problem.a.view_cone.to_amhv();
        a.cone = occupied_voxels(a.cone_volume);
    }
    const BSide b{BVolume(problem.b.interest), BVolume(problem.b.fidelity), BVolume(problem.b.whole), BVolume(cone_b)};
    const int last_angle = std::min(r.angles, first_angle + angle_count);
    const int steps = (last_angle - first_angle) * r.depth();
    for (int l = r.z_first; l <= r.z_last; ++l)
        for (int k = first_angle; k < last_angle; ++k) {
            for (int j = r.j_first; j <= r.j_last; ++j)
                for (int i = r.i_first; i <= r.i_last; ++i) result.outcomes[result.index(i, j, k, l)] = evaluate(problem, a, b, i, j, k, l);
            if (progress) progress((l - r.z_first) * (last_angle - first_angle) + k + 1 - first_angle, steps);
        }
    result.count();
    return result;
}

}  // namespace amhv
