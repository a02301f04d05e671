#pragma once
// Choosing one solution per key segment (docs/method.md section 7, eq. 16-18) by exact dynamic
// programming over the chain of key segments, on the CPU host.
//
// Scene frame: each object's capture frame is placed in the scene by the editor's placement yaw
// (psi_A, psi_B). State s_i = (j, d): solution j of R_i (B's offset r_j = (x_j, y_j) from A's root
// in A's capture axes, B's rotation theta_j) and A's extra rotation delta_d. Then
//   unary_i(s)    = lambda [ (2 - 2 cos delta) + (2 - 2 cos(psi_A + delta + theta_j - psi_B)) ]
//                 + mu [ |r_j - r0_i|^2 + wrap(theta_j - theta0_i)^2 ]
//   pair_i(s, s') = w_A w_B / (w_A + w_B) |P_i(s) - Q_{i+1}(s')|^2, with
//   P_i(s) = R(psi_B) dC^B_i - R(psi_A) dC^A_i + R(psi_A + delta) r_j and Q_{i+1}(s') = R(psi_A + delta') r_j',
// (e_i = P - Q; A's translations are eliminated in closed form). For transitions between equal A
// rotations the points lie on one grid of step h, so a separable distance transform of sampled
// functions (Felzenszwalb-Huttenlocher) makes each transition linear in the number of states.
#include <vector>

#include <Eigen/Core>

#include "src/core/process.hpp"

namespace amhv {

struct ChainSolution {
    int i = 0, j = 0;        // B's root offset from A's root, in voxels of the grid (x = i h, y = j h)
    double theta_rad = 0;    // B's rotation (the edit keeps each solution's lattice index beside the chain)
};

// On zero pages until written: the edit fills a gigabyte of them at 5 mm, a chunk per core.
using ChainSolutions = std::vector<ChainSolution, CallocAllocator<ChainSolution>>;

struct ChainSegment {
    ChainSolutions solutions;  // R_i, non-empty
    Eigen::Vector2d root_a = Eigen::Vector2d::Zero(), root_b = Eigen::Vector2d::Zero();  // capture frames, metres
    Eigen::Vector2d prior_offset = Eigen::Vector2d::Zero();  // r0: where the initial placement puts B (A's capture axes)
    double prior_theta_rad = 0;
    // How much B's facing term counts here (1: the paper's; 0: B's turn is not pulled toward the
    // editor's placement, docs/method.md section 7).
    double facing_b_weight = 1;
    // Per solution, a cost the edit adds to the unary (the editor's intent); empty: none.
    std::vector<double> extra_unary;
};

struct ChainWeights {
    double voxel = 0.01;
    double w_a = 1, w_b = 1, lambda = 1, mu = 1e-6;
    double yaw_a = 0, yaw_b = 0;                 // placement yaws psi_A, psi_B (radians)
    std::vector<double> a_rotations_rad{0.0};    // the set of delta
};

struct ChainChoice {
    std::vector<int> solution;  // index into R_i per segment
    std::vector<int> rotation;  // index into a_rotations_rad per segment
    double cost = 0, unary = 0, pairwise = 0;
};

struct ChainRestrictions;
// Exact minimiser by dynamic programming (distance transform for equal-rotation transitions); with
// `restrictions`, among the states they allow (host/choose/chain_alternatives.hpp): a choice of
// infinite cost and no states when they allow none.
ChainChoice solve_chain(const std::vector<ChainSegment>& segments, const ChainWeights& weights, const ChainRestrictions* restrictions = nullptr);
// Every combination; for tests on small chains.
ChainChoice solve_chain_exhaustively(const std::vector<ChainSegment>& segments, const ChainWeights& weights);
// The objective of one choice (fills cost, unary, pairwise).
void evaluate_chain(const std::vector<ChainSegment>& segments, const ChainWeights& weights, ChainChoice& choice);

// A's optimal translation steps u_i = t_{i+1} - t_i = w_B e_i / (w_A + w_B) for a choice (zero for
// w_A = infinity: A stays where it was captured).
std::vector<Eigen::Vector2d> a_translation_steps(const std::vector<ChainSegment>& segments, const ChainWeights& weights,
                                                 const ChainChoice& choice);

// f(q) = min_k g_k + c (q - v_k)^2 for centres v (ascending) and queries q (ascending); also the argmin k.
// Infinite g_k are ignored; f is infinite (argmin -1) when every g_k is.
void lower_envelope(const std::vector<double>& v, const std::vector<double>& g, double c, const std::vector<double>& q,
                    std::vector<double>& f, std::vector<int>& argmin);

}  // namespace amhv
