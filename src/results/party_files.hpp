#pragma once
// Files of a multi-party edit (docs/method.md section 11): every object's per-frame transforms, the
// check of every pair at every output frame, and every object's moved mesh per output frame.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "src/edit/edit.hpp"
#include "src/results/edit_files.hpp"
#include "src/results/result_json.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"

namespace amhv::results {

struct PartyFiles {
    int mesh_files = 0;
};

// One pair's check at one output frame, as the files read it.
struct PairRow {
    int frame = 0;
    std::size_t first = 0, second = 0;  // object indices
    std::uint64_t overlap = 0;
    std::optional<double> gap_m;
};

// transforms.json: per output frame and object (in placement order), the source frame and
// capture -> scene as x, y, z, yaw and a row-major 4x4 matrix (the two-object file's convention).
void write_party_transforms_json(const std::filesystem::path& path, const Scene& scene, const std::vector<std::string>& names,
                                 const std::vector<std::vector<ObjectFrameEdit>>& frames);

// `folder`/NNNN.ply: every object's moved mesh per output frame, each in its own colour (the
// header's comments give each object's vertex and face ranges and colour). Returns the files.
int write_party_frames(const std::filesystem::path& folder, const std::vector<std::string>& names,
                       const std::vector<std::vector<ObjectFrameEdit>>& frames, const std::vector<ObjectSource*>& sources);


// result.json's "pairs": per pair, the frames checked, the frames with overlap, the largest overlap
// and the smallest gap.
Json pair_summary(const std::vector<std::string>& names, const std::vector<PairRow>& rows, double voxel);

// frames.csv: frame,pair,overlap_voxels,overlap_cm3,gap_mm for every pair at every output frame
// (gap empty beyond kGapReach).
void write_pair_checks_csv(const std::filesystem::path& path, const std::vector<std::string>& names, const std::vector<PairRow>& rows, double voxel);

}  // namespace amhv::results
