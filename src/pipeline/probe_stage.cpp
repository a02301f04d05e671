#include "src/pipeline/probe_stage.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "src/core/angles.hpp"
#include "src/core/error.hpp"

namespace amhv::pipeline {

namespace {

// The lattice pose nearest to (x, y, theta, z), and a note when it is not the pose asked for.
std::array<int, 4> snap(const SweepProblem& p, double x, double y, double theta_deg, double z, std::string& note) {
    const double h = p.voxel;
    const int i = int(std::lround(x / h)), j = int(std::lround(y / h)), l = int(std::lround(z / h));
    const angles::AngleLattice lattice = p.angle_lattice();
    const int k = lattice.index_of_degrees(theta_deg);
    if (std::abs(i * h - x) > 1e-6 || std::abs(j * h - y) > 1e-6 || std::abs(l * h - z) > 1e-6 ||
        angles::degrees_apart(lattice.wrapped_degrees(k), theta_deg) > 1e-6)
        note = fmt::format("the pose asked for (x {}, y {}, z {}, theta {} deg) is not on the sweep's {} m / {} deg lattice: probing the nearest one", x,
                           y, z, theta_deg, h, p.angle_step_deg);
    return {i, j, k, l};
}

// Where the scene's [truth] puts B, as a pose of this key segment.
std::array<double, 4> truth_pose(const Scene& scene, const SweepProblem& p) {
    if (!scene.truth) fail(scene.file.string(), "--truth: the scene has no [truth] placement");
    const double yaw = angles::radians(scene.truth->yaw_deg);
    const Eigen::Vector2d offset = Eigen::Rotation2Dd(yaw) * p.b.root.head<2>() + Eigen::Vector2d(scene.truth->x, scene.truth->y) - p.a.root.head<2>();
    return {offset.x(), offset.y(), scene.truth->yaw_deg, 0};
}

std::string yes_no(bool b) { return b ? "yes" : "no"; }

std::string frame_list(const std::vector<int>& frames) {
    std::string out;
    for (std::size_t n = 0; n < frames.size(); ++n) out += fmt::format("{}{}", n ? "," : "", frames[n]);
    return out.empty() ? "none" : out;
}

std::string dictionary_line(const KeySegment& segment, const PoseProbe& p) {
    if (!p.touching.empty())
        return fmt::format("the parts share a voxel on {} of {} frames ({} needs {})", std::count(p.touching.begin(), p.touching.end(), 1),
                           p.touching.size(), segment.type.name(), p.touching_needed);
    return fmt::format("{} contact voxels break the {} rule", p.dictionary_violations, segment.type.name());
}

// The deepest interpenetration over the frames, of the interest parts and of any other parts.
std::string depth_line(const PoseProbe& p) {
    auto deepest = [](const std::vector<double>& d) { return int(std::max_element(d.begin(), d.end()) - d.begin()); };
    if (p.contact_depth_m.empty()) return {};
    const int c = deepest(p.contact_depth_m), o = deepest(p.other_depth_m);
    return fmt::format("depth: the interest parts merge up to {:.1f} mm (frame {}); other parts interpenetrate up to {:.1f} mm (frame {})\n",
                       p.contact_depth_m[std::size_t(c)] * 1000, c, p.other_depth_m[std::size_t(o)] * 1000, o);
}

}  // namespace

ProbeAnswer probe_scene(const Scene& scene, const ProbeRequest& request, Voxeliser& voxeliser) {
    if (request.segment < 1 || request.segment > int(scene.segments.size()))
        fail("--segment", "{} is not a key segment of {} (1..{})", request.segment, scene.file.string(), scene.segments.size());
    ProbeAnswer answer;
    answer.segment = scene.segments[std::size_t(request.segment - 1)];
    ObjectSource a(scene.a), b(scene.b);
    const SegmentBuild build = build_segment(scene, answer.segment, a, b, voxeliser);
    const SweepProblem& p = build.problem;
    const std::array<double, 4> asked = request.truth ? truth_pose(scene, p) : *request.pose;
    for (double v : asked)
        if (!std::isfinite(v) || std::abs(v) > 1e4) fail("--pose", "{} is not a pose within 10 km", v);
    const auto [i, j, k, l] = snap(p, asked[0], asked[1], asked[2], asked[3], answer.snapped);
    const PoseRange& r = p.range;
    answer.in_range = i >= r.i_first && i <= r.i_last && j >= r.j_first && j <= r.j_last && l >= r.z_first && l <= r.z_last;
    const PoseProber prober(p);
    answer.probe = prober.probe(i, j, k, l, true);
    if (answer.probe.outcome != PoseOutcome::Solution) {
        const int angles = p.angle_lattice().count;
        for (int dl = -1; dl <= 1; ++dl)
            for (int dk = -1; dk <= 1; ++dk)
                for (int dj = -1; dj <= 1; ++dj)
                    for (int di = -1; di <= 1; ++di) {
                        if ((di == 0 && dj == 0 && dk == 0 && dl == 0) || l + dl < r.z_first || l + dl > r.z_last) continue;
                        const PoseProbe n = prober.probe(i + di, j + dj, ((k + dk) % angles + angles) % angles, l + dl, false);
                        if (n.outcome == PoseOutcome::Solution) answer.neighbours_in_group.push_back(n.pose);
                    }
    }
    return answer;
}

std::string probe_table(const ProbeAnswer& answer, int frames) {
    const PoseProbe& p = answer.probe;
    const Solution& s = p.pose;
    std::string out;
    if (!answer.snapped.empty()) out += "note: " + answer.snapped + "\n";
    out += fmt::format("key segment {} ({}), pose x {:.4f} m, y {:.4f} m, z {:.4f} m, theta {:g} deg (L {:.3f} m, thetaA {:.1f} deg, thetaB {:.1f} deg)\n",
                       answer.segment.index, answer.segment.type.name(), s.x, s.y, s.z, s.theta_deg, s.distance, s.theta_a_deg, s.theta_b_deg);
    out += p.outcome == PoseOutcome::Solution ? std::string("verdict: a solution\n")
                                              : fmt::format("verdict: fails {} (the first constraint it fails, as the sweep decides)\n", p.failed_constraint());
    if (p.outcome != PoseOutcome::Solution) {
        const auto& near = answer.neighbours_in_group;
        if (near.empty()) out += "neighbours: none of the poses one voxel or one angle step away is a solution either\n";
        else
            out += fmt::format("neighbours: {} of the poses one voxel or one angle step away are solutions, the first x {:.4f} m, y {:.4f} m, z {:.4f} m, theta {:g} deg\n",
                               near.size(), near[0].x, near[0].y, near[0].z, near[0].theta_deg);
    }
    if (!answer.in_range) out += "note: the pose lies outside the range the sweep tests (there B's interest part cannot reach A's)\n";
    auto row = [&](const char* name, bool passes, const std::string& detail) { out += fmt::format("  {:<11} {:<6} {}\n", name, passes ? "passes" : "FAILS", detail); };
    row("contact", p.passes[0], fmt::format("{} voxels where the interest parts' unions meet", p.contact_voxels));
    row("dictionary", p.passes[1], dictionary_line(answer.segment, p));
    std::vector<int> overlaps;
    for (int t = 0; t < frames; ++t)
        if (p.fidelity_voxels[std::size_t(t)]) overlaps.push_back(t);
    row("fidelity", p.passes[2], fmt::format("the fidelity parts overlap at frames {}", frame_list(overlaps)));
    if (p.a_sees_b.empty()) row("visibility", true, "not asked for");
    else if (p.a_sees_b.size() == 1) row("visibility", p.passes[3], fmt::format("A sees B: {}, B sees A: {} (swept bodies)", yes_no(p.a_sees_b[0]), yes_no(p.b_sees_a[0])));
    else
        row("visibility", p.passes[3], fmt::format("A sees B on {} frames, B sees A on {} (each needs {})", std::count(p.a_sees_b.begin(), p.a_sees_b.end(), 1),
                                                  std::count(p.b_sees_a.begin(), p.b_sees_a.end(), 1), p.visibility_needed));
    out += depth_line(p);
    out += "frame   gap_mm  merge_mm  other_mm  fidelity_voxels  touching  A_sees_B  B_sees_A\n";
    for (int t = 0; t < frames; ++t) {
        const double gap = p.gap_m[std::size_t(t)];
        const bool per_frame = p.a_sees_b.size() > 1;
        out += fmt::format("{:>5} {:>8} {:>9.1f} {:>9.1f} {:>16} {:>9} {:>9} {:>9}\n", t, std::isinf(gap) ? std::string("-") : fmt::format("{:.1f}", gap * 1000),
                           p.contact_depth_m[std::size_t(t)] * 1000, p.other_depth_m[std::size_t(t)] * 1000,
                           p.fidelity_voxels[std::size_t(t)], p.touching.empty() ? "-" : yes_no(p.touching[std::size_t(t)]),
                           per_frame ? yes_no(p.a_sees_b[std::size_t(t)]) : "-", per_frame ? yes_no(p.b_sees_a[std::size_t(t)]) : "-");
    }
    return out;
}

results::Json probe_json(const ProbeAnswer& answer) {
    const PoseProbe& p = answer.probe;
    const Solution& s = p.pose;
    results::Json json;
    json["segment"] = answer.segment.index;
    json["type"] = answer.segment.type.name();
    json["pose"] = {{"x", s.x}, {"y", s.y}, {"z", s.z}, {"theta_deg", s.theta_deg}, {"L", s.distance}, {"thetaA_deg", s.theta_a_deg}, {"thetaB_deg", s.theta_b_deg}};
    json["snapped"] = answer.snapped.empty() ? results::Json(nullptr) : results::Json(answer.snapped);
    json["in_range"] = answer.in_range;
    json["verdict"] = p.outcome == PoseOutcome::Solution ? "solution" : p.failed_constraint();
    json["failed_frames"] = p.failed_frames();
    json["constraints"] = {{"contact", {{"passes", p.passes[0]}, {"contact_voxels", p.contact_voxels}}},
                           {"dictionary", {{"passes", p.passes[1]}, {"violations", p.dictionary_violations}, {"touching", p.touching},
                                           {"touching_needed", p.touching_needed}}},
                           {"fidelity", {{"passes", p.passes[2]}, {"overlap_voxels", p.fidelity_voxels}}},
                           {"visibility", {{"passes", p.passes[3]}, {"a_sees_b", p.a_sees_b}, {"b_sees_a", p.b_sees_a}, {"needed", p.visibility_needed}}}};
    results::Json gaps = results::Json::array();
    for (double g : p.gap_m) gaps.push_back(std::isinf(g) ? results::Json(nullptr) : results::Json(g * 1000));
    json["gap_mm"] = gaps;
    results::Json merge = results::Json::array(), other = results::Json::array();
    for (double d : p.contact_depth_m) merge.push_back(d * 1000);
    for (double d : p.other_depth_m) other.push_back(d * 1000);
    json["merge_mm"] = merge;
    json["other_mm"] = other;
    results::Json neighbours = results::Json::array();
    for (const Solution& n : answer.neighbours_in_group) neighbours.push_back({{"x", n.x}, {"y", n.y}, {"z", n.z}, {"theta_deg", n.theta_deg}});
    json["neighbours_in_group"] = neighbours;
    return json;
}

results::Json near_misses(const SweepProblem& problem, const SweepResult& result) {
    const PoseRange& r = result.range;
    PoseOutcome furthest = PoseOutcome::FailsContact;
    for (PoseOutcome o : result.outcomes)
        if (o != PoseOutcome::Solution) furthest = std::max(furthest, o);
    std::vector<std::size_t> candidates;
    for (std::size_t n = 0; n < result.outcomes.size(); ++n)
        if (result.outcomes[n] == furthest) candidates.push_back(n);
    if (candidates.empty()) return results::Json::array();
    constexpr std::size_t kProbed = 400;
    const std::size_t stride = std::max<std::size_t>(1, (candidates.size() + kProbed - 1) / kProbed);
    struct Miss {
        PoseProbe probe;
        std::size_t failed;
    };
    std::vector<Miss> misses;
    const PoseProber prober(problem);
    for (std::size_t c = 0; c < candidates.size(); c += stride) {
        std::size_t n = candidates[c];
        const int i = r.i_first + int(n % std::size_t(r.width()));
        n /= std::size_t(r.width());
        const int j = r.j_first + int(n % std::size_t(r.height()));
        n /= std::size_t(r.height());
        const int k = int(n % std::size_t(r.angles)), l = r.z_first + int(n / std::size_t(r.angles));
        PoseProbe probe = prober.probe(i, j, k, l, false);
        const std::size_t failed = probe.failed_frames().size();
        misses.push_back({std::move(probe), failed});
    }
    std::stable_sort(misses.begin(), misses.end(), [](const Miss& a, const Miss& b) { return a.failed < b.failed; });
    results::Json out = results::Json::array();
    std::vector<const Solution*> kept;
    for (const Miss& m : misses) {
        const Solution& s = m.probe.pose;
        const bool far = std::all_of(kept.begin(), kept.end(), [&](const Solution* o) {
            return std::hypot(s.x - o->x, s.y - o->y) >= 0.1 || angles::degrees_apart(s.theta_deg, o->theta_deg) >= 10 || s.l != o->l;
        });
        if (!far) continue;
        kept.push_back(&s);
        out.push_back({{"x", s.x}, {"y", s.y}, {"z", s.z}, {"theta_deg", s.theta_deg}, {"fails", m.probe.failed_constraint()},
                       {"frames_failed", m.probe.failed_frames()}, {"frames", problem.frames()}});
        if (kept.size() == 10) break;
    }
    return out;
}

}  // namespace amhv::pipeline
