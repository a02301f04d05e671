#pragma once
// The volume stage of `amhv mhv` (docs/method.md sections 2-3): one segment of one mesh sequence
// normalised to a frame count, voxelised into an aMHV, and written out (mhv.amhv, EXR slices,
// OpenVDB, mhv.json). The CLI reads the sequence, opens the output folder and calls these.
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "src/core/amhv.hpp"
#include "src/io/mesh_sequence.hpp"
#include "src/voxelise/voxelise.hpp"

namespace amhv::pipeline {

// What the stage will voxelise: the frames (after --resample) on their grid, quantised.
struct MhvPlan {
    std::string source;
    std::vector<const MeshFrame*> frames;
    VoxelGrid grid;
    VoxelisationInput input;
};

// Resamples `sequence` to `resample` frames (0: as it is) and lays its grid of edge `voxel`,
// refusing up front a volume that does not fit in memory.
MhvPlan plan_mhv(const MeshSequence& sequence, const std::string& source, double voxel, int resample);

struct MhvFiles {
    bool exr = true, exr_multipart = false, vdb = false, timings = true;
    char axis = 'z';
    bool glb = false;  // mhv.glb: the occupied voxels' surface coloured by t_end
};

struct MhvReport {
    AmhvSummary summary;
    int frames = 0, slices = 0;
    double voxelise_seconds = 0;
};

// Voxelises the plan with `voxeliser` and writes every file into `out`; `timings` (read, prepare,
// device so far) gains voxelise and write.
MhvReport write_mhv(const MhvPlan& plan, Voxeliser& voxeliser, const std::string& backend, const std::string& device, const MhvFiles& files,
                    const std::filesystem::path& out, nlohmann::ordered_json timings);

}  // namespace amhv::pipeline
