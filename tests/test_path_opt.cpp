// Path optimisation of transitional segments (docs/method.md section 8): analytic cases and the sparse
// banded solve against a generic dense least-squares solve.
#include <cmath>
#include <random>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "host/paths/path_opt.hpp"

namespace amhv {
namespace {

PathProblem straight_walk(int n, double speed) {
    PathProblem p;
    for (int k = 0; k < n; ++k) {
        p.roots.emplace_back(0.3 + speed * k, -0.2 + 0.5 * speed * k);
        p.facings.push_back(0.1);
    }
    return p;
}

TEST(PathOpt, StraightWalkShiftedAtBothEndsStaysStraightAndKeepsItsSpeed) {
    for (double delta : {0.0, 0.3, 0.5, 1.0}) {
        PathProblem p = straight_walk(40, 0.03);
        const Eigen::Vector2d shift(1.25, -0.75);
        p.first = PathEnd{p.roots.front() + shift, 0.1 + 0.4};
        p.last = PathEnd{p.roots.back() + shift, 0.1 + 0.4};
        PathWeights w;
        w.delta = delta;
        PathSolution s = optimise_path(p, w);
        for (std::size_t k = 0; k < p.roots.size(); ++k) {
            EXPECT_NEAR((s.roots[k] - (p.roots[k] + shift)).norm(), 0, 1e-9) << "delta " << delta << " frame " << k;
            EXPECT_NEAR(s.facings[k], 0.5, 1e-9);
        }
        EXPECT_NEAR(s.root_cost, 0, 1e-15);
        EXPECT_NEAR(s.facing_cost, 0, 1e-15);
    }
}

TEST(PathOpt, AccelerationOnlyAddsALinearRampBetweenDifferentEndShifts) {
    // delta = 1: only accelerations count, so the edited path is the captured one plus the straight
    // blend of the two end displacements (zero cost), on a curved, varying-speed path.
    PathProblem p;
    for (int k = 0; k < 30; ++k) {
        p.roots.emplace_back(std::sin(k * 0.2) * 0.8, 0.02 * k * k * 0.05);
        p.facings.push_back(std::cos(k * 0.1));
    }
    const Eigen::Vector2d d0(0.5, 0.1), d1(-0.4, 0.9);
    p.first = PathEnd{p.roots.front() + d0, p.facings.front() + 0.3};
    p.last = PathEnd{p.roots.back() + d1, p.facings.back() - 0.2};
    PathWeights w;
    w.delta = 1;
    PathSolution s = optimise_path(p, w);
    for (std::size_t k = 0; k < 30; ++k) {
        const double t = double(k) / 29;
        EXPECT_NEAR((s.roots[k] - (p.roots[k] + d0 + (d1 - d0) * t)).norm(), 0, 1e-9);
        EXPECT_NEAR(s.facings[k], p.facings[k] + 0.3 + (-0.5) * t, 1e-9);
    }
    EXPECT_NEAR(s.root_cost, 0, 1e-15);
}

TEST(PathOpt, OneFixedEndMovesTheWholeSegmentRigidlyInTranslation) {
    // A free end: translating the captured path keeps every acceleration and velocity (zero cost),
    // for every delta, including the two degenerate extremes.
    for (double delta : {0.0, 0.5, 1.0})
        for (bool fixed_first : {true, false}) {
            PathProblem p;
            for (int k = 0; k < 25; ++k) {
                p.roots.emplace_back(0.04 * k, 0.3 * std::sin(0.3 * k));
                p.facings.push_back(0.05 * k);
            }
            const Eigen::Vector2d d(-2, 3);
            const PathEnd end{(fixed_first ? p.roots.front() : p.roots.back()) + d, (fixed_first ? p.facings.front() : p.facings.back()) + 1};
            (fixed_first ? p.first : p.last) = end;
            PathWeights w;
            w.delta = delta;
            PathSolution s = optimise_path(p, w);
            for (std::size_t k = 0; k < 25; ++k) {
                EXPECT_NEAR((s.roots[k] - (p.roots[k] + d)).norm(), 0, 1e-7) << delta << " " << fixed_first << " " << k;
                EXPECT_NEAR(s.facings[k], p.facings[k] + 1, 1e-7);
            }
        }
}

TEST(PathOpt, VelocityOnlyKeepsCentralVelocitiesWhereItCan) {
    // delta = 0: the cost is (1 - delta) w_k |dv|^2 only. Here both ends move apart; the optimum
    // must cost no more than the linear ramp, and must satisfy the normal equations: at the optimum,
    // no single-frame perturbation lowers the cost.
    PathProblem p = straight_walk(21, 0.01);
    p.first = PathEnd{p.roots.front(), 0.1};
    p.last = PathEnd{p.roots.back() + Eigen::Vector2d(0.4, 0), 0.1};
    PathWeights w;
    w.delta = 0;
    PathSolution s = optimise_path(p, w);
    std::vector<Eigen::Vector2d> ramp;
    for (std::size_t k = 0; k < 21; ++k) ramp.push_back(p.roots[k] + Eigen::Vector2d(0.4 * double(k) / 20, 0));
    const double optimum = path_cost(p, w, s.roots, s.facings).first;
    EXPECT_LE(optimum, path_cost(p, w, ramp, s.facings).first + 1e-15);
    EXPECT_NEAR(optimum, s.root_cost, 1e-15);
    for (std::size_t k = 1; k + 1 < 21; ++k)
        for (double e : {-1e-4, 1e-4}) {
            auto moved = s.roots;
            moved[k].x() += e;
            EXPECT_GE(path_cost(p, w, moved, s.facings).first, optimum - 1e-15);
        }
}

TEST(PathOpt, ATurnedObjectKeepsWalkingTheWayItFaces) {
    // With the edit's turn given, a segment with one fixed end is the captured walk moved rigidly
    // (turned and shifted) onto that end, at zero cost; so is a segment whose two ends are moved by
    // one rigid motion.
    const double turn = 2.0;
    PathProblem base = straight_walk(30, 0.04);
    for (std::size_t k = 0; k < base.facings.size(); ++k) base.facings[k] = 0.1 + 0.01 * double(k);
    const Eigen::Vector2d shift(3, -1);
    auto rigid = [&](std::size_t k) { return Eigen::Vector2d(Eigen::Rotation2Dd(turn) * base.roots[k] + shift); };
    for (int ends = 0; ends < 3; ++ends) {
        PathProblem p = base;
        p.turns.assign(p.roots.size(), turn);
        if (ends != 2) p.first = PathEnd{rigid(0), p.facings.front() + turn};
        if (ends != 1) p.last = PathEnd{rigid(p.roots.size() - 1), p.facings.back() + turn};
        PathSolution s = optimise_path(p, PathWeights{});
        for (std::size_t k = 0; k < p.roots.size(); ++k) {
            EXPECT_NEAR((s.roots[k] - rigid(k)).norm(), 0, 1e-8) << ends << " " << k;
            EXPECT_NEAR(s.facings[k], p.facings[k] + turn, 1e-8);
        }
        EXPECT_NEAR(s.root_cost, 0, 1e-14);
        if (ends == 0) {  // without the turn (docs/method.md's world-frame velocities) the same two ends cost something
            p.turns.clear();
            EXPECT_GT(optimise_path(p, PathWeights{}).root_cost, 1e-6);
        }
    }
}

TEST(PathOpt, SpeedWeightsFollowTheLogisticFormula) {
    std::vector<Eigen::Vector2d> pts{{0, 0}, {0.01, 0}, {0.05, 0}, {0.05, 0}};
    const auto w = speed_weights(pts, 20, 0.02);
    EXPECT_EQ(w[0], 0);
    EXPECT_NEAR(w[1], 1 / (1 + std::exp(20 * ((0.01 + 0.04) / 2 - 0.02))), 1e-15);
    EXPECT_NEAR(w[2], 1 / (1 + std::exp(20 * ((0.04 + 0.0) / 2 - 0.02))), 1e-15);
    EXPECT_EQ(speed_weights(pts, 1e6, 0.0)[2], 0.0);  // overflow of exp gives weight 0, not NaN
}

TEST(PathOpt, SparseBandedSolveMatchesDenseLeastSquaresOnRandomInstances) {
    std::mt19937 random(11);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int round = 0; round < 60; ++round) {
        const int n = 2 + int(random() % 60);
        PathProblem p;
        Eigen::Vector2d c(u(random), u(random));
        double f = u(random);
        for (int k = 0; k < n; ++k) {
            c += Eigen::Vector2d(u(random), u(random)) * 0.04;
            f += u(random) * 0.1;
            p.roots.push_back(c);
            p.facings.push_back(f);
        }
        const int ends = round % 3;  // 0 both, 1 first only, 2 last only
        if (ends != 2) p.first = PathEnd{p.roots.front() + Eigen::Vector2d(u(random), u(random)), p.facings.front() + u(random)};
        if (ends != 1) p.last = PathEnd{p.roots.back() + Eigen::Vector2d(u(random), u(random)), p.facings.back() + u(random)};
        PathWeights w;
        w.delta = 0.05 + 0.9 * (u(random) + 1) / 2;
        w.lambda = 0.2 + (u(random) + 1);
        w.alpha = 10 + 30 * (u(random) + 1);
        PathSolution sparse = optimise_path(p, w), dense = optimise_path_dense(p, w);
        ASSERT_EQ(sparse.roots.size(), std::size_t(n));
        for (int k = 0; k < n; ++k) {
            EXPECT_NEAR((sparse.roots[std::size_t(k)] - dense.roots[std::size_t(k)]).norm(), 0, 1e-7) << "round " << round << " frame " << k;
            EXPECT_NEAR(sparse.facings[std::size_t(k)], dense.facings[std::size_t(k)], 1e-7);
        }
        EXPECT_NEAR(sparse.root_cost, dense.root_cost, 1e-9 * (1 + dense.root_cost));
        EXPECT_NEAR(sparse.facing_cost, dense.facing_cost, 1e-9 * (1 + dense.facing_cost));
        if (p.first) {
            EXPECT_EQ(sparse.roots.front(), p.first->root);
        }
        if (p.last) {
            EXPECT_EQ(sparse.roots.back(), p.last->root);
        }
    }
}

TEST(PathOpt, RejectsAFreeFloatingSegment) {
    PathProblem p = straight_walk(5, 0.01);
    EXPECT_THROW(optimise_path(p, PathWeights{}), std::exception);
}

}  // namespace
}  // namespace amhv
