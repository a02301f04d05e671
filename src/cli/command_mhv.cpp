#include <chrono>
#include <fstream>
#include <iostream>
#include <optional>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "src/body/character_body.hpp"
#include "src/body/skeleton_body.hpp"
#include "src/cli/backend.hpp"
#include "src/cli/bvh_options.hpp"
#include "src/cli/commands.hpp"
#include "src/core/error.hpp"
#include "src/io/bvh.hpp"
#include "src/io/mesh_sequence.hpp"
#include "src/io/output_dir.hpp"
#include "src/io/vdb_file.hpp"
#include "src/pipeline/mhv_stage.hpp"

namespace amhv::cli {

namespace {

struct MhvArguments {
    std::string meshes, bvh, character, animation, frames, unit, up, out, backend = "vulkan", axis = "z";
    double voxel = 0.01;
    int resample = 0;
    int device = -1;
    bool exr = true, exr_multipart = false, vdb = false, timings = true, glb = false;
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

// A character's frames FIRST:LAST (all by default), skinned by `skinner` 64 frames a call, welded,
// closed and cut into parts as a scene's character object is, each frame's parts as one mesh.
MeshSequence character_segment(const MhvArguments& args, Skinner& skinner) {
    UnitsAndAxes units{parse_unit(args.unit.empty() ? "m" : args.unit, "--unit"), parse_up_axis(args.up.empty() ? "y" : args.up, "--up")};
    std::optional<std::string> animation;
    if (!args.animation.empty()) animation = args.animation;
    const auto file = std::make_shared<const CharacterFile>(
        read_character(args.character, animation, args.bvh_options.fps > 0 ? std::optional<double>(args.bvh_options.fps) : std::nullopt));
    const auto body = build_character_body(file);
    FrameRange range{0, file->frame_count() - 1};
    if (!args.frames.empty()) range = parse_frame_range(args.frames, "--frames");
    if (range.first < 0 || range.last >= file->frame_count() || range.first > range.last)
        fail("--frames", "{}:{} is not within the animation's frames 0:{}", range.first, range.last, file->frame_count() - 1);
    MeshSequence sequence;
    sequence.source = args.character;
    constexpr int kBatch = 64;
    for (int first = range.first; first <= range.last; first += kBatch) {
        const std::vector<std::vector<Vec3>> batch =
            skin_frames(skinner, character_skin(*body), *file, first, std::min(range.last, first + kBatch - 1), units);
        for (std::size_t k = 0; k < batch.size(); ++k) {
            MeshFrame& frame = sequence.frames.emplace_back();
            frame.source = fmt::format("{} frame {}", args.character, first + int(k));
            for (const BodyPart& part : character_body_parts(*body, batch[k], first + int(k))) frame.mesh.append(part.mesh);
        }
    }
    return sequence;
}

// Reads the segment the arguments name: a mesh sequence, a BVH take turned into a body, or a
// character skinned on the backend.
MeshSequence read_segment(const MhvArguments& args, std::string& source, Backend& backend) {
    if (!args.character.empty()) {
        source = args.character;
        return character_segment(args, backend.skinner());
    }
    std::optional<FrameRange> range;
    if (!args.frames.empty()) range = parse_frame_range(args.frames, "--frames");
    if (!args.meshes.empty()) {
        UnitsAndAxes units{parse_unit(args.unit.empty() ? "m" : args.unit, "--unit"), parse_up_axis(args.up.empty() ? "z" : args.up, "--up")};
        source = args.meshes;
        return read_mesh_sequence(args.meshes, range, units);
    }
    SkeletonBodyOptions options;
    if (!args.unit.empty()) options.units.metres_per_unit = parse_unit(args.unit, "--unit");
    if (!args.up.empty()) options.units.up = parse_up_axis(args.up, "--up");
    BvhMotion motion = load_bvh(args.bvh, bvh_load_options(args.bvh_options));
    apply_body_option(args.bvh_options, motion, options);
    source = args.bvh;
    return skeleton_body_sequence(motion, bvh_frames(motion, args.frames), options);
}

void run_mhv(const MhvArguments& args) {
    Stopwatch clock;
    nlohmann::ordered_json timings;
    if (int(!args.meshes.empty()) + int(!args.bvh.empty()) + int(!args.character.empty()) != 1)
        throw Error("mhv: give exactly one of --meshes, --bvh and --character");
    if (args.axis.size() != 1 || std::string("xyz").find(args.axis) == std::string::npos)
        throw Error(fmt::format("--axis: '{}' is not x, y or z", args.axis));

    // The output folder is checked (and locked) before any work: a target amhv may not write is
    // refused at once, not after the volume is built.
    std::vector<std::filesystem::path> inputs{args.meshes, args.bvh, args.character};
    if (args.meshes.find('%') != std::string::npos) inputs.push_back(std::filesystem::path(args.meshes).parent_path());
    StagedOutput out(args.out, inputs);

    Backend backend(args.backend, args.device);
    timings["device"] = clock.lap();
    std::string source;
    const MeshSequence sequence = read_segment(args, source, backend);
    timings["read"] = clock.lap();  // a character's skinning included
    const pipeline::MhvPlan plan = pipeline::plan_mhv(sequence, source, args.voxel, args.resample);
    timings["prepare"] = clock.lap();

    const pipeline::MhvFiles files{args.exr, args.exr_multipart, args.vdb, args.timings, args.axis[0], args.glb};
    const pipeline::MhvReport report = pipeline::write_mhv(plan, backend.voxeliser(), args.backend, backend.device(), files, out.dir(), timings);
    out.commit();
    const VoxelGrid& grid = plan.grid;
    const AmhvSummary& summary = report.summary;
    std::cout << fmt::format("amhv mhv: {} frames, {} x {} x {} voxels of {} m, {} occupied ({} with gaps), root ({:.3f}, {:.3f}, {:.3f}) m\n",
                             report.frames, grid.dims[0], grid.dims[1], grid.dims[2], grid.voxel, summary.occupied_voxels,
                             summary.gap_voxels, summary.root.x(), summary.root.y(), summary.root.z());
    std::cout << fmt::format("  voxelised on {} in {:.2f} s; wrote {}/ (mhv.json, mhv.amhv{}{})\n", backend.device(), report.voxelise_seconds,
                             out.target().string(), args.exr ? fmt::format(", {} EXR slices in slices/", report.slices) : "",
                             fmt::format("{}{}", args.vdb ? ", mhv.vdb" : "", args.glb ? ", mhv.glb" : ""));
}

}  // namespace

void add_mhv_command(CLI::App& app) {
    auto args = std::make_shared<MhvArguments>();
    auto* command = app.add_subcommand("mhv", "Build the aMHV of one segment of one mesh sequence and write it out");
    auto* input = command->add_option_group("input", "exactly one input");
    input->add_option("--meshes", args->meshes, "Folder of mesh frames (sorted naturally) or printf pattern, e.g. 'walk/frame_%04d.obj'");
    input->add_option("--bvh", args->bvh, "BVH motion capture file: the body is built from capsules around the bones");
    input->add_option("--character", args->character, "Animated, skinned character (glTF, FBX, Collada): skinned on the backend, closed and cut into parts");
    input->require_option(1);
    command->add_option("--animation", args->animation, "Character: the animation to play (when the file holds several)");
    command->add_option("--frames", args->frames, "Segment FIRST:LAST, inclusive (pattern: file numbers; folder/BVH: 0-based positions)");
    command->add_option("--voxel", args->voxel, "Voxel edge in metres")->capture_default_str();
    command->add_option("--unit", args->unit, "Input unit: m, cm, mm, in, ft or metres per unit (default m; BVH: 0.0564444, CMU)");
    command->add_option("--up", args->up, "Input up axis: x, y or z (default z; BVH, character: y)");
    add_bvh_options(*command, args->bvh_options);
    command->add_option("--resample", args->resample, "Resample the segment to N frames (docs/method.md section 2)");
    command->add_option("--out", args->out, "Output folder (replaced as a whole when the run succeeds)")->required();
    add_backend_options(*command, args->backend, args->device);
    command->add_option("--axis", args->axis, "EXR slicing axis: x, y or z")->capture_default_str();
    command->add_flag("--exr-multipart", args->exr_multipart, "All slices as parts of one multi-part EXR file");
    command->add_flag("!--no-exr", args->exr, "Skip the EXR slices");
    command->add_flag("--vdb", args->vdb, "Also write mhv.vdb (OpenVDB: density, t_start, t_end)");
    command->add_flag("--glb", args->glb, "Also write mhv.glb: the occupied voxels' surface coloured by t_end (glTF, for any 3D viewer)");
    command->add_flag("!--no-timings", args->timings, "Leave timings out of mhv.json (byte-identical reruns)");
    command->callback([args] { run_mhv(*args); });
}

}  // namespace amhv::cli
