#pragma once
// The pipeline's stages as the commands call them (docs/method.md section 0):
//   the sweep stage: every key segment's volumes, sweep and files (segment_N/...), or the reading
//                    back of such a folder for `amhv edit --from-sweep`;
//   sweep_scene:     `amhv sweep` into an output folder (the stage and result.json);
//   edit_scene_into: `amhv edit` into an output folder (the sweep stage, the edit, every file).
// The CLI parses arguments, opens the output folder and calls these.
#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "src/edit/edit.hpp"
#include "src/results/result_json.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"

namespace amhv::pipeline {

struct SweepStage {
    std::vector<KeySweep> sweeps;
    results::Json segments = results::Json::array();  // result.json's "segments"
    double mhv_seconds = 0, sweep_seconds = 0, output_seconds = 0;
};

struct SweepStageOptions {
    int only_segment = 0;  // 0: every key segment
    bool maps = true, timings = true;
    bool csv = false;  // also segment_N/solutions.csv
};

// A swept key segment as the edit takes it: its roots, describer, group and counts.
KeySweep key_sweep(const KeySegment& segment, const SweepProblem& problem, const SweepResult& result, SolutionGroup group);

// Builds, sweeps and writes every key segment into `out` (segment_N/...), printing one line each.
SweepStage run_sweep_stage(const Scene& scene, ObjectSource& a, ObjectSource& b, Voxeliser& voxeliser, Sweeper& sweeper,
                           const std::filesystem::path& out, const SweepStageOptions& options);

// The files of one swept key segment (segment_N/...) and its result.json entry, appended to `stage`
// with one printed line: the same for `amhv sweep`, `amhv edit` and `amhv merge`. `timings` holds
// the segment's "mhv" and "sweep" seconds.
void finish_segment(const Scene& scene, const KeySegment& segment, const SweepProblem& problem, const SweepResult& result,
                    const std::filesystem::path& out, const SweepStageOptions& options, results::Json timings, SweepStage& stage);

// Reads `dir` written by a sweep (or an edit) of the same scene; throws amhv::Error naming the file
// when the folder does not match `scene`.
SweepStage read_sweep_stage(const std::filesystem::path& dir, const Scene& scene);

// The backends a run uses and how result.json names them.
struct Backends {
    Voxeliser& voxeliser;
    Sweeper& sweeper;
    std::string backend, device;
    Skinner* skinner = nullptr;  // characters' frames (null: the CPU reference)
};

// `amhv sweep`: the sweep stage and result.json into `out`. Returns the stage.
SweepStage sweep_scene(const Scene& scene, Backends& backends, const std::filesystem::path& out, const SweepStageOptions& options,
                       std::chrono::steady_clock::time_point start);

struct EditRunOptions {
    std::string from_sweep;  // empty: sweep now
    bool allow_empty = false, frames = true, maps = false, timings = true, csv = false;
    bool glb = true;  // scene.glb
    bool page = true;  // index.html and view/ (needs scene.glb)
    bool allow_transition_overlap = false;
};

// `amhv edit`: the sweep stage (or --from-sweep), the edit, transforms.json, frames, paths, views
// and result.json into `out`. Returns the edit.
EditResult edit_scene_into(const Scene& scene, Backends& backends, const std::filesystem::path& out, const EditRunOptions& options,
                           std::chrono::steady_clock::time_point start);

}  // namespace amhv::pipeline
