#include "src/sweep/solution_group.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <tuple>

#include <Eigen/Geometry>

#include "src/core/angles.hpp"
#include "src/core/error.hpp"
#include "src/core/parallel.hpp"

namespace amhv {

namespace {

auto row_key(const PoseRun& r) { return std::tie(r.l, r.k, r.j); }

double signed_angle_deg(const Eigen::Vector2d& from, const Eigen::Vector2d& to) {
    return angles::degrees(std::atan2(from.x() * to.y() - from.y() * to.x(), from.dot(to)));
}

}  // namespace

void SolutionGroup::add_run(const PoseRun& run) {
    if (run.i_last < run.i_first) throw Error("internal: an empty run of poses");
    if (!runs_.empty()) {
        PoseRun& last = runs_.back();
        const bool same_row = row_key(last) == row_key(run);
        if (row_key(run) < row_key(last) || (same_row && run.i_first <= last.i_last))
            throw Error("internal: poses added to a solution group out of the sweep's (z, theta, y, x) order");
        if (same_row && run.i_first == last.i_last + 1) {
            last.i_last = run.i_last;
            return;
        }
    }
    starts_.push_back(size());
    runs_.push_back(run);
}

std::size_t SolutionGroup::run_of(std::uint64_t n) const {
    return std::size_t(std::upper_bound(starts_.begin(), starts_.end(), n) - starts_.begin()) - 1;
}

PoseIndex SolutionGroup::at(std::uint64_t n) const {
    if (n >= size()) throw Error("internal: member past the end of a solution group");
    const std::size_t r = run_of(n);
    const PoseRun& run = runs_[r];
    return {run.i_first + int(n - starts_[r]), run.j, run.k, run.l};
}

std::uint64_t SolutionGroup::index_of(const PoseIndex& p) const {
    const PoseRun probe{p.l, p.k, p.j, p.i, p.i};
    // The first run past (l, k, j, i); the one before it holds the pose if any does.
    auto after = std::upper_bound(runs_.begin(), runs_.end(), probe, [](const PoseRun& a, const PoseRun& b) {
        return std::tie(a.l, a.k, a.j, a.i_first) < std::tie(b.l, b.k, b.j, b.i_first);
    });
    if (after == runs_.begin()) return size();
    const std::size_t r = std::size_t(std::prev(after) - runs_.begin());
    const PoseRun& run = runs_[r];
    if (row_key(run) != row_key(probe) || p.i < run.i_first || p.i > run.i_last) return size();
    return starts_[r] + std::uint64_t(p.i - run.i_first);
}

bool SolutionGroup::contains(const PoseIndex& p) const { return index_of(p) < size(); }

bool SolutionGroup::any_raised() const {
    return std::any_of(runs_.begin(), runs_.end(), [](const PoseRun& r) { return r.l != 0; });
}

namespace {

// The runs of solutions `keep` keeps in slice (l, k), in (j, x) order.
void solutions_of_slice(const SweepResult& result, int l, int k, const std::function<bool(const PoseIndex&)>& keep, std::vector<PoseRun>& runs) {
    const PoseRange& r = result.range;
    const std::size_t width = std::size_t(r.i_last - r.i_first + 1);
    for (int j = r.j_first; j <= r.j_last; ++j) {
        // Solutions are rare: memchr skips to each.
        const PoseOutcome* row = &result.outcomes[result.index(r.i_first, j, k, l)];
        for (const void* at = std::memchr(row, int(PoseOutcome::Solution), width); at;) {
            const std::size_t offset = std::size_t(static_cast<const PoseOutcome*>(at) - row);
            const int i = r.i_first + int(offset);
            if (!keep || keep(PoseIndex{i, j, k, l})) {
                if (!runs.empty() && runs.back().j == j && runs.back().i_last + 1 == i) ++runs.back().i_last;
                else runs.push_back({l, k, j, i, i});
            }
            at = std::memchr(row + offset + 1, int(PoseOutcome::Solution), width - offset - 1);
        }
    }
}

}  // namespace

SolutionGroup solution_group(const SweepResult& result, const std::function<bool(const PoseIndex&)>& keep) {
    SolutionGroup group;
    const PoseRange& r = result.range;
    if (r.i_last < r.i_first) return group;
    const std::size_t slices = std::size_t(r.z_last - r.z_first + 1) * std::size_t(r.angles);
    std::vector<std::vector<PoseRun>> runs(slices);
    parallel_for(slices, [&](std::size_t s) {
        solutions_of_slice(result, r.z_first + int(s / std::size_t(r.angles)), int(s % std::size_t(r.angles)), keep, runs[s]);
    });
    for (const std::vector<PoseRun>& slice : runs)
        for (const PoseRun& run : slice) group.add_run(run);
    return group;
}

Solution PoseDescriber::operator()(const PoseIndex& p) const {
    Solution s;
    s.i = p.i;
    s.j = p.j;
    s.k = p.k;
    s.l = p.l;
    s.x = p.i * voxel;
    s.y = p.j * voxel;
    s.z = p.l * voxel;
    s.theta_deg = theta_deg(p.k);
    s.distance = std::hypot(s.x, s.y);
    if (s.distance > 0) {
        Eigen::Vector2d towards_b(s.x, s.y);
        double theta = angles::radians(p.k * angle_step_deg);
        Eigen::Vector2d facing = Eigen::Rotation2Dd(theta) * facing_b;
        s.theta_a_deg = angles::wrap_degrees(signed_angle_deg(facing_a, towards_b));
        s.theta_b_deg = angles::wrap_degrees(signed_angle_deg(facing, -towards_b));
    }
    return s;
}

double PoseDescriber::theta_deg(int k) const { return angles::wrap_degrees(k * angle_step_deg); }

PoseDescriber describer(const SweepProblem& problem) {
    return {problem.voxel, problem.angle_step_deg, problem.a.facing, problem.b.facing};
}

}  // namespace amhv
