#pragma once
// `amhv solutions`: one key segment's group from an output folder's segment_N/group.vdb, printed
// as a summary or exported as the CSV the sweep writes (same columns, same order, same bytes).
#include <filesystem>
#include <string>
#include <vector>

#include "src/results/group_vdb.hpp"
#include "src/sweep/solution_group.hpp"

namespace amhv::pipeline {

struct GroupRead {
    results::GroupLattice lattice;
    SolutionGroup group;
    PoseDescriber describe;  // the descriptors of a member (facings from result.json)
    std::uint64_t file_bytes = 0;
};

// Reads `dir`/segment_N/group.vdb; the facings for the descriptors come from `dir`/result.json.
GroupRead read_group(const std::filesystem::path& dir, int segment);

// The group's size, bounding box and count per angle, as lines for a terminal.
std::string group_report(const GroupRead& group);

// Writes the group as solutions.csv to `path`, which must not exist (amhv never overwrites a file
// it did not create); written beside it and moved into place when complete.
void export_group_csv(const GroupRead& group, const std::filesystem::path& path);

}  // namespace amhv::pipeline
