// The choice of one solution per key segment (docs/method.md section 7): the distance-transform DP
// against exhaustive enumeration, the lower envelope against brute force, and the w_A -> infinity limit.
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <set>
#include <tuple>
#include <random>

#include <gtest/gtest.h>

#include "host/choose/chain_alternatives.hpp"
#include "host/choose/chain_dp.hpp"

namespace amhv {
namespace {

TEST(ChainDp, LowerEnvelopeMatchesBruteForce) {
    std::mt19937 random(7);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int round = 0; round < 200; ++round) {
        int n = 1 + int(random() % 12), m = 1 + int(random() % 12);
        std::vector<double> v(static_cast<std::size_t>(n)), g(static_cast<std::size_t>(n)), q(static_cast<std::size_t>(m));
        for (int k = 0; k < n; ++k) {
            v[std::size_t(k)] = std::round(u(random) * 5) * 0.1 + (round % 2 ? 0.037 : 0);
            g[std::size_t(k)] = random() % 5 == 0 ? std::numeric_limits<double>::infinity() : u(random);
        }
        std::sort(v.begin(), v.end());
        for (auto& x : q) x = u(random) * 0.8;
        std::sort(q.begin(), q.end());
        const double c = 0.5 + std::abs(u(random)) * 10;
        std::vector<double> f;
        std::vector<int> arg;
        lower_envelope(v, g, c, q, f, arg);
        for (int t = 0; t < m; ++t) {
            double best = std::numeric_limits<double>::infinity();
            for (int k = 0; k < n; ++k) best = std::min(best, g[std::size_t(k)] + c * std::pow(q[std::size_t(t)] - v[std::size_t(k)], 2));
            if (std::isinf(best)) {
                EXPECT_TRUE(std::isinf(f[std::size_t(t)]));
                continue;
            }
            EXPECT_NEAR(f[std::size_t(t)], best, 1e-12);
            int k = arg[std::size_t(t)];
            ASSERT_GE(k, 0);
            EXPECT_NEAR(g[std::size_t(k)] + c * std::pow(q[std::size_t(t)] - v[std::size_t(k)], 2), best, 1e-12);
        }
    }
}

std::vector<ChainSegment> random_chain(std::mt19937& random, int segments, int max_solutions) {
    std::uniform_real_distribution<double> u(-1, 1);
    std::vector<ChainSegment> chain(static_cast<std::size_t>(segments));
    Eigen::Vector2d a(0, 0), b(1.5, 0.3);
    for (auto& s : chain) {
        a += Eigen::Vector2d(u(random), u(random));
        b += Eigen::Vector2d(u(random), u(random));
        s.root_a = a;
        s.root_b = b;
        s.prior_offset = Eigen::Vector2d(u(random), u(random)) * 0.5;
        s.prior_theta_rad = u(random) * 3;
        const int n = 1 + int(random() % unsigned(max_solutions));
        for (int k = 0; k < n; ++k) s.solutions.push_back({int(random() % 21) - 10, int(random() % 21) - 10, u(random) * std::numbers::pi});
    }
    return chain;
}

TEST(ChainDp, MatchesExhaustiveEnumeration) {
    std::mt19937 random(20261121);
    std::uniform_real_distribution<double> u(0, 1);
    for (int round = 0; round < 300; ++round) {
        auto chain = random_chain(random, 1 + round % 4, 7);
        ChainWeights w;
        w.voxel = 0.05;
        w.w_a = 0.2 + 3 * u(random);
        w.w_b = 0.2 + 3 * u(random);
        w.lambda = round % 5 == 0 ? 0 : 2 * u(random);
        w.mu = round % 3 == 0 ? 0 : 0.5 * u(random);
        w.yaw_a = (u(random) - 0.5) * 2;
        w.yaw_b = (u(random) - 0.5) * 2;
        if (round % 2) w.a_rotations_rad = {-0.2, 0.0, 0.15};
        ChainChoice dp = solve_chain(chain, w), all = solve_chain_exhaustively(chain, w);
        ASSERT_NEAR(dp.cost, all.cost, 1e-9 * (1 + all.cost)) << "round " << round;
        ChainChoice check = dp;
        evaluate_chain(chain, w, check);
        EXPECT_NEAR(check.cost, dp.cost, 1e-12 * (1 + dp.cost));
    }
}

// Choosing again without failing combinations (host/choose/chain_alternatives.hpp): on random
// chains where random pairs of consecutive key poses (and single end poses) "leave a transition
// stuck", ruling out each stuck choice's cells and asking again reaches exactly the cheapest
// choice that is neither stuck nor in a ruled-out combination of cells (exhaustive enumeration;
// with radius 0 a cell is one pose), giving no choice twice and the choices in increasing cost.
using ChainState = std::pair<int, int>;  // (solution, A rotation)

TEST(ChainDp, AlternativesSkipRuledOutCombinationsExactly) {
    std::mt19937 random(20261126);
    std::uniform_real_distribution<double> u(0, 1);
    for (int round = 0; round < 200; ++round) {
        const int keys = 1 + round % 4;
        auto chain = random_chain(random, keys, 5);
        ChainWeights w;
        w.voxel = 0.05;
        w.mu = 0.3 * u(random);
        w.yaw_a = u(random) - 0.5;
        if (round % 2) w.a_rotations_rad = {-0.2, 0.0};
        for (auto& s : chain)  // pairs of solutions a voxel or two apart at one angle, so that cells hold several
            if (s.solutions.size() > 1 && round % 3 == 0) s.solutions[1] = {s.solutions[0].i + 1, s.solutions[0].j, s.solutions[0].theta_rad};
        const double radius = round % 2 ? 0.0 : 0.12;
        const double stuck_share = 0.2 + 0.6 * u(random);
        std::map<std::tuple<std::size_t, ChainState, ChainState>, bool> stuck;  // transition t (0: before key 0) and its end states
        auto is_stuck = [&](std::size_t t, ChainState before, ChainState after) {
            auto [at, added] = stuck.emplace(std::make_tuple(t, before, after), false);
            if (added) at->second = u(random) < stuck_share;
            return at->second;
        };
        auto first_stuck = [&](const ChainChoice& c) -> std::optional<std::vector<std::size_t>> {
            auto state = [&](std::size_t i) { return ChainState{c.solution[i], c.rotation[i]}; };
            for (std::size_t t = 0; t <= std::size_t(keys); ++t) {
                const ChainState none{-1, -1};
                if (!is_stuck(t, t > 0 ? state(t - 1) : none, t < std::size_t(keys) ? state(t) : none)) continue;
                std::vector<std::size_t> around;
                if (t > 0) around.push_back(t - 1);
                if (t < std::size_t(keys)) around.push_back(t);
                return around;
            }
            return std::nullopt;
        };
        std::vector<std::vector<std::pair<std::size_t, ChainCell>>> ruled_out;  // combinations of cells
        auto in_ruled_out = [&](const ChainChoice& c) {
            for (const auto& combination : ruled_out) {
                bool all = true;
                for (const auto& [i, cell] : combination) all = all && cell.holds(chain[i].solutions[std::size_t(c.solution[i])], c.rotation[i], w.voxel);
                if (all) return true;
            }
            return false;
        };
        ChainAlternatives alternatives(chain, w);
        std::set<std::pair<std::vector<int>, std::vector<int>>> given;
        double last_cost = -1;
        std::optional<ChainChoice> found;
        while (auto choice = alternatives.next()) {
            EXPECT_TRUE(given.insert({choice->solution, choice->rotation}).second) << "round " << round;
            EXPECT_FALSE(in_ruled_out(*choice)) << "round " << round;
            EXPECT_GE(choice->cost, last_cost - 1e-12);
            last_cost = choice->cost;
            auto around = first_stuck(*choice);
            if (!around) {
                found = choice;
                break;
            }
            std::vector<std::pair<std::size_t, ChainCell>> combination;
            for (std::size_t i : *around) combination.push_back({i, {chain[i].solutions[std::size_t(choice->solution[i])], choice->rotation[i], radius}});
            ruled_out.push_back(combination);
            alternatives.rule_out(*around, radius);
        }
        std::optional<double> best;  // every choice, exhaustively
        ChainChoice c;
        c.solution.assign(std::size_t(keys), 0);
        c.rotation.assign(std::size_t(keys), 0);
        while (true) {
            evaluate_chain(chain, w, c);
            if (!first_stuck(c) && !in_ruled_out(c) && (!best || c.cost < *best)) best = c.cost;
            std::size_t i = 0;
            for (; i < std::size_t(keys); ++i) {
                if (++c.rotation[i] < int(w.a_rotations_rad.size())) break;
                c.rotation[i] = 0;
                if (++c.solution[i] < int(chain[i].solutions.size())) break;
                c.solution[i] = 0;
            }
            if (i == std::size_t(keys)) break;
        }
        ASSERT_EQ(found.has_value(), best.has_value()) << "round " << round;
        if (best) {
            EXPECT_NEAR(found->cost, *best, 1e-9 * (1 + *best)) << "round " << round;
        }
    }
}

// w_A -> infinity: A's translations vanish (A stays where it was captured) and the choice is the
// one that best keeps B's displacements alone.
TEST(ChainDp, InfiniteWeightOnAKeepsAInPlace) {
    std::mt19937 random(3);
    for (int round = 0; round < 50; ++round) {
        auto chain = random_chain(random, 3, 6);
        ChainWeights w;
        w.voxel = 0.05;
        w.w_a = std::numeric_limits<double>::infinity();
        ChainChoice dp = solve_chain(chain, w);
        for (const auto& step : a_translation_steps(chain, w, dp)) EXPECT_EQ(step.norm(), 0.0);
        ChainWeights huge = w;
        huge.w_a = 1e12;
        EXPECT_NEAR(solve_chain_exhaustively(chain, huge).cost, dp.cost, 1e-6 * (1 + dp.cost));
        ChainWeights finite = w;
        finite.w_a = 1;
        bool moved = false;
        for (const auto& step : a_translation_steps(chain, finite, solve_chain(chain, finite))) moved = moved || step.norm() > 0;
        EXPECT_TRUE(moved);
    }
}

// A large chain: 3 segments of 40,000 solutions on 100 x 100 cells x 4 angles; the DP optimum is
// no worse than any of many random choices and than the best choice per segment pair found greedily.
TEST(ChainDp, LargeGroupsAreHandled) {
    std::vector<ChainSegment> chain(3);
    for (int s = 0; s < 3; ++s) {
        chain[std::size_t(s)].root_a = Eigen::Vector2d(2.0 * s, 0);
        chain[std::size_t(s)].root_b = Eigen::Vector2d(2.0 * s + 0.3 * s, 1.0 + 0.1 * s);
        for (int k = 0; k < 4; ++k)
            for (int j = -50; j < 50; ++j)
                for (int i = -50; i < 50; ++i) chain[std::size_t(s)].solutions.push_back({i, j, k * std::numbers::pi / 2});
    }
    ChainWeights w;
    ChainChoice dp = solve_chain(chain, w);
    std::mt19937 random(11);
    for (int trial = 0; trial < 2000; ++trial) {
        ChainChoice other = dp;
        for (std::size_t s = 0; s < 3; ++s) other.solution[s] = int(random() % chain[s].solutions.size());
        evaluate_chain(chain, w, other);
        EXPECT_LE(dp.cost, other.cost + 1e-12);
    }
    // Perfectly consistent offsets exist (B's displacement minus A's is on the grid), so the
    // pairwise term reaches zero.
    EXPECT_NEAR(dp.pairwise, 0.0, 1e-12);
}

// The editor's intent enters the unary cost (docs/method.md section 7, "Intent"): the DP with an
// extra unary per solution still equals exhaustive enumeration.
TEST(ChainDp, IntentCostsMatchExhaustiveEnumeration) {
    std::mt19937 random(20261125);
    std::uniform_real_distribution<double> u(0, 5);
    for (int round = 0; round < 200; ++round) {
        auto chain = random_chain(random, 1 + round % 4, 7);
        for (auto& s : chain)
            if (random() % 2)
                for (std::size_t k = 0; k < s.solutions.size(); ++k) s.extra_unary.push_back(u(random));
        ChainWeights w;
        w.voxel = 0.05;
        ChainChoice dp = solve_chain(chain, w), all = solve_chain_exhaustively(chain, w);
        EXPECT_NEAR(dp.cost, all.cost, 1e-9 * (1 + all.cost)) << "round " << round;
        EXPECT_EQ(dp.solution, all.solution) << "round " << round;
    }
}

// With one key segment the intent decides among solutions the paper's terms leave nearly flat.
TEST(ChainDp, IntentPicksThePreferredSolution) {
    std::vector<ChainSegment> chain(1);
    for (int i = 0; i < 10; ++i) chain[0].solutions.push_back({i, 0, 0.0});
    for (int i = 0; i < 10; ++i) chain[0].extra_unary.push_back(std::pow(i - 6, 2));
    EXPECT_EQ(solve_chain(chain, ChainWeights{}).solution[0], 6);
}

}  // namespace
}  // namespace amhv
