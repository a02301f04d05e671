#include "host/reference/pose_checks.hpp"

#include <algorithm>

namespace amhv {

PoseSides::PoseSides(const SweepProblem& problem)
    : interest(occupied_voxels(problem.a.interest)),
      fidelity(occupied_voxels(problem.a.fidelity)),
      whole(occupied_voxels(problem.a.whole)),
      cone_a(problem.visibility ? problem.a.view_cone.to_amhv() : Amhv()),
      cone_b(problem.visibility ? problem.b.view_cone.to_amhv() : Amhv()),
      b{BVolume(problem.b.interest), BVolume(problem.b.fidelity), BVolume(problem.b.whole), BVolume(cone_b)} {
    if (problem.visibility) cone = occupied_voxels(cone_a);
    if (problem.a.has_clearance()) clearance = occupied_voxels(problem.a.clearance);
}

bool keeps_apart(const SweepProblem& p, const PoseSides& s, const PoseLookup& lookup) {
    auto meet = [&](const std::vector<LatticeVoxel>& list, const Amhv& a, const BVolume& b) {
        for (const LatticeVoxel& u : list) {
            auto vb = lookup(b, u);
            if (!vb) continue;
            for (int t = 0; t < p.frames(); ++t)
                if (a.occupied(u.index, t) && b.volume.occupied(*vb, t)) return true;
        }
        return false;
    };
    return !meet(s.fidelity, p.a.fidelity, s.b.fidelity) && !(p.a.has_clearance() && meet(s.clearance, p.a.clearance, s.b.whole));
}

ContactPairs contact_pairs(const PoseSides& s, const PoseLookup& lookup) {
    ContactPairs contact;
    for (const LatticeVoxel& u : s.interest)
        if (auto vb = lookup(s.b.interest, u); vb && s.b.interest.any(*vb)) contact.emplace_back(u.index, *vb);
    return contact;
}

bool breaks_rule(const SweepProblem& p, std::size_t va, std::size_t vb) {
    const Amhv& ia = p.a.interest;
    const Amhv& ib = p.b.interest;
    const int last = p.frames() - 1;
    if (!p.type.lateral_pair())
        return !satisfies(p.type.a, ia.t_start(va), ia.t_end(va), last, p.tolerance) ||
               !satisfies(p.type.b, ib.t_start(vb), ib.t_end(vb), last, p.tolerance);
    if (p.type.variant == 'c') return !(ia.t_start(va) > ib.t_end(vb));  // on K, B left before A arrived
    return false;
}

std::vector<std::uint8_t> touching_frames(const SweepProblem& p, const ContactPairs& contact) {
    std::vector<std::uint8_t> touching(std::size_t(p.frames()), 0);
    for (int t = 0; t < p.frames(); ++t)
        for (auto [va, vb] : contact)
            if (p.a.interest.occupied(va, t) && p.b.interest.occupied(vb, t)) {
                touching[std::size_t(t)] = 1;
                break;
            }
    return touching;
}

bool Sight::passes(const SweepProblem& p) const {
    const int needed = p.per_frame_visibility() ? p.visibility_frames : 1;
    return int(std::count(a_sees_b.begin(), a_sees_b.end(), 1)) >= needed && int(std::count(b_sees_a.begin(), b_sees_a.end(), 1)) >= needed;
}

// Swept (one entry): A's cone holds a voxel of W^B and B's moved cone a voxel of W^A. Per frame:
// each cone at frame t holds a voxel of the other's body at frame t.
Sight sight(const SweepProblem& p, const PoseSides& s, const PoseLookup& lookup) {
    const int cones = p.per_frame_visibility() ? p.frames() : 1;
    Sight out{std::vector<std::uint8_t>(std::size_t(cones), 0), std::vector<std::uint8_t>(std::size_t(cones), 0)};
    for (int t = 0; t < cones; ++t) {
        const bool swept = cones == 1;
        for (const LatticeVoxel& u : s.cone)
            if (auto vb = lookup(s.b.whole, u); vb && (swept ? s.b.whole.any(*vb) : s.cone_a.occupied(u.index, t) && p.b.whole.occupied(*vb, t))) {
                out.a_sees_b[std::size_t(t)] = 1;
                break;
            }
        for (const LatticeVoxel& u : s.whole)
            if (auto vb = lookup(s.b.cone, u); vb && (swept ? s.b.cone.any(*vb) : p.a.whole.occupied(u.index, t) && s.cone_b.occupied(*vb, t))) {
                out.b_sees_a[std::size_t(t)] = 1;
                break;
            }
    }
    return out;
}

}  // namespace amhv
