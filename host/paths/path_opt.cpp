#include "host/paths/path_opt.hpp"

#include <cmath>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>
#include <Eigen/SparseQR>

#include "src/core/error.hpp"

namespace amhv {

namespace {

constexpr double kTieBreak = 1e-9;

double sigmoid_weight(double speed, double alpha, double threshold) {
    const double e = alpha * (speed - threshold);
    return e > 700 ? 0.0 : 1.0 / (1.0 + std::exp(e));  // exp overflows past ~709
}

// One scalar channel (x, y or the facing) of the problem.
struct Channel {
    std::vector<double> moved;                // the captured path moved rigidly onto the fixed ends (tie-break reference)
    std::vector<double> acceleration_target;  // per frame 1 .. n-2: the captured second difference (after the turn)
    std::vector<double> velocity_target;      // per frame 1 .. n-2: the captured central velocity (after the turn)
    std::optional<double> first, last;        // fixed edited values at the ends
    std::vector<double> velocity_weight;      // (1 - delta) w_k, frames 1 .. n-2
    double acceleration_weight = 0;           // delta
    double scale = 1;                         // lambda for the facing
    std::vector<std::pair<int, double>> targets;  // (frame, value): PathTarget on this channel
    std::vector<double> target_weights;

    int n() const { return int(moved.size()); }
    bool fixed(int k) const { return (k == 0 && first) || (k == n() - 1 && last); }
    double fixed_value(int k) const { return k == 0 ? *first : *last; }
};

struct Row {
    double weight;  // square root of the term's weight
    int frames[3];
    double coefficients[3];
    double target;
};

// Every residual row of the objective: acceleration and velocity at each frame with two neighbours.
std::vector<Row> objective_rows(const Channel& c) {
    std::vector<Row> rows;
    for (int k = 1; k + 1 < c.n(); ++k) {
        const std::size_t u = std::size_t(k);
        if (c.acceleration_weight > 0)
            rows.push_back({std::sqrt(c.scale * c.acceleration_weight), {k - 1, k, k + 1}, {1, -2, 1}, c.acceleration_target[u]});
        const double wv = c.velocity_weight[u];
        if (wv > 0) rows.push_back({std::sqrt(c.scale * wv), {k - 1, k, k + 1}, {0.5, 0, -0.5}, c.velocity_target[u]});
    }
    return rows;
}

// The rows the solver minimises: the objective's, then one per target (targets are not part of the
// paper's objective, so channel_cost leaves them out).
std::vector<Row> solve_rows(const Channel& c) {
    std::vector<Row> rows = objective_rows(c);
    for (std::size_t t = 0; t < c.targets.size(); ++t) {
        const int k = c.targets[t].first;
        rows.push_back({std::sqrt(c.target_weights[t]), {k, k, k}, {1, 0, 0}, c.targets[t].second});
    }
    return rows;
}

double channel_cost(const Channel& c, const std::vector<double>& z) {
    double cost = 0;
    for (const Row& r : objective_rows(c)) {
        double v = -r.target;
        for (int m = 0; m < 3; ++m) v += r.coefficients[m] * z[std::size_t(r.frames[m])];
        cost += r.weight * r.weight * v * v;
    }
    return cost;
}

// Banded sparse least squares over the free frames, by sparse QR; the tie-break rows are added only
// when the objective alone leaves the path undetermined (rank-deficient system).
std::vector<double> solve_sparse(const Channel& c) {
    const int n = c.n();
    std::vector<int> column(std::size_t(n), -1);
    int free_count = 0;
    for (int k = 0; k < n; ++k)
        if (!c.fixed(k)) column[std::size_t(k)] = free_count++;
    std::vector<double> z(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) z[std::size_t(k)] = c.fixed(k) ? c.fixed_value(k) : c.moved[std::size_t(k)];
    if (free_count == 0) return z;

    const std::vector<Row> rows = solve_rows(c);
    auto solve = [&](bool tie_break, Eigen::VectorXd& x) {
        std::vector<Eigen::Triplet<double>> entries;
        const int row_count = int(rows.size()) + (tie_break ? free_count : 0);
        Eigen::VectorXd rhs = Eigen::VectorXd::Zero(row_count);
        int r = 0;
        for (const Row& row : rows) {
            double target = row.target;
            for (int m = 0; m < 3; ++m) {
                const int k = row.frames[m];
                if (row.coefficients[m] == 0) continue;
                if (c.fixed(k)) target -= row.coefficients[m] * c.fixed_value(k);  // known values move to the right-hand side
                else entries.emplace_back(r, column[std::size_t(k)], row.weight * row.coefficients[m]);
            }
            rhs[r++] = row.weight * target;
        }
        if (tie_break)
            for (int k = 0; k < n; ++k)
                if (!c.fixed(k)) {
                    entries.emplace_back(r, column[std::size_t(k)], std::sqrt(kTieBreak));
                    rhs[r++] = std::sqrt(kTieBreak) * c.moved[std::size_t(k)];
                }
        // Fewer rows than unknowns (a transition of one or two frames has no objective row at all):
        // the objective leaves the path undetermined, and Eigen's QR must not see an empty matrix.
        if (!tie_break && row_count < free_count) return false;
        Eigen::SparseMatrix<double> a(row_count, free_count);
        a.setFromTriplets(entries.begin(), entries.end());
        a.makeCompressed();
        Eigen::SparseQR<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> qr(a);
        if (qr.info() != Eigen::Success) throw Error("path optimisation: the sparse QR factorisation failed");
        if (!tie_break && int(qr.rank()) < free_count) return false;
        x = qr.solve(rhs);
        return true;
    };
    Eigen::VectorXd x;
    if (!solve(false, x)) solve(true, x);
    for (int k = 0; k < n; ++k)
        if (!c.fixed(k)) z[std::size_t(k)] = x[column[std::size_t(k)]];
    return z;
}

// The same objective as one dense matrix over every frame; fixed frames are pinned by eliminating
// their columns, and the complete orthogonal decomposition returns the minimum-norm deviation from
// the moved path (the tie-break's limit).
std::vector<double> solve_dense(const Channel& c) {
    const int n = c.n();
    const std::vector<Row> rows = solve_rows(c);
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(Eigen::Index(rows.size()), n);
    Eigen::VectorXd b(Eigen::Index(rows.size()));
    for (std::size_t r = 0; r < rows.size(); ++r) {
        for (int m = 0; m < 3; ++m) a(Eigen::Index(r), rows[r].frames[m]) += rows[r].weight * rows[r].coefficients[m];
        b[Eigen::Index(r)] = rows[r].weight * rows[r].target;
    }
    Eigen::VectorXd reference(n);
    for (int k = 0; k < n; ++k) reference[k] = c.fixed(k) ? c.fixed_value(k) : c.moved[std::size_t(k)];
    std::vector<int> free;
    for (int k = 0; k < n; ++k)
        if (!c.fixed(k)) free.push_back(k);
    Eigen::MatrixXd af(a.rows(), Eigen::Index(free.size()));
    for (std::size_t f = 0; f < free.size(); ++f) af.col(Eigen::Index(f)) = a.col(free[f]);
    const Eigen::VectorXd residual = b - a * reference;
    Eigen::VectorXd deviation = Eigen::VectorXd::Zero(Eigen::Index(free.size()));
    if (af.rows() > 0 && af.cols() > 0) deviation = af.completeOrthogonalDecomposition().solve(residual);
    std::vector<double> z(reference.data(), reference.data() + n);
    for (std::size_t f = 0; f < free.size(); ++f) z[std::size_t(free[f])] += deviation[Eigen::Index(f)];
    return z;
}

std::array<Channel, 3> channels(const PathProblem& p, const PathWeights& w) {
    const std::size_t n = p.roots.size();
    if (n == 0 || p.facings.size() != n) throw Error("path optimisation: roots and facings must have the same, non-zero length");
    if (!p.turns.empty() && p.turns.size() != n) throw Error("path optimisation: one turn per frame, or none");
    if (!p.first && !p.last) throw Error("path optimisation: a transitional segment needs at least one fixed end");
    if (!(w.delta >= 0 && w.delta <= 1)) throw Error("path optimisation: delta must lie in [0, 1]");
    auto turn = [&](std::size_t k) { return p.turns.empty() ? 0.0 : p.turns[k]; };
    const std::vector<double> root_w = speed_weights(p.roots, w.alpha, w.v_c);
    const std::vector<double> facing_w = speed_weights(p.facings, w.alpha, w.r_c);

    // The rigid moves that carry the captured path onto each fixed end (turn, then shift), blended.
    std::vector<Eigen::Vector2d> moved_roots(n);
    std::vector<double> moved_facings(n);
    for (std::size_t k = 0; k < n; ++k) {
        auto onto = [&](const PathEnd& end, std::size_t at) {
            return std::pair{Eigen::Vector2d(Eigen::Rotation2Dd(turn(at)) * (p.roots[k] - p.roots[at]) + end.root),
                             p.facings[k] - p.facings[at] + end.facing};
        };
        const auto from_first = p.first ? onto(*p.first, 0) : onto(*p.last, n - 1);
        const auto from_last = p.last ? onto(*p.last, n - 1) : from_first;
        const double t = n > 1 ? double(k) / double(n - 1) : 0.0;
        moved_roots[k] = (1 - t) * from_first.first + t * from_last.first;
        moved_facings[k] = (1 - t) * from_first.second + t * from_last.second;
    }
    std::array<Channel, 3> c;
    for (int axis = 0; axis < 3; ++axis) {
        Channel& ch = c[std::size_t(axis)];
        ch.moved.resize(n);
        ch.acceleration_target.assign(n, 0.0);
        ch.velocity_target.assign(n, 0.0);
        for (std::size_t k = 0; k < n; ++k) ch.moved[k] = axis < 2 ? moved_roots[k][axis] : moved_facings[k];
        for (std::size_t k = 1; k + 1 < n; ++k) {
            if (axis < 2) {
                const Eigen::Rotation2Dd r(turn(k));
                ch.acceleration_target[k] = (r * (p.roots[k - 1] - 2 * p.roots[k] + p.roots[k + 1]))[axis];
                ch.velocity_target[k] = (r * ((p.roots[k - 1] - p.roots[k + 1]) / 2))[axis];
            } else {
                ch.acceleration_target[k] = p.facings[k - 1] - 2 * p.facings[k] + p.facings[k + 1];
                ch.velocity_target[k] = (p.facings[k - 1] - p.facings[k + 1]) / 2;
            }
        }
        if (p.first) ch.first = axis < 2 ? p.first->root[axis] : p.first->facing;
        if (p.last) ch.last = axis < 2 ? p.last->root[axis] : p.last->facing;
        ch.acceleration_weight = w.delta;
        ch.velocity_weight = axis < 2 ? root_w : facing_w;
        for (double& v : ch.velocity_weight) v *= 1 - w.delta;
        ch.scale = axis < 2 ? 1.0 : w.lambda;
        if (axis < 2)
            for (const PathTarget& t : p.targets) {
                if (t.frame < 0 || t.frame >= int(n)) throw Error("path optimisation: a target lies outside the segment's frames");
                ch.targets.emplace_back(t.frame, t.root[axis]);
                ch.target_weights.push_back(t.weight);
            }
    }
    return c;
}

template <typename Solve>
PathSolution optimise_with(const PathProblem& problem, const PathWeights& weights, Solve solve) {
    const auto c = channels(problem, weights);
    const auto x = solve(c[0]), y = solve(c[1]), f = solve(c[2]);
    PathSolution s;
    for (std::size_t k = 0; k < x.size(); ++k) s.roots.emplace_back(x[k], y[k]);
    s.facings = f;
    s.root_cost = channel_cost(c[0], x) + channel_cost(c[1], y);
    s.facing_cost = channel_cost(c[2], f);
    return s;
}

}  // namespace

std::vector<double> speed_weights(const std::vector<Eigen::Vector2d>& points, double alpha, double threshold) {
    std::vector<double> w(points.size(), 0.0);
    for (std::size_t k = 1; k + 1 < points.size(); ++k)
        w[k] = sigmoid_weight(((points[k - 1] - points[k]).norm() + (points[k] - points[k + 1]).norm()) / 2, alpha, threshold);
    return w;
}

std::vector<double> speed_weights(const std::vector<double>& angles, double alpha, double threshold) {
    std::vector<double> w(angles.size(), 0.0);
    for (std::size_t k = 1; k + 1 < angles.size(); ++k)
        w[k] = sigmoid_weight((std::abs(angles[k - 1] - angles[k]) + std::abs(angles[k] - angles[k + 1])) / 2, alpha, threshold);
    return w;
}

PathSolution optimise_path(const PathProblem& problem, const PathWeights& weights) {
    return optimise_with(problem, weights, solve_sparse);
}

PathSolution optimise_path_dense(const PathProblem& problem, const PathWeights& weights) {
    return optimise_with(problem, weights, solve_dense);
}

std::pair<double, double> path_cost(const PathProblem& problem, const PathWeights& weights, const std::vector<Eigen::Vector2d>& roots,
                                    const std::vector<double>& facings) {
    const auto c = channels(problem, weights);
    std::vector<double> x, y;
    for (const auto& r : roots) {
        x.push_back(r.x());
        y.push_back(r.y());
    }
    return {channel_cost(c[0], x) + channel_cost(c[1], y), channel_cost(c[2], facings)};
}

}  // namespace amhv
