#include "host/choose/chain_dp.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>

#include <Eigen/Geometry>

#include "src/core/angles.hpp"
#include "src/core/budget.hpp"
#include "src/core/error.hpp"
#include "src/core/parallel.hpp"
#include "src/core/uninitialised_allocator.hpp"
#include "host/choose/chain_alternatives.hpp"

namespace amhv {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Eigen::Vector2d rotate(double angle, const Eigen::Vector2d& v) { return Eigen::Rotation2Dd(angle) * v; }

// The unary term of a segment's solutions at one A rotation. Its terms of theta are kept from one
// solution to the next while theta stays the same (solutions come in (theta, y, x) order): the
// same arithmetic, so the same bits, at a fraction of the cosines.
class UnaryTerms {
public:
    UnaryTerms(const ChainSegment& s, const ChainWeights& w, int d) : s_(s), w_(w), delta_(w.a_rotations_rad[std::size_t(d)]) {}

    double operator()(std::size_t j) {
        const ChainSolution& sol = s_.solutions[j];
        if (!known_ || sol.theta_rad != theta_) {
            known_ = true;
            theta_ = sol.theta_rad;
            const double b = 2 - 2 * std::cos(w_.yaw_a + delta_ + sol.theta_rad - w_.yaw_b);
            facing_ = (2 - 2 * std::cos(delta_)) + s_.facing_b_weight * b;
            turn_ = std::pow(angles::wrap_radians(sol.theta_rad - s_.prior_theta_rad), 2);
        }
        const Eigen::Vector2d r(sol.i * w_.voxel, sol.j * w_.voxel);
        const double prior = (r - s_.prior_offset).squaredNorm() + turn_;
        const double cost = w_.lambda * facing_ + w_.mu * prior;
        return s_.extra_unary.empty() ? cost : cost + s_.extra_unary[j];
    }

private:
    const ChainSegment& s_;
    const ChainWeights& w_;
    double delta_;
    bool known_ = false;
    double theta_ = 0, facing_ = 0, turn_ = 0;
};

double unary(const ChainSegment& s, const ChainWeights& w, int j, int d) { return UnaryTerms(s, w, d)(std::size_t(j)); }

// Solutions are handed to the cores in chunks of this many.
constexpr std::size_t kChunk = std::size_t(1) << 15;

void for_chunks(std::size_t n, const std::function<void(std::size_t, std::size_t)>& work) {
    parallel_for((n + kChunk - 1) / kChunk, [&](std::size_t c) { work(c * kChunk, std::min(n, (c + 1) * kChunk)); });
}

// Per-solution lists of the DP (up to 60 MB a segment at 5 mm) are first written on every core:
// a list filled on one thread paid for its fresh pages there, and a copy of a filled list twice.
template <typename T>
using PerSolution = std::vector<T, UninitialisedAllocator<T>>;

template <typename T>
PerSolution<T> filled(std::size_t n, T value) {
    PerSolution<T> list(n);
    for_chunks(n, [&](std::size_t first, std::size_t last) { std::fill(list.begin() + std::ptrdiff_t(first), list.begin() + std::ptrdiff_t(last), value); });
    return list;
}

// cost[j]: the unary term of every solution j of segment i at rotation d that the restrictions
// allow, else infinity; on every core.
void fill_unary(const ChainSegment& seg, std::size_t i, int d, const ChainWeights& w, const ChainRestrictions* restrictions, PerSolution<double>& cost) {
    for_chunks(seg.solutions.size(), [&](std::size_t first, std::size_t last) {
        UnaryTerms terms(seg, w, d);
        for (std::size_t j = first; j < last; ++j)
            cost[j] = !restrictions || restrictions->allows(i, seg.solutions[j], d, w.voxel) ? terms(j) : kInf;
    });
}

double pair_factor(const ChainWeights& w) { return std::isinf(w.w_a) ? w.w_b : w.w_a * w.w_b / (w.w_a + w.w_b); }

// P_i(s) without the rotated offset: R(psi_B) dC^B_i - R(psi_A) dC^A_i.
Eigen::Vector2d displacement_term(const ChainSegment& a, const ChainSegment& b, const ChainWeights& w) {
    return rotate(w.yaw_b, b.root_b - a.root_b) - rotate(w.yaw_a, b.root_a - a.root_a);
}

Eigen::Vector2d offset(const ChainSolution& s, const ChainWeights& w, int d) {
    return rotate(w.yaw_a + w.a_rotations_rad[std::size_t(d)], Eigen::Vector2d(s.i * w.voxel, s.j * w.voxel));
}

void check(const std::vector<ChainSegment>& segments, const ChainWeights& w) {
    if (segments.empty()) throw Error("global optimisation: no key segment");
    for (std::size_t i = 0; i < segments.size(); ++i)
        if (segments[i].solutions.empty()) throw Error(fmt::format("global optimisation: key segment {} has no solution", i + 1));
    if (w.a_rotations_rad.empty()) throw Error("global optimisation: the set of A rotations is empty");
}

}  // namespace

