#include "host/reference/pose_probe.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "host/reference/pose_checks.hpp"
#include "src/core/angles.hpp"
#include "src/core/distance.hpp"

namespace amhv {

PoseProber::PoseProber(const SweepProblem& problem) : problem_(problem) {
    validate(problem);
    sides_ = std::make_unique<PoseSides>(problem);
}

PoseProber::~PoseProber() = default;

namespace {

// The dictionary on the contact voxels (docs/method.md section 5), with the reference's rules:
// labelled types and 0&0 (c) count the voxels that break them, 0&0 (a) and (b) the frames.
void probe_dictionary(const SweepProblem& p, const ContactPairs& contact, PoseProbe& out) {
    if (p.type.lateral_pair() && p.type.variant != 'c') {
        out.touching = touching_frames(p, contact);
        out.touching_needed = p.type.variant == 'a' ? p.touching_frames_needed() : 1;
        out.passes[1] = int(std::count(out.touching.begin(), out.touching.end(), 1)) >= out.touching_needed;
        return;
    }
    for (auto [va, vb] : contact) out.dictionary_violations += breaks_rule(p, va, vb);
    out.passes[1] = out.dictionary_violations == 0;
}

// B's occupied voxels of `volume` under A's lattice at the pose, with their voxels in B's grid: the
// columns of a box around where the pose puts B's volume, pulled.
std::vector<std::pair<LatticeVoxel, std::size_t>> pull_b(const SweepProblem& p, const PoseLookup& lookup, const BVolume& volume, int i, int j,
                                                         int k, int l) {
    const Box3 bounds = summarise(volume.volume).bounds;
    const double h = p.voxel, theta = angles::radians(p.angle_deg(k));
    const Eigen::Rotation2Dd turn(theta);
    Box3 moved;
    for (int c = 0; c < 4; ++c) {
        const Eigen::Vector2d corner((c & 1) ? bounds.max.x() : bounds.min.x(), (c & 2) ? bounds.max.y() : bounds.min.y());
        const Eigen::Vector2d at = turn * (corner - p.b.root.head<2>()) + p.a.root.head<2>() + Eigen::Vector2d(i * h, j * h);
        moved.extend(Vec3(at.x(), at.y(), 0));
    }
    const VoxelGrid& gb = volume.volume.grid();
    const std::int64_t z_first = gb.lattice_origin()[2] + l, z_last = z_first + gb.dims[2] - 1;
    std::vector<std::pair<LatticeVoxel, std::size_t>> pulled;  // A lattice voxel, B voxel
    for (std::int64_t gy = std::int64_t(std::floor(moved.min.y() / h)) - 2; gy <= std::int64_t(std::ceil(moved.max.y() / h)) + 2; ++gy)
        for (std::int64_t gx = std::int64_t(std::floor(moved.min.x() / h)) - 2; gx <= std::int64_t(std::ceil(moved.max.x() / h)) + 2; ++gx)
            for (std::int64_t gz = z_first; gz <= z_last; ++gz) {
                const LatticeVoxel u{0, gx, gy, gz};
                if (auto vb = lookup(volume, u); vb && volume.any(*vb)) pulled.push_back({u, *vb});
            }
    return pulled;
}

// Per frame, the smallest distance between the centres of a voxel of A's interest part and one of
// B's at pose (i, j, k, l) (PoseProbe::gap_m).
std::vector<double> interest_gaps(const SweepProblem& p, const PoseSides& s, const PoseLookup& lookup, int i, int j, int k, int l) {
    const auto pulled = pull_b(p, lookup, s.b.interest, i, j, k, l);
    std::vector<double> gap_m(std::size_t(p.frames()), std::numeric_limits<double>::infinity());
    std::vector<detail::LatticePoint> at_a, at_b;
    for (int t = 0; t < p.frames(); ++t) {
        at_a.clear(), at_b.clear();
        for (const LatticeVoxel& u : s.interest)
            if (p.a.interest.occupied(u.index, t)) at_a.push_back({u.gx, u.gy, u.gz});
        for (const auto& [w, vb] : pulled)
            if (p.b.interest.occupied(vb, t)) at_b.push_back({w.gx, w.gy, w.gz});
        const std::int64_t best = detail::smallest_squared_gap(at_a, at_b);
        if (best != std::numeric_limits<std::int64_t>::max()) gap_m[std::size_t(t)] = p.voxel * std::sqrt(double(best));
    }
    return gap_m;
}

// Whether A's `volume` holds lattice point (gx, gy, gz) at frame t.
bool a_holds(const Amhv& volume, std::int64_t gx, std::int64_t gy, std::int64_t gz, int t) {
    const VoxelGrid& g = volume.grid();
    const auto o = g.lattice_origin();
    const std::int64_t x = gx - o[0], y = gy - o[1], z = gz - o[2];
    if (x < 0 || y < 0 || z < 0 || x >= g.dims[0] || y >= g.dims[1] || z >= g.dims[2]) return false;
    return volume.occupied(g.index(int(x), int(y), int(z)), t);
}

// One frame's interpenetration (PoseProbe::contact_depth_m, other_depth_m) from the voxels where
// the whole bodies overlap: each voxel's depth is d_A + d_B - 2 voxels, d_X the distance from its
// centre to the nearest voxel centre outside X's whole body (exact distance transforms over a box
// around the overlap, widened until every distance found is nearer than the box's edge).
std::pair<double, double> frame_depths(const SweepProblem& p, const BSide& b, const PoseLookup& lookup, const std::vector<detail::LatticePoint>& overlap,
                                       int t) {
    detail::LatticePoint lo = overlap[0], hi = overlap[0];
    for (const auto& q : overlap)
        for (std::size_t c = 0; c < 3; ++c) lo[c] = std::min(lo[c], q[c]), hi[c] = std::max(hi[c], q[c]);
    for (std::int64_t margin = 4;; margin *= 2) {
        const std::array<int, 3> dims{int(hi[0] - lo[0] + 1 + 2 * margin), int(hi[1] - lo[1] + 1 + 2 * margin), int(hi[2] - lo[2] + 1 + 2 * margin)};
        const std::size_t count = std::size_t(dims[0]) * std::size_t(dims[1]) * std::size_t(dims[2]);
        std::vector<double> fa(count), fb(count);
        auto at = [&](std::int64_t gx, std::int64_t gy, std::int64_t gz) {
            return std::size_t(((gz - lo[2] + margin) * dims[1] + (gy - lo[1] + margin)) * dims[0] + (gx - lo[0] + margin));
        };
        for (std::int64_t gz = lo[2] - margin; gz <= hi[2] + margin; ++gz)
            for (std::int64_t gy = lo[1] - margin; gy <= hi[1] + margin; ++gy)
                for (std::int64_t gx = lo[0] - margin; gx <= hi[0] + margin; ++gx) {
                    const auto vb = lookup(b.whole, LatticeVoxel{0, gx, gy, gz});
                    fa[at(gx, gy, gz)] = a_holds(p.a.whole, gx, gy, gz, t) ? 1e30 : 0;
                    fb[at(gx, gy, gz)] = vb && p.b.whole.occupied(*vb, t) ? 1e30 : 0;
                }
        squared_distance_transform(fa, dims);
        squared_distance_transform(fb, dims);
        double contact = 0, other = 0, farthest = 0;
        for (const auto& q : overlap) {
            const double da = std::sqrt(fa[at(q[0], q[1], q[2])]), db = std::sqrt(fb[at(q[0], q[1], q[2])]);
            farthest = std::max({farthest, da, db});
            const auto vb = lookup(b.interest, LatticeVoxel{0, q[0], q[1], q[2]});
            const bool interest = a_holds(p.a.interest, q[0], q[1], q[2], t) && vb && p.b.interest.occupied(*vb, t);
            double& deepest = interest ? contact : other;
            deepest = std::max(deepest, da + db - 2);
        }
        // A voxel outside the box is more than `margin` voxels from every overlap voxel.
        if (farthest <= double(margin) || margin > 4096) return {contact * p.voxel, other * p.voxel};
    }
}

// Per frame, how deep the bodies interpenetrate at pose (i, j, k, l): the interest parts' merge
// and the deepest overlap of any other parts (PoseProbe::contact_depth_m, other_depth_m).
void depths(const SweepProblem& p, const PoseSides& s, const PoseLookup& lookup, int i, int j, int k, int l, PoseProbe& out) {
    const auto pulled = pull_b(p, lookup, s.b.whole, i, j, k, l);
    out.contact_depth_m.assign(std::size_t(p.frames()), 0.0);
    out.other_depth_m.assign(std::size_t(p.frames()), 0.0);
    std::vector<detail::LatticePoint> overlap;
    for (int t = 0; t < p.frames(); ++t) {
        overlap.clear();
        for (const auto& [w, vb] : pulled)
            if (p.b.whole.occupied(vb, t) && a_holds(p.a.whole, w.gx, w.gy, w.gz, t)) overlap.push_back({w.gx, w.gy, w.gz});
        if (overlap.empty()) continue;
        std::tie(out.contact_depth_m[std::size_t(t)], out.other_depth_m[std::size_t(t)]) = frame_depths(p, s.b, lookup, overlap, t);
    }
}

}  // namespace

namespace detail {

std::int64_t smallest_squared_gap(std::vector<LatticePoint>& a, std::vector<LatticePoint>& b) {
    constexpr std::int64_t kNone = std::numeric_limits<std::int64_t>::max();
    if (a.empty() || b.empty()) return kNone;
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    for (const LatticePoint& q : a)
        if (std::binary_search(b.begin(), b.end(), q)) return 0;
    // The points of a set with a face neighbour outside it.
    auto boundary = [](const std::vector<LatticePoint>& set) {
        std::vector<LatticePoint> out;
        for (const LatticePoint& q : set)
            for (int axis = 0; axis < 3; ++axis) {
                LatticePoint below = q, above = q;
                --below[std::size_t(axis)], ++above[std::size_t(axis)];
                if (!std::binary_search(set.begin(), set.end(), below) || !std::binary_search(set.begin(), set.end(), above)) {
                    out.push_back(q);
                    break;
                }
            }
        return out;
    };
    const std::vector<LatticePoint> edge_a = boundary(a), edge_b = boundary(b);
    std::int64_t best = kNone;
    for (const LatticePoint& q : edge_a)
        for (const LatticePoint& r : edge_b) {
            const std::int64_t dx = q[0] - r[0], dy = q[1] - r[1], dz = q[2] - r[2];
            best = std::min(best, dx * dx + dy * dy + dz * dz);
        }
    return best;
}

}  // namespace detail

PoseProbe PoseProber::probe(int i, int j, int k, int l, bool gaps) const {
    const SweepProblem& p = problem_;
    const PoseSides& s = *sides_;
    const BSide& b = s.b;
    const PoseLookup lookup(p, i, j, k, l);
    const int frames = p.frames();
    PoseProbe out;
    out.pose = describe(p, i, j, k, l);

    const ContactPairs contact = contact_pairs(s, lookup);
    out.contact_voxels = contact.size();
    out.passes[0] = !contact.empty();
    probe_dictionary(p, contact, out);

    out.fidelity_voxels.assign(std::size_t(frames), 0);
    for (const LatticeVoxel& u : s.fidelity)
        if (auto vb = lookup(b.fidelity, u))
            for (int t = 0; t < frames; ++t) out.fidelity_voxels[std::size_t(t)] += p.a.fidelity.occupied(u.index, t) && p.b.fidelity.occupied(*vb, t);
    for (const LatticeVoxel& u : s.clearance)  // multi-party: the other placed objects against B's whole body
        if (auto vb = lookup(b.whole, u))
            for (int t = 0; t < frames; ++t) out.fidelity_voxels[std::size_t(t)] += p.a.clearance.occupied(u.index, t) && p.b.whole.occupied(*vb, t);
    out.passes[2] = std::all_of(out.fidelity_voxels.begin(), out.fidelity_voxels.end(), [](std::uint64_t n) { return n == 0; });

    out.passes[3] = true;
    if (p.visibility) {
        Sight seen = sight(p, s, lookup);
        out.passes[3] = seen.passes(p);
        out.visibility_needed = p.per_frame_visibility() ? p.visibility_frames : 1;
        out.a_sees_b = std::move(seen.a_sees_b);
        out.b_sees_a = std::move(seen.b_sees_a);
    }
    out.outcome = PoseOutcome::Solution;
    for (int c = 3; c >= 0; --c)
        if (!out.passes[std::size_t(c)]) out.outcome = PoseOutcome(c);
    if (!gaps) return out;

    out.gap_m = interest_gaps(p, s, lookup, i, j, k, l);
    depths(p, s, lookup, i, j, k, l, out);
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
