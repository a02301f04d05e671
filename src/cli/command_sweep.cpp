// `amhv check` and `amhv sweep`: scene validation and the constraint satisfaction stage.
#include <chrono>
#include <iostream>

#include <memory>
#include <fmt/ranges.h>

#include "src/cli/backend.hpp"
#include "src/cli/commands.hpp"
#include "src/scene/interest.hpp"
#include "src/pipeline/shard_stage.hpp"
#include "src/pipeline/solutions_export.hpp"
#include "src/pipeline/sweep_stage.hpp"
#include "src/core/error.hpp"
#include "src/io/output_dir.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"

namespace amhv::cli {

namespace {

struct SweepArguments {
    std::string scene, out, backend = "vulkan";
    int segment = 0;  // 0: all
    int device = -1;
    bool require_solutions = false, maps = true, timings = true, csv = false;
    std::optional<std::string> shard;  // --shard [K/N]
};

// A character's rig as amhv read it: each joint's role and part, and how its surface was closed.
void print_character_mapping(const std::string& name, const CharacterBody& body) {
    const CharacterMapping& m = character_mapping(body);
    const CharacterFile& file = character_file(body);
    std::cout << fmt::format("# object {}: character {}, animation {} ({} frames at {} fps); {} hole{} capped, {} cut{} between parts\n", name,
                             file.source, printable(file.animation), file.frame_count(), file.fps, m.capped_holes, m.capped_holes == 1 ? "" : "s",
                             m.part_caps, m.part_caps == 1 ? "" : "s");
    for (std::size_t j = 0; j < m.joint_roles.size(); ++j)
        std::cout << fmt::format("#   joint {} -> role {} -> part {}\n", printable(m.joint_roles[j].first), m.joint_roles[j].second, m.joint_parts[j].second);
}

void run_check(const std::string& file) {
    Scene scene = load_scene(file);
    // The objects' takes and tracks too: a scene whose files are broken is not valid.
    std::vector<std::unique_ptr<ObjectSource>> sources;
    for (const SceneObject& o : scene.objects) sources.push_back(std::make_unique<ObjectSource>(o));
    std::vector<ObjectSource*> pointers;
    for (auto& s : sources) pointers.push_back(s.get());
    check_part_names(scene, pointers);
    std::cout << resolved_toml(scene);
    for (std::size_t o = 0; o < sources.size(); ++o)
        if (!sources[o]->label_names().empty())
            std::cout << fmt::format("# object {} has the parts {}\n", scene.objects[o].name, fmt::join(sources[o]->label_names(), ", "));
    for (const auto& o : sources)
        if (!o->floor_note().empty()) std::cout << "# " << o->floor_note() << '\n';
    for (const auto& o : sources)
        if (const CharacterBody* c = o->character()) print_character_mapping(o->spec().name, *c);
    if (scene.multi_party())
        std::cout << fmt::format("# placement order: {} ({})\n", fmt::join(scene.order, ", "), scene.order_rule);
}

// `amhv sweep --shard K/N`: one shard's folder; the options that shape the files are merge's.
void run_shard(const SweepArguments& args, std::chrono::steady_clock::time_point start) {
    if (args.segment || args.csv || !args.maps || args.require_solutions)
        throw Error("--shard: --segment, --csv, --no-maps and --require-solutions are options of `amhv merge`, which writes the files");
    const pipeline::ShardIndex shard = pipeline::parse_shard(*args.shard);
    Scene scene = load_two_object_scene(args.scene, "sweep --shard");
    pipeline::plan_shards(scene, shard.count);  // refuses an impossible N before the backend starts
    Backend backend(args.backend, args.device);
    pipeline::Backends backends = backend.backends();
    StagedOutput out(args.out, scene_inputs(scene));
    const results::ShardManifest manifest = pipeline::sweep_shard(scene, backends, out.dir(), shard, args.timings, start);
    out.commit();
    std::cout << fmt::format("wrote {}/ (shard.json and {} outcome files: shard {} of {})\n", out.target().string(), manifest.pieces.size(), shard.index,
                             shard.count);
}

void run_sweep(const SweepArguments& args) {
    const auto start = std::chrono::steady_clock::now();
    if (args.shard) return run_shard(args, start);
    Scene scene = load_two_object_scene(args.scene, "sweep");
    if (args.segment < 0 || args.segment > int(scene.segments.size()))
        throw Error(fmt::format("--segment: {} is not a key segment of {} (1..{})", args.segment, args.scene, scene.segments.size()));

    Backend backend(args.backend, args.device);
    pipeline::Backends backends = backend.backends();
    StagedOutput out(args.out, scene_inputs(scene));
    const pipeline::SweepStage stage = pipeline::sweep_scene(scene, backends, out.dir(), {args.segment, args.maps, args.timings, args.csv}, start);
    std::vector<int> empty_segments;
    for (const KeySweep& k : stage.sweeps)
        if (k.group.empty()) empty_segments.push_back(k.index);
    out.commit();
    std::cout << fmt::format("wrote {}/ (result.json, segment_N/group.vdb{}{})\n", out.target().string(), args.csv ? ", segment_N/solutions.csv" : "",
                             args.maps ? ", segment_N/feasibility/" : "");
    if (args.require_solutions && !empty_segments.empty())
        throw Error(fmt::format("--require-solutions: key segment {} has no solution", empty_segments.front()));
}

void run_solutions(const std::string& dir, int segment, const std::string& csv) {
    const pipeline::GroupRead group = pipeline::read_group(dir, segment);
    if (csv.empty()) {
        std::cout << pipeline::group_report(group);
        return;
    }
    pipeline::export_group_csv(group, csv);
    std::cout << fmt::format("wrote {} ({} solutions)\n", csv, group.group.size());
}

}  // namespace

void add_scene_commands(CLI::App& app) {
    auto solutions_args = std::make_shared<std::tuple<std::string, int, std::string>>("", 1, "");
    auto* solutions = app.add_subcommand("solutions", "One key segment's solution group from an output folder (segment_N/group.vdb): a summary, or --csv");
    solutions->add_option("dir", std::get<0>(*solutions_args), "Output folder of `amhv sweep` or `amhv edit`")->required();
    solutions->add_option("--segment", std::get<1>(*solutions_args), "Key segment N (1-based; 1)");
    solutions->add_option("--csv", std::get<2>(*solutions_args), "Write the group as solutions.csv to this file (which must not exist)");
    solutions->callback([solutions_args] { run_solutions(std::get<0>(*solutions_args), std::get<1>(*solutions_args), std::get<2>(*solutions_args)); });

    auto check_file = std::make_shared<std::string>();
    auto* check = app.add_subcommand("check", "Validate a scene file and print it with every default filled in");
    check->add_option("scene", *check_file, "Scene file (TOML)")->required();
    check->callback([check_file] { run_check(*check_file); });

    auto args = std::make_shared<SweepArguments>();
    auto* sweep = app.add_subcommand("sweep", "Find every placement of B around A that satisfies each key segment's constraints");
    sweep->add_option("scene", args->scene, "Scene file (TOML)")->required();
    sweep->add_option("--out", args->out, "Output folder (replaced as a whole when the run succeeds)")->required();
    add_backend_options(*sweep, args->backend, args->device);
    sweep->add_option("--segment", args->segment, "Only key segment N (1-based)");
    sweep->add_flag("--require-solutions", args->require_solutions, "Exit non-zero when a key segment has no solution");
    sweep->add_flag("!--no-maps", args->maps, "Skip the feasibility maps");
    sweep->add_flag("--csv", args->csv, "Also write each solution group as segment_N/solutions.csv (text: gigabytes at fine sampling)");
    sweep->add_flag("!--no-timings", args->timings, "Leave timings out of result.json (byte-identical reruns)");
    sweep->add_option("--shard", args->shard,
                      "Sweep only shard K of N of the scene's work (K/N; without a value, K and N from the Slurm array task) into a shard folder for `amhv merge`")
        ->expected(0, 1);
    sweep->callback([args] { run_sweep(*args); });
}

}  // namespace amhv::cli
