#pragma once
// Multi-party scenes (docs/method.md section 11): the objects are placed one at a time in the
// scene's order, each against every object placed before it, which stay fixed. Each placement is
// a two-object edit (the sweep stage, the DP, the paths, the checks) of a stage scene whose A is
// the placed group (src/scene/segment.hpp) and whose B is the object being placed.
#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "src/pipeline/sweep_stage.hpp"
#include "src/results/party_files.hpp"

namespace amhv::pipeline {

// One placement.
struct PartyStage {
    std::string object;               // placed in this stage
    std::vector<std::string> against;  // the objects placed before it
    Scene scene;                      // the stage scene: A is the group (or the anchor), B the object
    SweepStage sweep;
    EditResult edit;
};

// Every object through the whole edited scene.
struct PartyEdit {
    std::vector<std::string> names;  // the scene's placement order
    std::vector<std::vector<ObjectFrameEdit>> frames;  // per object (names' order), per output frame
    std::vector<PartyStage> stages;
    int length() const { return frames.empty() ? 0 : int(frames.front().size()); }
};

// One output frame's check of two objects (both whole bodies as solids at the scene's voxel);
// first and second index PartyEdit::names.
using PairCheck = results::PairRow;

// `amhv edit` of a multi-party scene into `out`: every stage (segment_N/... for each key segment),
// then transforms.json, frames.csv (every pair at every output frame), frames/NNNN.ply and
// result.json. Returns the edit.
PartyEdit edit_party_into(const Scene& scene, Backends& backends, const std::filesystem::path& out, const EditRunOptions& options,
                          std::chrono::steady_clock::time_point start);

// The steps, for tests: the stages of `scene` run one after the other (no files but segment_N/).
PartyEdit edit_party(const Scene& scene, std::vector<std::unique_ptr<ObjectSource>>& sources, Backends& backends, const std::filesystem::path& out,
                     const EditRunOptions& options);

// The placed group of the objects `placed` holds (src/scene/segment.hpp), `partner` first, as the
// next stage sweeps against it; `sources` in the scene's placement order.
std::unique_ptr<ObjectSource> placed_group(const Scene& scene, const PartyEdit& placed, const std::string& partner,
                                           std::vector<std::unique_ptr<ObjectSource>>& sources);

// Every pair of objects checked at every output frame.
std::vector<PairCheck> check_pairs(const PartyEdit& edit, std::vector<std::unique_ptr<ObjectSource>>& sources, double voxel, Voxeliser& voxeliser);

}  // namespace amhv::pipeline
