#include "src/pipeline/mhv_stage.hpp"

#include <chrono>

#include <unistd.h>

#include <spdlog/spdlog.h>

#include "src/core/budget.hpp"
#include "src/core/clock.hpp"
#include "src/core/error.hpp"
#include "src/core/normalise.hpp"
#include "src/io/amhv_file.hpp"
#include "src/io/exr_slices.hpp"
#include "src/io/files.hpp"
#include "src/io/vdb_file.hpp"
#include "src/results/mhv_glb.hpp"

namespace amhv::pipeline {

namespace {

// Refuses up front a volume that cannot fit in memory, with the numbers.
void check_memory(const VoxelGrid& grid, int frames) {
    double needed = double(grid.voxel_count()) * ((frames + 31) / 32) * 4.0;
    double available = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGE_SIZE));
    if (needed > 0.5 * available)
        throw Error(fmt::format("the aMHV needs {:.1f} GiB ({} x {} x {} voxels x {} frames) but this machine has {:.1f} GiB of "
                                "memory; use a larger --voxel or fewer frames",
                                needed / (1 << 30), grid.dims[0], grid.dims[1], grid.dims[2], frames, available / (1 << 30)));
}

nlohmann::ordered_json mhv_json(const MhvPlan& plan, const Amhv& volume, const MhvReport& report, const VoxeliseReport& voxelised,
                                const std::string& backend, const std::string& device, const MhvFiles& files) {
    const VoxelGrid& grid = plan.grid;
    const AmhvSummary& summary = report.summary;
    nlohmann::ordered_json json;
    json["program"] = std::string("amhv ") + AMHV_VERSION;
    json["source"] = plan.source;
    json["frames"] = volume.frames();
    json["source_frames"] = nlohmann::json::array();
    for (const MeshFrame* f : plan.frames) json["source_frames"].push_back(f->source);
    json["voxel_size_m"] = grid.voxel;
    json["grid"] = {{"origin_m", {grid.origin.x(), grid.origin.y(), grid.origin.z()}},
                    {"dims", {grid.dims[0], grid.dims[1], grid.dims[2]}},
                    {"layout", "voxel index = x + nx * (y + ny * z); capture frame, metres, z up"}};
    json["occupied_voxels"] = summary.occupied_voxels;
    json["gap_voxels"] = summary.gap_voxels;
    json["root_m"] = {summary.root.x(), summary.root.y(), summary.root.z()};
    json["bounding_box_m"] = {{"min", {summary.bounds.min.x(), summary.bounds.min.y(), summary.bounds.min.z()}},
                              {"max", {summary.bounds.max.x(), summary.bounds.max.y(), summary.bounds.max.z()}}};
    json["occupied_per_frame"] = summary.occupied_per_frame;
    json["open_frames"] = voxelised.open_frames;
    json["backend"] = backend;
    json["device"] = device;
    json["files"] = {{"volume", "mhv.amhv"},
                     {"exr_slices", files.exr ? nlohmann::json(files.exr_multipart ? fmt::format("slices/slices_{}.exr", files.axis)
                                                                                     : fmt::format("slices/{}_NNNN.exr", files.axis))
                                              : nlohmann::json(nullptr)},
                     {"exr_slice_count", report.slices},
                     {"vdb", files.vdb ? nlohmann::json("mhv.vdb") : nlohmann::json(nullptr)}};
    if (files.glb) json["files"]["glb"] = "mhv.glb";
    return json;
}

}  // namespace

MhvPlan plan_mhv(const MeshSequence& sequence, const std::string& source, double voxel, int resample) {
    MhvPlan plan;
    plan.source = source;
    std::vector<int> source_frames(sequence.frames.size());
    for (std::size_t i = 0; i < source_frames.size(); ++i) source_frames[i] = int(i);
    // A segment resampled to many frames is as many frame meshes and a mask word per 32 of them.
    if (resample > 100'000) throw Error(fmt::format("--resample: {} frames is more than the 100000 a segment may have", resample));
    if (resample > 0) source_frames = resample_indices(int(sequence.frames.size()), resample);
    else if (resample < 0) throw Error("--resample: the frame count must be positive");
    for (int f : source_frames) plan.frames.push_back(&sequence.frames[std::size_t(f)]);
    plan.grid = grid_covering(sequence.bounds(), voxel, source);
    check_memory(plan.grid, int(plan.frames.size()));
    plan.input = prepare_voxelisation(plan.frames, plan.grid);
    return plan;
}

MhvReport write_mhv(const MhvPlan& plan, Voxeliser& voxeliser, const std::string& backend, const std::string& device, const MhvFiles& files,
                    const std::filesystem::path& out, nlohmann::ordered_json timings) {
    MhvReport report;
    auto t0 = std::chrono::steady_clock::now();
    VoxeliseReport voxelised;
    Amhv volume = voxelise(plan.input, voxeliser, &voxelised);
    report.voxelise_seconds = seconds_since(t0);
    timings["voxelise"] = report.voxelise_seconds;
    report.summary = summarise(volume);
    report.frames = volume.frames();
    if (report.summary.gap_voxels) spdlog::info("{} voxels are occupied in more than one interval of frames", report.summary.gap_voxels);

    t0 = std::chrono::steady_clock::now();
    // The volume file's size is known exactly: a voxel index and its words per occupied voxel.
    budget::require_disk(out, 64 + report.summary.occupied_voxels * (4 + 4 * std::uint64_t(volume.words())), "mhv.amhv",
                         "free some disk or use a larger --voxel");
    write_amhv(volume, out / "mhv.amhv");
    if (files.exr) report.slices = write_exr_slices(volume, out / "slices", {.axis = files.axis, .multipart = files.exr_multipart});
    if (files.vdb) write_vdb(volume, out / "mhv.vdb");
    if (files.glb) write_mhv_glb(volume, out / "mhv.glb");
    timings["write"] = seconds_since(t0);
    nlohmann::ordered_json json = mhv_json(plan, volume, report, voxelised, backend, device, files);
    if (files.timings) json["timings_s"] = timings;
    write_file(out / "mhv.json", json.dump(2) + '\n');
    return report;
}

}  // namespace amhv::pipeline
