// `amhv propose`: key segments found in a scene's two takes, ranked (docs/method.md section 13).
#include <chrono>
#include <filesystem>
#include <iostream>

#include <fmt/format.h>

#include "src/cli/backend.hpp"
#include "src/cli/commands.hpp"
#include "src/core/error.hpp"
#include "src/io/files.hpp"
#include "src/io/output_dir.hpp"
#include "src/pipeline/propose_stage.hpp"

namespace amhv::cli {

namespace {

struct ProposeArguments {
    std::string scene, out, backend = "vulkan";
    int device = -1;
    bool best = true;  // edit the best proposal into best/
};

// The best proposal edited into `dir` (the page plays it); the reason when its edit fails.
std::string edit_best(const Scene& scene, const pipeline::Proposal& best, pipeline::Backends& backends, const std::filesystem::path& dir) {
    const Scene edited = pipeline::with_proposal(scene, best);
    pipeline::EditRunOptions options;
    options.frames = false;
    options.timings = false;
    std::filesystem::create_directories(dir);
    try {
        pipeline::edit_scene_into(edited, backends, dir, options, std::chrono::steady_clock::now());
    } catch (const Error& e) {
        std::filesystem::remove_all(dir);  // written by this run, in its staging folder
        return fmt::format("The best proposal does not edit: {}", e.what());
    }
    return "";
}

void run_propose(const ProposeArguments& args) {
    const Scene scene = load_two_object_scene(args.scene, "propose", true);
    Backend backend(args.backend, args.device);
    pipeline::Backends backends = backend.backends();
    StagedOutput out(args.out, scene_inputs(scene));
    const pipeline::ProposeResult result = pipeline::propose_scene(scene, backends);
    pipeline::require_proposals(scene, result);
    write_file(out.dir() / "proposals.toml", pipeline::proposals_toml(scene, result));
    results::write_json_file(out.dir() / "proposals.json", pipeline::proposals_json(scene, result));
    const std::string note = args.best ? edit_best(scene, result.proposals.front(), backends, out.dir() / "best") : "Not edited (--no-best).";
    write_file(out.dir() / "index.html", pipeline::proposals_page(scene, result, note));
    out.commit();
    for (std::size_t n = 0; n < result.proposals.size(); ++n) {
        const pipeline::Proposal& p = result.proposals[n];
        const pipeline::ProposalSweep& d = p.decided();
        std::cout << fmt::format("{}. {} {} / {}: A {}-{}, B {}-{} (shift {:+d}), {} members at {} m / {} deg, natural score {:.2f}\n", n + 1,
                                 p.segment.type.name(), propose::hand_part(p.candidate.hand_a), propose::hand_part(p.candidate.hand_b), p.segment.a[0],
                                 p.segment.a[1], p.segment.b[0], p.segment.b[1], p.candidate.shift(), d.members, d.voxel, d.angle_step_deg, d.score);
    }
    if (!note.empty() && args.best) std::cout << note << '\n';
    std::cout << fmt::format("wrote {}/: proposals.toml, proposals.json, index.html{} ({} pairs swept in {:.1f} s)\n", out.target().string(),
                             note.empty() ? ", best/ (the best proposal edited)" : "", result.candidates, result.seconds);
}

}  // namespace

void add_propose_command(CLI::App& app) {
    auto args = std::make_shared<ProposeArguments>();
    auto* propose = app.add_subcommand("propose", "Propose key segments: when the two takes can interact, which frames meet, ranked");
    propose->add_option("scene", args->scene, "Scene file (TOML) with two BVH objects; its key segments, if any, are not used")->required();
    propose->add_option("--out", args->out, "Output folder (replaced as a whole when the run succeeds)")->required();
    propose->add_flag("!--no-best", args->best, "Skip the best proposal's edit (best/, which the page plays)");
    add_backend_options(*propose, args->backend, args->device);
    propose->callback([args] { run_propose(*args); });
}

}  // namespace amhv::cli
