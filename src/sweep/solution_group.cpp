#include "src/sweep/solution_group.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>

#include <Eigen/Geometry>

#include "src/core/angles.hpp"
#include "src/core/error.hpp"

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

bool SolutionGroup::contains(const PoseIndex& p) const {
    const PoseRun probe{p.l, p.k, p.j, p.i, p.i};
    // The first run past (l, k, j, i); the one before it holds the pose if any does.
    auto after = std::upper_bound(runs_.begin(), runs_.end(), probe, [](const PoseRun& a, const PoseRun& b) {
        return std::tie(a.l, a.k, a.j, a.i_first) < std::tie(b.l, b.k, b.j, b.i_first);
    });
    if (after == runs_.begin()) return false;
    const PoseRun& run = *std::prev(after);
    return row_key(run) == row_key(probe) && p.i >= run.i_first && p.i <= run.i_last;
}

bool SolutionGroup::any_raised() const {
    return std::any_of(runs_.begin(), runs_.end(), [](const PoseRun& r) { return r.l != 0; });
}

SolutionGroup solution_group(const SweepResult& result) {
    return solution_group(result, [](const PoseIndex&) { return true; });
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