void lower_envelope(const std::vector<double>& v, const std::vector<double>& g, double c, const std::vector<double>& q,
                    std::vector<double>& f, std::vector<int>& argmin) {
    // Felzenszwalb-Huttenlocher: the lower envelope of parabolas g_k + c (x - v_k)^2, built left
    // to right, then read at the ascending queries.
    std::vector<int> hull;
    std::vector<double> from;  // hull[m] is lowest on [from[m], from[m+1])
    for (int k = 0; k < int(v.size()); ++k) {
        if (std::isinf(g[std::size_t(k)])) continue;
        double start = -kInf;
        while (!hull.empty()) {
            const int h = hull.back();
            const double vk = v[std::size_t(k)], vh = v[std::size_t(h)];
            if (vk == vh) {  // same centre: keep the lower (the earlier on ties)
                if (g[std::size_t(k)] < g[std::size_t(h)]) {
                    hull.pop_back();
                    from.pop_back();
                    continue;
                }
                start = kInf;
                break;
            }
            start = ((g[std::size_t(k)] + c * vk * vk) - (g[std::size_t(h)] + c * vh * vh)) / (2 * c * (vk - vh));
            if (start <= from.back()) {
                hull.pop_back();
                from.pop_back();
                start = -kInf;
                continue;
            }
            break;
        }
        if (start == kInf) continue;
        hull.push_back(k);
        from.push_back(hull.size() == 1 ? -kInf : start);
    }
    f.assign(q.size(), kInf);
    argmin.assign(q.size(), -1);
    if (hull.empty()) return;
    std::size_t m = 0;
    for (std::size_t t = 0; t < q.size(); ++t) {
        while (m + 1 < hull.size() && from[m + 1] <= q[t]) ++m;
        const int k = hull[m];
        const double d = q[t] - v[std::size_t(k)];
        f[t] = g[std::size_t(k)] + c * d * d;
        argmin[t] = k;
    }
}

void evaluate_chain(const std::vector<ChainSegment>& segments, const ChainWeights& w, ChainChoice& choice) {
    choice.unary = choice.pairwise = 0;
    const double c = pair_factor(w);
    for (std::size_t i = 0; i < segments.size(); ++i) {
        choice.unary += unary(segments[i], w, choice.solution[i], choice.rotation[i]);
        if (i + 1 < segments.size()) {
            Eigen::Vector2d p = displacement_term(segments[i], segments[i + 1], w) +
                                offset(segments[i].solutions[std::size_t(choice.solution[i])], w, choice.rotation[i]);
            Eigen::Vector2d q = offset(segments[i + 1].solutions[std::size_t(choice.solution[i + 1])], w, choice.rotation[i + 1]);
            choice.pairwise += c * (p - q).squaredNorm();
        }
    }
    choice.cost = choice.unary + choice.pairwise;
}

