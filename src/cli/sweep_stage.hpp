#pragma once
// The constraint satisfaction stage shared by `amhv sweep` and `amhv edit`: every key segment's
// volumes, sweep and files (segment_N/solutions.csv, optional feasibility maps, its result.json
// entry), and the reading back of such a folder for `amhv edit --from-sweep`.
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "edit/edit.hpp"
#include "scene/scene.hpp"
#include "scene/segment.hpp"

namespace amhv::cli {

struct SweepStage {
    std::vector<KeySweep> sweeps;
    nlohmann::ordered_json segments = nlohmann::ordered_json::array();  // result.json's "segments"
    double mhv_seconds = 0, sweep_seconds = 0, output_seconds = 0;
};

struct SweepStageOptions {
    int only_segment = 0;  // 0: every key segment
    bool maps = true, timings = true;
};

// The start of result.json for `amhv sweep` and `amhv edit`: program, scene, backend, device and
// the resolved sampling and weights.
nlohmann::ordered_json result_header(const Scene& scene, const std::string& backend, const std::string& device);

// Builds, sweeps and writes every key segment into `out` (segment_N/...), printing one line each.
SweepStage run_sweep_stage(const Scene& scene, ObjectSource& a, ObjectSource& b, Voxeliser& voxeliser, Sweeper& sweeper,
                           const std::filesystem::path& out, const SweepStageOptions& options);

// Reads `dir`/result.json and `dir`/segment_N/solutions.csv written by a sweep (or an edit) of the
// same scene; throws amhv::Error naming the file when the folder does not match `scene`.
SweepStage read_sweep_stage(const std::filesystem::path& dir, const Scene& scene);

}  // namespace amhv::cli
