#pragma once
// `amhv propose` (docs/method.md section 13): key segments found in two takes. Each candidate
// pair of contact moments (src/propose/) is swept coarsely on the run's backend and scored by the
// natural choice's criteria (src/edit/natural.hpp) at its best member; the best few are swept again
// at the scene's own sampling. Writes proposals.toml (ready-to-paste [[segments]] blocks) and
// proposals.json.
#include <array>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "src/edit/natural_terms.hpp"
#include "src/pipeline/sweep_stage.hpp"
#include "src/propose/proposals.hpp"
#include "src/results/result_json.hpp"

namespace amhv::pipeline {

// One candidate as swept: its key segment, and per sampling (coarse, then the scene's own for the
// best few) the group's size and its best member's natural score.
struct ProposalSweep {
    double voxel = 0, angle_step_deg = 0;
    std::uint64_t poses = 0, members = 0;
    std::array<std::uint64_t, 4> rejected{};
    double score = std::numeric_limits<double>::infinity();  // the best member's natural cost
    NaturalTerms terms;
    Solution best;
};

struct Proposal {
    propose::Candidate candidate;
    KeySegment segment;
    ProposalSweep coarse;
    std::optional<ProposalSweep> refined;
    const ProposalSweep& decided() const { return refined ? *refined : coarse; }
};

struct ProposeResult {
    std::vector<propose::ContactEvent> events_a, events_b;
    std::vector<Proposal> proposals;  // ranked, best first; only those whose group has a member
    int candidates = 0;               // pairs swept
    double seconds = 0;
};

// Proposals for the two people of `scene`, BVH takes, characters or mesh sequences with part
// labels (its key segments, if any, are not used). Throws amhv::Error naming the file when an
// object is a mesh sequence without part labels (its torso and hands give the moments).
ProposeResult propose_scene(const Scene& scene, Backends& backends);

// `scene` with `proposal` as its one key segment (amhv edit --propose, and propose's best/).
Scene with_proposal(const Scene& scene, const Proposal& proposal);

// Throws amhv::Error naming the scene, in one line, when `result` holds no proposal.
void require_proposals(const Scene& scene, const ProposeResult& result);

// proposals.json's content, and proposals.toml's text.
results::Json proposals_json(const Scene& scene, const ProposeResult& result);
std::string proposals_toml(const Scene& scene, const ProposeResult& result);
// index.html: each take's contact moments as a strip, the ranked table, and the best proposal's
// edit (best/index.html) in a frame, or `best_note` saying why there is none.
std::string proposals_page(const Scene& scene, const ProposeResult& result, const std::string& best_note);

}  // namespace amhv::pipeline