namespace {

// A state (k, d) of the segment before as one word, d * (its solutions) + k: half the memory of a
// pair, and the back pointers of every segment stay until the end (a third of a gigabyte at 5 mm).
using PackedState = std::uint32_t;
constexpr PackedState kNoState = std::numeric_limits<PackedState>::max();

PackedState pack_state(int k, int d, std::size_t states_per_rotation) { return PackedState(std::size_t(d) * states_per_rotation + std::size_t(k)); }

// The box of the solutions' cells: first and last i, first and last j (on every core).
std::array<int, 4> cell_box(const ChainSolutions& solutions) {
    const std::size_t chunks = (solutions.size() + kChunk - 1) / kChunk;
    std::vector<std::array<int, 4>> boxes(chunks, {INT32_MAX, INT32_MIN, INT32_MAX, INT32_MIN});
    for_chunks(solutions.size(), [&](std::size_t first, std::size_t last) {
        std::array<int, 4> box = boxes[first / kChunk];
        for (std::size_t k = first; k < last; ++k) {
            const ChainSolution& s = solutions[k];
            box = {std::min(box[0], s.i), std::max(box[1], s.i), std::min(box[2], s.j), std::max(box[3], s.j)};
        }
        boxes[first / kChunk] = box;
    });
    std::array<int, 4> box{INT32_MAX, INT32_MIN, INT32_MAX, INT32_MIN};
    for (const auto& b : boxes) box = {std::min(box[0], b[0]), std::max(box[1], b[1]), std::min(box[2], b[2]), std::max(box[3], b[3])};
    return box;
}

// Best and its argument over the states (k, d) of the segment before, for each state (j, d) of
// `seg` (the same rotation R): |a + R r - R r'|^2 = |R^-1 a + r - r'|^2, with r and r' on the h
// grid, a separable 2D distance transform over the cells of the segment before. Its rows, then its
// columns, are independent: they go to every core.
void same_rotation_minimum(const ChainSegment& prev, const ChainSegment& seg, const PerSolution<double>& g, const Eigen::Vector2d& a,
                           const ChainWeights& w, int d, std::size_t i, PerSolution<double>& best, PerSolution<PackedState>& arg) {
    const double c = pair_factor(w), h = w.voxel;
    const Eigen::Vector2d shift = rotate(-(w.yaw_a + w.a_rotations_rad[std::size_t(d)]), a);
    // Plain names (not structured bindings): lambdas below capture them, which clang 14 refuses.
    const auto prev_box = cell_box(prev.solutions), seg_box = cell_box(seg.solutions);
    const int pi0 = prev_box[0], pi1 = prev_box[1], pj0 = prev_box[2], pj1 = prev_box[3];
    const int qi0 = seg_box[0], qi1 = seg_box[1], qj0 = seg_box[2], qj1 = seg_box[3];
    const int pw = pi1 - pi0 + 1, ph = pj1 - pj0 + 1, qw = qi1 - qi0 + 1, qh = qj1 - qj0 + 1;
    // The distance transform's grids span both groups' boxes: checked before allocating.
    budget::require_memory((std::uint64_t(pw) * ph + std::uint64_t(ph) * qw + std::uint64_t(qw) * qh) * 12,
                           fmt::format("the DP's grid between key segments {} and {} ({} x {} and {} x {} cells)", i, i + 1, pw, ph, qw, qh),
                           "the solution groups spread over too wide an area: narrow x_range / y_range");
    // Best state of each cell of R_{i-1} (the first in (theta, y, x) order on ties).
    std::vector<double> cell(std::size_t(pw) * ph, kInf);
    std::vector<int> cell_state(std::size_t(pw) * ph, -1);
    for (int k = 0; k < int(prev.solutions.size()); ++k) {
        const auto& s = prev.solutions[std::size_t(k)];
        std::size_t at = std::size_t(s.j - pj0) * pw + std::size_t(s.i - pi0);
        if (g[std::size_t(k)] < cell[at]) cell[at] = g[std::size_t(k)], cell_state[at] = k;
    }
    // Pass 1, along x per row of R_{i-1}: centres (i h + shift.x), queries q_i h.
    std::vector<double> vx(static_cast<std::size_t>(pw)), qx(static_cast<std::size_t>(qw)), vy(static_cast<std::size_t>(ph)), qy(static_cast<std::size_t>(qh));
    for (int x = 0; x < pw; ++x) vx[std::size_t(x)] = (pi0 + x) * h + shift.x();
    for (int x = 0; x < qw; ++x) qx[std::size_t(x)] = (qi0 + x) * h;
    for (int y = 0; y < ph; ++y) vy[std::size_t(y)] = (pj0 + y) * h + shift.y();
    for (int y = 0; y < qh; ++y) qy[std::size_t(y)] = (qj0 + y) * h;
    std::vector<double> rows(std::size_t(ph) * qw);
    std::vector<int> row_arg(std::size_t(ph) * qw);
    parallel_for(std::size_t(ph), [&](std::size_t y) {
        const std::vector<double> line(cell.begin() + std::ptrdiff_t(y) * pw, cell.begin() + std::ptrdiff_t(y + 1) * pw);
        std::vector<double> f;
        std::vector<int> am;
        lower_envelope(vx, line, c, qx, f, am);
        std::copy(f.begin(), f.end(), rows.begin() + std::ptrdiff_t(y) * qw);
        std::copy(am.begin(), am.end(), row_arg.begin() + std::ptrdiff_t(y) * qw);
    });
    // Pass 2, along y per query column.
    std::vector<double> field(std::size_t(qw) * qh);
    std::vector<int> field_state(std::size_t(qw) * qh, -1);
    parallel_for(std::size_t(qw), [&](std::size_t x) {
        std::vector<double> column(static_cast<std::size_t>(ph)), f;
        std::vector<int> am;
        for (int y = 0; y < ph; ++y) column[std::size_t(y)] = rows[std::size_t(y) * qw + x];
        lower_envelope(vy, column, c, qy, f, am);
        for (int y = 0; y < qh; ++y) {
            field[std::size_t(y) * qw + x] = f[std::size_t(y)];
            if (am[std::size_t(y)] >= 0) {
                const int py = am[std::size_t(y)];
                const int px = row_arg[std::size_t(py) * qw + x];
                field_state[std::size_t(y) * qw + x] = cell_state[std::size_t(py) * pw + std::size_t(px)];
            }
        }
    });
    for_chunks(seg.solutions.size(), [&](std::size_t first, std::size_t last) {
        for (std::size_t j = first; j < last; ++j) {
            const auto& s = seg.solutions[j];
            const std::size_t at = std::size_t(s.j - qj0) * qw + std::size_t(s.i - qi0);
            if (field[at] < best[j]) best[j] = field[at], arg[j] = pack_state(field_state[at], d, prev.solutions.size());
        }
    });
}

// The same through another rotation dp of the segment before: the two point sets are not on one
// grid, so the direct minimum, each state of `seg` on its own core's share.
void other_rotation_minimum(const ChainSegment& prev, const ChainSegment& seg, const PerSolution<double>& g, const Eigen::Vector2d& a,
                            const ChainWeights& w, int d, int dp, PerSolution<double>& best, PerSolution<PackedState>& arg) {
    const double c = pair_factor(w);
    for_chunks(seg.solutions.size(), [&](std::size_t first, std::size_t last) {
        for (std::size_t j = first; j < last; ++j) {
            const Eigen::Vector2d qj = offset(seg.solutions[j], w, d);
            for (int k = 0; k < int(prev.solutions.size()); ++k) {
                const double v = g[std::size_t(k)] + c * (a + offset(prev.solutions[std::size_t(k)], w, dp) - qj).squaredNorm();
                if (v < best[j]) best[j] = v, arg[j] = pack_state(k, dp, prev.solutions.size());
            }
        }
    });
}

}  // namespace

