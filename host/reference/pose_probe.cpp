#include "host/reference/pose_probe.hpp"

#include <algorithm>
#include <cmath>

#include "host/reference/lattice_lookup.hpp"
#include "src/core/angles.hpp"

namespace amhv {

struct PoseProber::Sides {
    std::vector<LatticeVoxel> interest, fidelity, whole, cone;
    Amhv cone_a, cone_b;  // the cones as aMHVs (visibility only)
    std::unique_ptr<BSide> b;
};

PoseProber::PoseProber(const SweepProblem& problem) : problem_(problem), sides_(std::make_unique<Sides>()) {
    validate(problem);
    Sides& s = *sides_;
    s.interest = occupied_voxels(problem.a.interest);
    s.fidelity = occupied_voxels(problem.a.fidelity);
    s.whole = occupied_voxels(problem.a.whole);
    if (problem.visibility) {
        s.cone_a = problem.a.view_cone.to_amhv();
        s.cone_b = problem.b.view_cone.to_amhv();
        s.cone = occupied_voxels(s.cone_a);
    }
    s.b = std::make_unique<BSide>(BSide{BVolume(problem.b.interest), BVolume(problem.b.fidelity), BVolume(problem.b.whole), BVolume(s.cone_b)});
}

PoseProber::~PoseProber() = default;

namespace {

using Contact = std::vector<std::pair<std::size_t, std::size_t>>;  // (A voxel, B voxel) of K

// The dictionary on the contact voxels (docs/method.md section 5), as the reference decides it.
void probe_dictionary(const SweepProblem& p, const Contact& contact, PoseProbe& out) {
    const Amhv& ia = p.a.interest;
    const Amhv& ib = p.b.interest;
    const int last = p.frames() - 1;
    if (!p.type.lateral_pair()) {
        for (auto [va, vb] : contact)
            out.dictionary_violations += !satisfies(p.type.a, ia.t_start(va), ia.t_end(va), last, p.tolerance) ||
                                         !satisfies(p.type.b, ib.t_start(vb), ib.t_end(vb), last, p.tolerance);
        out.passes[1] = out.dictionary_violations == 0;
    } else if (p.type.variant == 'a' || p.type.variant == 'b') {
        out.touching.assign(std::size_t(p.frames()), 0);
        for (int t = 0; t < p.frames(); ++t)
            for (auto [va, vb] : contact)
                if (ia.occupied(va, t) && ib.occupied(vb, t)) {
                    out.touching[std::size_t(t)] = 1;
                    break;
                }
        const int frames = int(std::count(out.touching.begin(), out.touching.end(), 1));
        out.touching_needed = p.type.variant == 'a' ? p.touching_frames_needed() : 1;
        out.passes[1] = frames >= out.touching_needed;
    } else {
        for (auto [va, vb] : contact) out.dictionary_violations += !(ia.t_start(va) > ib.t_end(vb));
        out.passes[1] = out.dictionary_violations == 0;
    }
}

}  // namespace

PoseProbe PoseProber::probe(int i, int j, int k, int l, bool gaps) const {
    const SweepProblem& p = problem_;
    const Sides& s = *sides_;
    const BSide& b = *s.b;
    const PoseLookup lookup(p, i, j, k, l);
    const int frames = p.frames();
    PoseProbe out;
    out.pose = describe(p, i, j, k, l);

    Contact contact;
    for (const LatticeVoxel& u : s.interest)
        if (auto vb = lookup(b.interest, u); vb && b.interest.any(*vb)) contact.emplace_back(u.index, *vb);
    out.contact_voxels = contact.size();
    out.passes[0] = !contact.empty();
    probe_dictionary(p, contact, out);

    out.fidelity_voxels.assign(std::size_t(frames), 0);
    for (const LatticeVoxel& u : s.fidelity)
        if (auto vb = lookup(b.fidelity, u))
            for (int t = 0; t < frames; ++t) out.fidelity_voxels[std::size_t(t)] += p.a.fidelity.occupied(u.index, t) && p.b.fidelity.occupied(*vb, t);
    out.passes[2] = std::all_of(out.fidelity_voxels.begin(), out.fidelity_voxels.end(), [](std::uint64_t n) { return n == 0; });

    out.passes[3] = true;
    if (p.visibility) {
        const int cones = p.per_frame_visibility() ? frames : 1;
        out.a_sees_b.assign(std::size_t(cones), 0);
        out.b_sees_a.assign(std::size_t(cones), 0);
        for (int t = 0; t < cones; ++t) {
            const bool swept = cones == 1;
            for (const LatticeVoxel& u : s.cone)
                if (auto vb = lookup(b.whole, u);
                    vb && (swept ? b.whole.any(*vb) : s.cone_a.occupied(u.index, t) && p.b.whole.occupied(*vb, t))) {
                    out.a_sees_b[std::size_t(t)] = 1;
                    break;
                }
            for (const LatticeVoxel& u : s.whole)
                if (auto vb = lookup(b.cone, u); vb && (swept ? b.cone.any(*vb) : p.a.whole.occupied(u.index, t) && s.cone_b.occupied(*vb, t))) {
                    out.b_sees_a[std::size_t(t)] = 1;
                    break;
                }
        }
        out.visibility_needed = p.per_frame_visibility() ? p.visibility_frames : 1;
        const auto count = [](const std::vector<std::uint8_t>& v) { return int(std::count(v.begin(), v.end(), 1)); };
        out.passes[3] = count(out.a_sees_b) >= out.visibility_needed && count(out.b_sees_a) >= out.visibility_needed;
    }
    out.outcome = PoseOutcome::Solution;
    for (int c = 3; c >= 0; --c)
        if (!out.passes[std::size_t(c)]) out.outcome = PoseOutcome(c);
    if (!gaps) return out;

    // B's interest voxels under A's lattice: the columns of a box around where the pose puts them.
    const Box3 bounds = summarise(p.b.interest).bounds;
    const double h = p.voxel, theta = angles::radians(p.angle_deg(k));
    const Eigen::Rotation2Dd turn(theta);
    Box3 moved;
    for (int c = 0; c < 4; ++c) {
        const Eigen::Vector2d corner((c & 1) ? bounds.max.x() : bounds.min.x(), (c & 2) ? bounds.max.y() : bounds.min.y());
        const Eigen::Vector2d at = turn * (corner - p.b.root.head<2>()) + p.a.root.head<2>() + Eigen::Vector2d(i * h, j * h);
        moved.extend(Vec3(at.x(), at.y(), 0));
    }
    const VoxelGrid& gb = p.b.interest.grid();
    const std::int64_t z_first = gb.lattice_origin()[2] + l, z_last = z_first + gb.dims[2] - 1;
    std::vector<std::pair<LatticeVoxel, std::size_t>> pulled;  // A lattice voxel, B voxel
    for (std::int64_t gy = std::int64_t(std::floor(moved.min.y() / h)) - 2; gy <= std::int64_t(std::ceil(moved.max.y() / h)) + 2; ++gy)
        for (std::int64_t gx = std::int64_t(std::floor(moved.min.x() / h)) - 2; gx <= std::int64_t(std::ceil(moved.max.x() / h)) + 2; ++gx)
            for (std::int64_t gz = z_first; gz <= z_last; ++gz) {
                const LatticeVoxel u{0, gx, gy, gz};
                if (auto vb = lookup(b.interest, u); vb && b.interest.any(*vb)) pulled.push_back({u, *vb});
            }
    out.gap_m.assign(std::size_t(frames), std::numeric_limits<double>::infinity());
    for (int t = 0; t < frames; ++t) {
        std::int64_t best = std::numeric_limits<std::int64_t>::max();
        for (const LatticeVoxel& u : s.interest) {
            if (!p.a.interest.occupied(u.index, t)) continue;
            for (const auto& [w, vb] : pulled) {
                if (!p.b.interest.occupied(vb, t)) continue;
                const std::int64_t dx = u.gx - w.gx, dy = u.gy - w.gy, dz = u.gz - w.gz;
                best = std::min(best, dx * dx + dy * dy + dz * dz);
            }
            if (best == 0) break;
        }
        if (best != std::numeric_limits<std::int64_t>::max()) out.gap_m[std::size_t(t)] = h * std::sqrt(double(best));
    }
    return out;
}

std::string PoseProbe::failed_constraint() const {
    return outcome == PoseOutcome::Solution ? std::string() : std::string(kConstraintNames[std::size_t(outcome)]);
}

std::vector<int> PoseProbe::failed_frames() const {
    const int frames = int(fidelity_voxels.size());
    std::vector<int> out;
    for (int t = 0; t < frames; ++t) {
        bool fails = false;
        switch (outcome) {
            case PoseOutcome::Solution: break;
            case PoseOutcome::FailsDictionary: fails = touching.empty() || !touching[std::size_t(t)]; break;
            case PoseOutcome::FailsFidelity: fails = fidelity_voxels[std::size_t(t)] > 0; break;
            case PoseOutcome::FailsVisibility:
                fails = a_sees_b.size() == 1 || !a_sees_b[std::size_t(t)] || !b_sees_a[std::size_t(t)];
                break;
            default: fails = true; break;
        }
        if (fails) out.push_back(t);
    }
    return out;
}

}  // namespace amhv
