#include "host/choose/chain_alternatives.hpp"

#include <algorithm>
#include <cmath>

namespace amhv {

bool ChainCell::holds(const ChainSolution& s, int d, double voxel) const {
    return d == rotation && s.theta_rad == centre.theta_rad && std::hypot(s.i - centre.i, s.j - centre.j) * voxel <= radius;
}

bool ChainRestrictions::allows(std::size_t i, const ChainSolution& s, int d, double voxel) const {
    if (auto f = forced.find(i); f != forced.end())
        for (const ChainCell& cell : f->second)
            if (!cell.holds(s, d, voxel)) return false;
    if (auto e = excluded.find(i); e != excluded.end())
        for (const ChainCell& cell : e->second)
            if (cell.holds(s, d, voxel)) return false;
    return true;
}

std::optional<ChainChoice> solve_chain_restricted(const std::vector<ChainSegment>& segments, const ChainWeights& weights,
                                                  const ChainRestrictions& restrictions) {
    ChainChoice choice = solve_chain(segments, weights, &restrictions);
    if (!std::isfinite(choice.cost)) return std::nullopt;
    return choice;
}

ChainAlternatives::ChainAlternatives(const std::vector<ChainSegment>& segments, const ChainWeights& weights)
    : segments_(segments), weights_(weights) {
    open({});
}

void ChainAlternatives::open(ChainRestrictions restrictions) {
    if (auto choice = solve_chain_restricted(segments_, weights_, restrictions)) open_.push_back({std::move(restrictions), std::move(*choice)});
}

const ChainAlternatives::Combination* ChainAlternatives::ruling_out(const ChainChoice& choice) const {
    for (const Combination& combination : ruled_out_) {
        bool all = true;
        for (const auto& [i, cell] : combination)
            all = all && cell.holds(segments_[i].solutions[std::size_t(choice.solution[i])], choice.rotation[i], weights_.voxel);
        if (all) return &combination;
    }
    return nullptr;
}

void ChainAlternatives::split(const Branch& branch, const Combination& combination) {
    for (std::size_t m = 0; m < combination.size(); ++m) {
        ChainRestrictions r = branch.restrictions;
        for (std::size_t before = 0; before < m; ++before) r.forced[combination[before].first].push_back(combination[before].second);
        r.excluded[combination[m].first].push_back(combination[m].second);
        open(std::move(r));
    }
}

std::optional<ChainChoice> ChainAlternatives::next() {
    while (!open_.empty()) {
        // The cheapest open set's best choice; on equal costs the set opened first.
        const auto best = std::min_element(open_.begin(), open_.end(), [](const Branch& x, const Branch& y) { return x.choice.cost < y.choice.cost; });
        Branch branch = std::move(*best);
        open_.erase(best);
        if (const Combination* combination = ruling_out(branch.choice)) {
            split(branch, *combination);
            continue;
        }
        current_ = std::move(branch);
        return current_->choice;
    }
    return std::nullopt;
}

void ChainAlternatives::rule_out(const std::vector<std::size_t>& keys, double radius) {
    if (!current_) return;
    Combination combination;
    for (std::size_t i : keys)
        combination.push_back({i, ChainCell{segments_[i].solutions[std::size_t(current_->choice.solution[i])], current_->choice.rotation[i], radius}});
    ruled_out_.push_back(std::move(combination));
    open_.push_back(std::move(*current_));  // split by the combination when it comes up again
    current_.reset();
}

}  // namespace amhv
