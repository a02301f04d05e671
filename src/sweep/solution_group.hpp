#pragma once
// A key segment's solution group as the pipeline holds it: a set on the sweep's own lattice (pose
// (i, j, k, l): x = i h, y = j h, theta = k step, B raised by l h), stored as runs of consecutive i
// along (l, k, j) rows. A group is a few solid blobs: at 10 mm / 2 deg one segment's 3.75 million
// members lie in 62,656 runs, so a run costs 20 bytes where a listed pose with its descriptors cost
// 72. The members keep the sweep's order (z, theta, y, x); member n is the n-th pose in that order
// (the DP's state index). The descriptors (L, thetaA, thetaB) are computed from a pose when needed.
#include <algorithm>
#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Core>

#include "src/sweep/problem.hpp"

namespace amhv {

struct PoseIndex {
    int i = 0, j = 0, k = 0, l = 0;
    bool operator==(const PoseIndex&) const = default;
};

// i_first..i_last at row (l, k, j).
struct PoseRun {
    std::int32_t l = 0, k = 0, j = 0, i_first = 0, i_last = 0;
    std::uint64_t size() const { return std::uint64_t(i_last - i_first + 1); }
    bool operator==(const PoseRun&) const = default;
};

class SolutionGroup {
public:
    // Appends poses in (l, k, j, i) order, each after the last (throws amhv::Error otherwise: a
    // group is a set in the sweep's order); a pose next to the last run extends it.
    void add(const PoseIndex& pose) { add_run({pose.l, pose.k, pose.j, pose.i, pose.i}); }
    void add_run(const PoseRun& run);

    std::uint64_t size() const { return starts_.empty() ? 0 : starts_.back() + runs_.back().size(); }
    bool empty() const { return runs_.empty(); }
    const std::vector<PoseRun>& runs() const { return runs_; }
    // Member n (0 <= n < size()) in the sweep's order.
    PoseIndex at(std::uint64_t n) const;
    bool contains(const PoseIndex& pose) const;
    // The member number of `pose` (at(index_of(p)) == p), or size() when it is not a member.
    std::uint64_t index_of(const PoseIndex& pose) const;
    bool any_raised() const;  // some member has l != 0
    std::size_t memory_bytes() const { return runs_.capacity() * sizeof(PoseRun) + starts_.capacity() * sizeof(std::uint64_t); }

    // f(PoseIndex) for every member in order.
    template <typename F>
    void for_each(F&& f) const {
        for (const PoseRun& r : runs_)
            for (int i = r.i_first; i <= r.i_last; ++i) f(PoseIndex{i, r.j, r.k, r.l});
    }
    // f(PoseIndex) for members first..last-1 in order.
    template <typename F>
    void for_range(std::uint64_t first, std::uint64_t last, F&& f) const {
        if (first >= last) return;
        std::size_t r = run_of(first);
        std::uint64_t n = first;
        for (; n < last; ++r) {
            const PoseRun& run = runs_[r];
            const int from = run.i_first + int(n - starts_[r]);
            for (int i = from; i <= run.i_last && n < last; ++i, ++n) f(PoseIndex{i, run.j, run.k, run.l});
        }
    }

    bool operator==(const SolutionGroup& other) const { return runs_ == other.runs_; }

private:
    std::size_t run_of(std::uint64_t n) const;  // the run holding member n
    std::vector<PoseRun> runs_;
    std::vector<std::uint64_t> starts_;  // member index of each run's first pose
};

// How a group of `members` is sampled down to at most `at_most` (the page's plot, the natural
// scores kept for it): every member, else every n-th by rank; returns n (at least 1).
inline std::uint64_t sample_stride(std::uint64_t members, std::uint64_t at_most) {
    return std::max<std::uint64_t>(1, (members + at_most - 1) / std::max<std::uint64_t>(1, at_most));
}

// The sweep's solutions, less those `keep` refuses (the editor's limits; null: none): found one
// (l, k) slice at a time from the outcomes, on every core, never as a list of poses. `keep` is
// called from several threads at once.
SolutionGroup solution_group(const SweepResult& result, const std::function<bool(const PoseIndex&)>& keep = nullptr);

// What the descriptors of a pose depend on: the lattice and the two facings (docs/method.md section 6).
struct PoseDescriber {
    double voxel = 0.01, angle_step_deg = 2;
    Eigen::Vector2d facing_a = Eigen::Vector2d::UnitX(), facing_b = Eigen::Vector2d::UnitX();
    Solution operator()(const PoseIndex& p) const;
    double theta_deg(int k) const;  // B's turn at angle index k, wrapped to (-180, 180]
};
PoseDescriber describer(const SweepProblem& problem);

}  // namespace amhv
