#pragma once
// Choosing again without a pair of key poses (docs/method.md section 8a, "When a transition cannot
// be freed"): the DP's best choice under restrictions, and the next-best choices that avoid every
// combination of key poses found wrong after the DP, by Lawler's partition.
#include <map>
#include <optional>
#include <vector>

#include "host/choose/chain_dp.hpp"

namespace amhv {

// The key poses near one: the same B rotation and A rotation, B's offset within `radius` metres.
// Near poses fail alike (the lattice holds thousands a few millimetres apart), so a failing pose
// rules out its cell, not itself alone.
struct ChainCell {
    ChainSolution centre;
    int rotation = 0;
    double radius = 0;
    bool holds(const ChainSolution& s, int d, double voxel) const;
};

// Cells of states the DP may not use (excluded) or must use (forced), per key segment.
struct ChainRestrictions {
    std::map<std::size_t, std::vector<ChainCell>> excluded;
    std::map<std::size_t, std::vector<ChainCell>> forced;  // a state in every one
    bool allows(std::size_t i, const ChainSolution& s, int d, double voxel) const;
};

// The exact minimiser among the choices the restrictions allow (solve_chain's DP with every other
// state's cost infinite); nullopt when they allow none.
std::optional<ChainChoice> solve_chain_restricted(const std::vector<ChainSegment>& segments, const ChainWeights& weights,
                                                  const ChainRestrictions& restrictions);

// The choices in increasing cost, ruled-out combinations skipped: next() gives the best choice not
// yet given or ruled out; rule_out(keys, radius) says the last one fails on its poses at those key
// segments (one, or two consecutive: the two ends of a transition), so that no later choice has
// poses in all of their cells together. The choices still open are sets R, each with its best
// choice; a set whose best lies in a ruled-out combination is split, when it comes up, into "R,
// the first key's cell excluded" and "R, the first key forced into its cell, the second key's cell
// excluded": disjoint, and together R without the combination. A set's best bounds every choice
// in it, so the first best that lies in no ruled-out combination is the exact next choice.
class ChainAlternatives {
public:
    ChainAlternatives(const std::vector<ChainSegment>& segments, const ChainWeights& weights);
    std::optional<ChainChoice> next();
    void rule_out(const std::vector<std::size_t>& keys, double radius);

private:
    struct Branch {
        ChainRestrictions restrictions;
        ChainChoice choice;
    };
    using Combination = std::vector<std::pair<std::size_t, ChainCell>>;
    void open(ChainRestrictions restrictions);
    const Combination* ruling_out(const ChainChoice& choice) const;
    void split(const Branch& branch, const Combination& combination);

    const std::vector<ChainSegment>& segments_;
    const ChainWeights& weights_;
    std::vector<Branch> open_;
    std::optional<Branch> current_;
    std::vector<Combination> ruled_out_;
};

}  // namespace amhv
