#pragma once
// Path optimisation of one object's transitional segment (docs/method.md section 8, eq. 19-25), on the
// CPU host: edited roots and facings that keep the captured accelerations and (at low speed) the
// captured velocities, between edited boundaries fixed by the key segments.
//
// Frames 0 .. n-1 of the input include the boundary frames: frame 0 is the last frame of the key
// segment before (when there is one) and frame n-1 the first frame of the key segment after.
// Every frame k with two neighbours contributes
//   delta f_a(k) + (1 - delta) w^C_k f_v(k) + lambda [ delta f_a^F(k) + (1 - delta) w^F_k f_v^F(k) ]
// and the minimiser is found exactly as a banded sparse linear least-squares problem (Eigen).
// x, y and the facing separate into three problems of the same band structure.
#include <optional>
#include <vector>

#include <Eigen/Core>

namespace amhv {

struct PathWeights {
    double delta = 0.5;   // acceleration (1) vs velocity (0)
    double lambda = 1.0;  // facing vs root
    double alpha = 20.0;  // steepness of the speed weights
    double v_c = 0.02;    // root speed threshold, metres per frame
    double r_c = 0.05;    // facing speed threshold, radians per frame
};

struct PathEnd {
    Eigen::Vector2d root = Eigen::Vector2d::Zero();  // edited root, metres
    double facing = 0;                                // edited facing, radians (same unwrapping as the input)
};

// Beyond the paper (docs/method.md section 8a): a point the edited root must pass at one frame,
// added where the two performers would overlap, as a least-squares term of weight `weight`.
struct PathTarget {
    int frame = 0;  // index into the problem's frames
    Eigen::Vector2d root = Eigen::Vector2d::Zero();
    double weight = 1e4;
};

struct PathProblem {
    std::vector<Eigen::Vector2d> roots;  // captured roots C_k, in the scene frame
    std::vector<double> facings;         // captured facings F_k, unwrapped radians
    std::optional<PathEnd> first, last;  // the fixed edited boundaries (at least one)
    // Beyond the paper: the turn (radians) the edit gives the object at each frame. The captured
    // accelerations and velocities are compared after this turn, so a performer turned by the edit
    // keeps walking the way it faces. Empty: no turn, exactly docs/method.md's f_a and f_v.
    std::vector<double> turns;
    std::vector<PathTarget> targets;  // empty: the paper's objective alone
};

struct PathSolution {
    std::vector<Eigen::Vector2d> roots;  // edited C-bar_k (the fixed ends included)
    std::vector<double> facings;         // edited F-bar_k
    double root_cost = 0, facing_cost = 0;  // the objective's two parts at the optimum (facing part includes lambda; targets excluded)
};

// The speed weights w_k = 1 / (1 + exp(alpha (s_k - threshold))), s_k = (|p_{k-1} - p_k| + |p_k - p_{k+1}|) / 2,
// for frames 1 .. n-2 (entries 0 and n-1 are unused and 0).
std::vector<double> speed_weights(const std::vector<Eigen::Vector2d>& points, double alpha, double threshold);
std::vector<double> speed_weights(const std::vector<double>& angles, double alpha, double threshold);

// The exact minimiser, by sparse QR on the banded system. When the objective alone does not
// determine the path (one fixed end, or delta = 0 with its odd/even decoupling), a tie-break term
// 1e-9 |C-bar_k - M_k|^2 picks the minimiser closest to the captured path moved rigidly onto the
// fixed ends (M_k: the two ends' rigid moves blended linearly along the segment); it is zero
// whenever that moved path is itself optimal (e.g. both ends moved by one rigid motion).
PathSolution optimise_path(const PathProblem& problem, const PathWeights& weights);

// The same objective built as one dense matrix over every frame and solved by a generic dense
// least-squares method; for tests.
PathSolution optimise_path_dense(const PathProblem& problem, const PathWeights& weights);

// The objective of a given edited path (root part, facing part).
std::pair<double, double> path_cost(const PathProblem& problem, const PathWeights& weights, const std::vector<Eigen::Vector2d>& roots,
                                    const std::vector<double>& facings);

}  // namespace amhv
