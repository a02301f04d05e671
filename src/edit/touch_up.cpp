#include "src/edit/touch_up.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "host/reference/pose_probe.hpp"
#include "src/scene/segment.hpp"

namespace amhv {

namespace {

// Offsets (di, dj) within `reach` voxels, nearest first (then by dj, di: deterministic).
std::vector<std::array<int, 2>> offsets_within(int reach) {
    std::vector<std::array<int, 2>> out;
    for (int dj = -reach; dj <= reach; ++dj)
        for (int di = -reach; di <= reach; ++di)
            if (di * di + dj * dj <= reach * reach) out.push_back({di, dj});
    std::stable_sort(out.begin(), out.end(), [](const auto& p, const auto& q) { return p[0] * p[0] + p[1] * p[1] < q[0] * q[0] + q[1] * q[1]; });
    return out;
}

}  // namespace

ExactKeys::ExactKeys() = default;
ExactKeys::~ExactKeys() = default;

const PoseProber& ExactKeys::prober(const Scene& scene, std::size_t key, ObjectSource& a, ObjectSource& b, Voxeliser& voxeliser) {
    auto& [build, prober] = built_[key];
    if (!prober) {
        KeySegment exact = scene.segments[key];
        exact.contact_tolerance = 0;
        build = std::make_unique<SegmentBuild>(build_segment(scene, exact, a, b, voxeliser));
        prober = std::make_unique<PoseProber>(build->problem);
    }
    return *prober;
}

std::vector<TouchUp> touch_up_choice(const Scene& scene, const std::vector<KeySweep>& sweeps, ObjectSource& a, ObjectSource& b,
                                     Voxeliser& voxeliser, const std::vector<bool>& captured, ExactKeys& exact, ChainChoice& choice) {
    std::vector<TouchUp> out;
    const double h = scene.sampling.voxel;
    for (std::size_t n = 0; n < sweeps.size(); ++n) {
        const KeySegment& key = scene.segments[n];
        const bool touching_type = key.type.lateral_pair() && !key.type.near && (key.type.variant == 'a' || key.type.variant == 'b');
        if (!(key.contact_tolerance > 0) || !touching_type || captured[n]) continue;
        const SolutionGroup& group = sweeps[n].group;
        TouchUp t;
        t.key = key.index;
        t.from = t.to = group.at(std::uint64_t(choice.solution[n]));
        const PoseProber& prober = exact.prober(scene, n, a, b, voxeliser);
        const int reach = int(std::floor(key.contact_tolerance / h + 1e-9));
        for (const auto& [di, dj] : offsets_within(reach)) {
            const PoseIndex q{t.from.i + di, t.from.j + dj, t.from.k, t.from.l};
            if (!group.contains(q) || prober.probe(q.i, q.j, q.k, q.l, false).outcome != PoseOutcome::Solution) continue;
            t.touches = true;
            t.to = q;
            t.moved_m = h * std::sqrt(double(di * di + dj * dj));
            choice.solution[n] = int(group.index_of(q));
            break;
        }
        if (!t.touches)
            t.note = fmt::format("no member of the group within {} m of the chosen pose, at its turn and height, meets without the tolerance: "
                                 "the parts stay up to {} m apart",
                                 key.contact_tolerance, key.contact_tolerance);
        out.push_back(t);
    }
    return out;
}

}  // namespace amhv
