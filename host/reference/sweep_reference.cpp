#include "host/reference/sweep_reference.hpp"

#include "host/reference/pose_checks.hpp"

#include <algorithm>

namespace amhv {

namespace {

// The constraints in order (docs/method.md section 5); the first one failed decides.
PoseOutcome evaluate(const SweepProblem& p, const PoseSides& s, int i, int j, int k, int l) {
    const PoseLookup lookup(p, i, j, k, l);

    // Contact (eq. 3): K is not empty.
    const ContactPairs contact = contact_pairs(s, lookup);
    if (contact.empty()) return PoseOutcome::FailsContact;

    // Interaction dictionary (eq. 4-11): (a) the parts share a voxel at every frame (at
    // contact_frames of them); (b) at some frame; the others on every contact voxel.
    if (p.type.lateral_pair() && p.type.variant != 'c') {
        const auto touching = touching_frames(p, contact);
        const int frames_touching = int(std::count(touching.begin(), touching.end(), 1));
        if (frames_touching < (p.type.variant == 'a' ? p.touching_frames_needed() : 1)) return PoseOutcome::FailsDictionary;
    } else {
        for (auto [va, vb] : contact)
            if (breaks_rule(p, va, vb)) return PoseOutcome::FailsDictionary;
    }

    if (!keeps_apart(p, s, lookup)) return PoseOutcome::FailsFidelity;

    if (p.visibility && !sight(p, s, lookup).passes(p)) return PoseOutcome::FailsVisibility;
    return PoseOutcome::Solution;
}

}  // namespace

SweepResult ReferenceSweeper::sweep(const SweepProblem& problem) {
    return sweep_angles(problem, problem.first_angle, problem.angle_end() - problem.first_angle);
}

SweepResult ReferenceSweeper::sweep_angles(const SweepProblem& problem, int first_angle, int angle_count) {
    validate(problem);
    SweepResult result;
    const PoseRange& r = problem.range;
    result.range = r;
    result.outcomes.assign(r.size(), PoseOutcome::FailsContact);
    // The plain reference reads the cones as dense volumes (one frame, or one per frame).
    const PoseSides sides(problem);
    const int last_angle = std::min(r.angles, first_angle + angle_count);
    const int steps = (last_angle - first_angle) * r.depth();
    for (int l = r.z_first; l <= r.z_last; ++l)
        for (int k = first_angle; k < last_angle; ++k) {
            for (int j = r.j_first; j <= r.j_last; ++j)
                for (int i = r.i_first; i <= r.i_last; ++i) result.outcomes[result.index(i, j, k, l)] = evaluate(problem, sides, i, j, k, l);
            if (progress) progress((l - r.z_first) * (last_angle - first_angle) + k + 1 - first_angle, steps);
        }
    result.count();
    return result;
}

}  // namespace amhv