ChainChoice solve_chain(const std::vector<ChainSegment>& segments, const ChainWeights& w, const ChainRestrictions* restrictions) {
    check(segments, w);
    const int rotations = int(w.a_rotations_rad.size());
    // cost[i][d][j] = best cost of segments 0..i ending in state (j, d); back[i][d][j] = (j', d') before it.
    std::vector<std::vector<PerSolution<double>>> cost(segments.size());
    std::vector<std::vector<PerSolution<PackedState>>> back(segments.size());
    for (std::size_t i = 0; i < segments.size(); ++i) {
        const auto& seg = segments[i];
        const std::size_t n = seg.solutions.size();
        if (i > 0 && segments[i - 1].solutions.size() * std::size_t(rotations) >= kNoState)
            throw Error(fmt::format("the DP: key segment {} has {} solutions at {} rotations, more states than it handles", i,
                                    segments[i - 1].solutions.size(), rotations));
        cost[i].assign(std::size_t(rotations), {});
        // Filled per rotation below (the first segment's are never read): a pre-filled copy beside
        // `arg` was a quarter gigabyte of the DP's peak at 5 mm.
        back[i].resize(std::size_t(rotations));
        for (int d = 0; d < rotations; ++d) {
            PerSolution<double>& here = cost[i][std::size_t(d)];
            here.resize(n);  // every entry written by fill_unary
            fill_unary(seg, i, d, w, restrictions, here);
            if (i == 0) continue;
            const auto& prev = segments[i - 1];
            const Eigen::Vector2d a = displacement_term(prev, seg, w);
            PerSolution<double> best_step = filled(n, kInf);
            PerSolution<PackedState> arg = filled(n, kNoState);
            for (int dp = 0; dp < rotations; ++dp) {
                const auto& g = cost[i - 1][std::size_t(dp)];
                if (dp == d) same_rotation_minimum(prev, seg, g, a, w, d, i, best_step, arg);
                else other_rotation_minimum(prev, seg, g, a, w, d, dp, best_step, arg);
            }
            // inf stays inf: a state no allowed path reaches
            for_chunks(n, [&](std::size_t first, std::size_t last) {
                for (std::size_t j = first; j < last; ++j) here[j] += best_step[j];
            });
            back[i][std::size_t(d)] = std::move(arg);
        }
        // Only the back pointers of earlier segments are read again: at 5 mm the costs of every
        // segment were a gigabyte beside the sweep's results.
        if (i > 0) std::vector<PerSolution<double>>().swap(cost[i - 1]);
    }
    // The best final state; ties go to the first rotation, then the first solution in (theta, y, x) order.
    ChainChoice choice;
    const std::size_t last = segments.size() - 1;
    int best_j = -1, best_d = -1;
    double best = kInf;
    for (int d = 0; d < rotations; ++d)
        for (int j = 0; j < int(segments[last].solutions.size()); ++j)
            if (cost[last][std::size_t(d)][std::size_t(j)] < best) best = cost[last][std::size_t(d)][std::size_t(j)], best_j = j, best_d = d;
    if (best_j < 0) {  // the restrictions allow no choice
        choice.cost = kInf;
        return choice;
    }
    choice.solution.assign(segments.size(), -1);
    choice.rotation.assign(segments.size(), -1);
    for (std::size_t i = last + 1; i-- > 0;) {
        choice.solution[i] = best_j;
        choice.rotation[i] = best_d;
        if (i > 0) {
            const PackedState before = back[i][std::size_t(best_d)][std::size_t(best_j)];
            const std::size_t per_rotation = segments[i - 1].solutions.size();
            best_j = int(before % per_rotation), best_d = int(before / per_rotation);
        }
    }
    evaluate_chain(segments, w, choice);
    return choice;
}

