#include <chrono>
#include <fstream>
#include <iostream>
#include <optional>

#include <unistd.h>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "src/body/skeleton_body.hpp"
#include "src/cli/backend.hpp"
#include "src/cli/bvh_options.hpp"
#include "src/cli/commands.hpp"
#include "src/core/error.hpp"
#include "src/core/normalise.hpp"
#include "src/voxelise/voxelise.hpp"
#include "src/io/amhv_file.hpp"
#include "src/io/bvh.hpp"
#include "src/io/exr_slices.hpp"
#include "src/io/mesh_sequence.hpp"
#include "src/io/files.hpp"
#include "src/io/output_dir.hpp"
#include "src/io/vdb_file.hpp"

namespace amhv::cli {

namespace {

struct MhvArguments {
    std::string meshes, bvh, frames, unit, up, out, backend = "vulkan", axis = "z";
    double voxel = 0.01;
    int resample = 0;
    int device = -1;
    bool exr = true, exr_multipart = false, vdb = false, timings = true;
    BvhArguments bvh_options;
};

class Stopwatch {
public:
    double lap() {
        auto now = std::chrono::steady_clock::now();
        double seconds = std::chrono::duration<double>(now - last_).count();
        last_ = now;
        return seconds;
    }

private:
    std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

// Refuses up front a volume that cannot fit in memory, with the numbers.
void check_memory(const VoxelGrid& grid, int frames) {
    double needed = double(grid.voxel_count()) * ((frames + 31) / 32) * 4.0;
    double available = double(sysconf(_SC_PHYS_PAGES)) * double(sysconf(_SC_PAGE_SIZE));
    if (needed > 0.5 * available)
        throw Error(fmt::format("the aMHV needs {:.1f} GiB ({} x {} x {} voxels x {} frames) but this machine has {:.1f} GiB of "
                                "memory; use a larger --voxel or fewer frames",
                                needed / (1 << 30), grid.dims[0], grid.dims[1], grid.dims[2], frames, available / (1 << 30)));
}

void run_mhv(const MhvArguments& args) {
    Stopwatch clock;
    nlohmann::ordered_json timings;
    if (args.meshes.empty() == args.bvh.empty()) throw Error("mhv: give exactly one of --meshes and --bvh");
    if (args.vdb && !vdb_available()) throw Error("--vdb: this build of amhv has no OpenVDB support (install libopenvdb-dev and rebuild)");
    if (args.axis.size() != 1 || std::string("xyz").find(args.axis) == std::string::npos)
        throw Error(fmt::format("--axis: '{}' is not x, y or z", args.axis));

    // 1. Read the segment.
    MeshSequence sequence;
    std::optional<FrameRange> range;
    if (!args.frames.empty()) range = parse_frame_range(args.frames, "--frames");
    std::string source;
    if (!args.meshes.empty()) {
        UnitsAndAxes units{parse_unit(args.unit.empty() ? "m" : args.unit, "--unit"), parse_up_axis(args.up.empty() ? "z" : args.up, "--up")};
        sequence = read_mesh_sequence(args.meshes, range, units);
        source = args.meshes;
    } else {
        SkeletonBodyOptions options;
        if (!args.unit.empty()) options.units.metres_per_unit = parse_unit(args.unit, "--unit");
        if (!args.up.empty()) options.units.up = parse_up_axis(args.up, "--up");
        BvhMotion motion = load_bvh(args.bvh, bvh_load_options(args.bvh_options));
        sequence = skeleton_body_sequence(motion, bvh_frames(motion, args.frames), options);
        source = args.bvh;
    }
    timings["read"] = clock.lap();

    // 2. Temporal normalisation to --resample frames.
    std::vector<int> source_frames(sequence.frames.size());
    for (std::size_t i = 0; i < source_frames.size(); ++i) source_frames[i] = int(i);
    // A segment resampled to many frames is as many frame meshes and a mask word per 32 of them.
    if (args.resample > 100'000) throw Error(fmt::format("--resample: {} frames is more than the 100000 a segment may have", args.resample));
    if (args.resample > 0) source_frames = resample_indices(int(sequence.frames.size()), args.resample);
    else if (args.resample < 0) throw Error("--resample: the frame count must be positive");
    std::vector<const MeshFrame*> frames;
    for (int f : source_frames) frames.push_back(&sequence.frames[std::size_t(f)]);

    VoxelGrid grid = grid_covering(sequence.bounds(), args.voxel, source);
    check_memory(grid, int(frames.size()));
    VoxelisationInput input = prepare_voxelisation(frames, grid);
    timings["prepare"] = clock.lap();

    // 3. Voxelise.
    Backend backend(args.backend, args.device);
    const std::string& device = backend.device();
    Voxeliser& voxeliser = backend.voxeliser();
    timings["device"] = clock.lap();
    VoxeliseReport report;
    Amhv volume = voxelise(input, voxeliser, &report);
    timings["voxelise"] = clock.lap();
    AmhvSummary summary = summarise(volume);
    if (summary.gap_voxels) spdlog::info("{} voxels are occupied in more than one interval of frames", summary.gap_voxels);

    // 4. Write everything into a staging folder; it replaces --out only when complete.
    std::vector<std::filesystem::path> inputs{args.meshes, args.bvh};
    if (args.meshes.find('%') != std::string::npos) inputs.push_back(std::filesystem::path(args.meshes).parent_path());
    StagedOutput out(args.out, inputs);
    write_amhv(volume, out.dir() / "mhv.amhv");
    int slices = 0;
    if (args.exr) slices = write_exr_slices(volume, out.dir() / "slices", {.axis = args.axis[0], .multipart = args.exr_multipart});
    if (args.vdb) write_vdb(volume, out.dir() / "mhv.vdb");
    timings["write"] = clock.lap();

    nlohmann::ordered_json json;
    json["program"] = std::string("amhv ") + AMHV_VERSION;
    json["source"] = source;
    json["frames"] = volume.frames();
    json["source_frames"] = nlohmann::json::array();
    for (const MeshFrame* f : frames) json["source_frames"].push_back(f->source);
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
    json["open_frames"] = report.open_frames;
    json["backend"] = args.backend;
    json["device"] = device;
    json["files"] = {{"volume", "mhv.amhv"},
                     {"exr_slices", args.exr ? nlohmann::json(args.exr_multipart ? fmt::format("slices/slices_{}.exr", args.axis)
                                                                                   : fmt::format("slices/{}_NNNN.exr", args.axis))
                                             : nlohmann::json(nullptr)},
                     {"exr_slice_count", slices},
                     {"vdb", args.vdb ? nlohmann::json("mhv.vdb") : nlohmann::json(nullptr)}};
    if (args.timings) json["timings_s"] = timings;
    write_file(out.dir() / "mhv.json", json.dump(2) + '\n');
    out.commit();
    std::cout << fmt::format("amhv mhv: {} frames, {} x {} x {} voxels of {} m, {} occupied ({} with gaps), root ({:.3f}, {:.3f}, {:.3f}) m\n",
                             volume.frames(), grid.dims[0], grid.dims[1], grid.dims[2], grid.voxel, summary.occupied_voxels,
                             summary.gap_voxels, summary.root.x(), summary.root.y(), summary.root.z());
    std::cout << fmt::format("  voxelised on {} in {:.2f} s; wrote {}/ (mhv.json, mhv.amhv{}{})\n", device, timings["voxelise"].get<double>(),
                             out.target().string(), args.exr ? fmt::format(", {} EXR slices in slices/", slices) : "",
                             args.vdb ? ", mhv.vdb" : "");
}

}  // namespace

void add_mhv_command(CLI::App& app) {
    auto args = std::make_shared<MhvArguments>();
    auto* command = app.add_subcommand("mhv", "Build the aMHV of one segment of one mesh sequence and write it out");
    auto* input = command->add_option_group("input", "exactly one input");
    input->add_option("--meshes", args->meshes, "Folder of mesh frames (sorted naturally) or printf pattern, e.g. 'walk/frame_%04d.obj'");
    input->add_option("--bvh", args->bvh, "BVH motion capture file: the body is built from capsules around the bones");
    input->require_option(1);
    command->add_option("--frames", args->frames, "Segment FIRST:LAST, inclusive (pattern: file numbers; folder/BVH: 0-based positions)");
    command->add_option("--voxel", args->voxel, "Voxel edge in metres")->capture_default_str();
    command->add_option("--unit", args->unit, "Input unit: m, cm, mm, in, ft or metres per unit (default m; BVH: 0.0564444, CMU)");
    command->add_option("--up", args->up, "Input up axis: x, y or z (default z; BVH: y)");
    add_bvh_options(*command, args->bvh_options);
    command->add_option("--resample", args->resample, "Resample the segment to N frames (docs/method.md section 2)");
    command->add_option("--out", args->out, "Output folder (replaced as a whole when the run succeeds)")->required();
    add_backend_options(*command, args->backend, args->device);
    command->add_option("--axis", args->axis, "EXR slicing axis: x, y or z")->capture_default_str();
    command->add_flag("--exr-multipart", args->exr_multipart, "All slices as parts of one multi-part EXR file");
    command->add_flag("!--no-exr", args->exr, "Skip the EXR slices");
    command->add_flag("--vdb", args->vdb, "Also write mhv.vdb (OpenVDB: density, t_start, t_end)");
    command->add_flag("!--no-timings", args->timings, "Leave timings out of mhv.json (byte-identical reruns)");
    command->callback([args] { run_mhv(*args); });
}

}  // namespace amhv::cli
