// `amhv import-bvh`: a BVH take as files other tools (and scenes) read: the body mesh per frame,
// its per-vertex part labels, the view track, and a scene snippet that uses them.
#include <iostream>


#include "src/body/skeleton_body.hpp"
#include "src/cli/bvh_options.hpp"
#include "src/cli/commands.hpp"
#include "src/core/error.hpp"
#include "src/io/bvh.hpp"
#include "src/io/output_dir.hpp"
#include "src/pipeline/import_stage.hpp"

namespace amhv::cli {

namespace {

namespace fs = std::filesystem;

struct ImportArguments {
    std::string bvh, out, frames, unit, up;
    BvhArguments bvh_options;
};

void run_import(const ImportArguments& args) {
    SkeletonBodyOptions options;
    if (!args.unit.empty()) options.units.metres_per_unit = parse_unit(args.unit, "--unit");
    if (!args.up.empty()) options.units.up = parse_up_axis(args.up, "--up");
    const BvhMotion motion = load_bvh(args.bvh, bvh_load_options(args.bvh_options));
    apply_body_option(args.bvh_options, motion, options);
    const FrameRange range = bvh_frames(motion, args.frames);
    StagedOutput out(args.out, {args.bvh});
    pipeline::import_bvh_into(motion, args.bvh, range, options, out.dir());
    out.commit();
    std::cout << fmt::format("wrote {}/: meshes/ ({} PLY frames, {}..{}), labels/, track.csv, object.toml, import.json\n",
                             out.target().string(), range.count(), range.first, range.last);
}

}  // namespace

void add_import_bvh_command(CLI::App& app) {
    auto args = std::make_shared<ImportArguments>();
    auto* command = app.add_subcommand("import-bvh", "Turn a BVH take into a body mesh per frame (PLY), part labels and a view track (CSV)");
    command->add_option("bvh", args->bvh, "BVH motion capture file")->required();
    command->add_option("--out", args->out, "Output folder (replaced as a whole when the run succeeds)")->required();
    command->add_option("--frames", args->frames, "FIRST:LAST, inclusive (default: the whole take after a T-pose)");
    command->add_option("--unit", args->unit, "File unit: m, cm, mm, in, ft or metres per unit (default 0.0564444, CMU)");
    command->add_option("--up", args->up, "File up axis: x, y or z (default y)");
    add_bvh_options(*command, args->bvh_options);
    command->callback([args] { run_import(*args); });
}

}  // namespace amhv::cli