std::vector<Eigen::Vector2d> a_translation_steps(const std::vector<ChainSegment>& segments, const ChainWeights& w,
                                                 const ChainChoice& choice) {
    std::vector<Eigen::Vector2d> steps;
    for (std::size_t i = 0; i + 1 < segments.size(); ++i) {
        Eigen::Vector2d e = displacement_term(segments[i], segments[i + 1], w) +
                            offset(segments[i].solutions[std::size_t(choice.solution[i])], w, choice.rotation[i]) -
                            offset(segments[i + 1].solutions[std::size_t(choice.solution[i + 1])], w, choice.rotation[i + 1]);
        steps.push_back(std::isinf(w.w_a) ? Eigen::Vector2d::Zero() : Eigen::Vector2d(w.w_b * e / (w.w_a + w.w_b)));
    }
    return steps;
}

ChainChoice solve_chain_exhaustively(const std::vector<ChainSegment>& segments, const ChainWeights& w) {
    check(segments, w);
    const int rotations = int(w.a_rotations_rad.size());
    ChainChoice current, best;
    current.solution.assign(segments.size(), 0);
    current.rotation.assign(segments.size(), 0);
    best.cost = kInf;
    while (true) {
        evaluate_chain(segments, w, current);
        if (current.cost < best.cost) best = current;
        std::size_t i = 0;
        for (; i < segments.size(); ++i) {
            if (++current.rotation[i] < rotations) break;
            current.rotation[i] = 0;
            if (++current.solution[i] < int(segments[i].solutions.size())) break;
            current.solution[i] = 0;
        }
        if (i == segments.size()) break;
    }
    return best;
}

}  // namespace amhv
