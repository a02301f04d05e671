// `amhv edit`: the whole pipeline, from a scene file to the edited two-person scene.
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <iostream>

#include <fmt/ranges.h>

#include "src/cli/backend.hpp"
#include "src/cli/commands.hpp"
#include "src/pipeline/party_stage.hpp"
#include "src/pipeline/propose_stage.hpp"
#include "src/pipeline/sweep_stage.hpp"
#include "src/core/error.hpp"
#include "src/io/files.hpp"
#include "src/io/output_dir.hpp"

namespace amhv::cli {

namespace {

struct EditArguments {
    std::string scene, out, backend = "vulkan";
    std::string body;  // the demo's --body: given, every BVH object gets it
    int device = -1;
    bool propose = false;  // --propose: a scene without key segments edits with the best proposal
    pipeline::EditRunOptions options;
};

// --propose on a scene without key segments: the best proposal (amhv propose) becomes its one key
// segment.
void propose_into(Scene& scene, pipeline::Backends& backends) {
    if (scene.multi_party()) fail(scene.file.string(), "--propose takes a scene of two objects; this one has {}", scene.objects.size());
    const pipeline::ProposeResult result = pipeline::propose_scene(scene, backends);
    pipeline::require_proposals(scene, result);
    scene = pipeline::with_proposal(scene, result.proposals.front());
    const KeySegment& best = scene.segments.front();
    std::cout << fmt::format("proposed: {} on {} / {}, A frames {}-{}, B frames {}-{} (the best of {}; amhv propose lists them)\n", best.type.name(),
                             best.interest_a.labels.front(), best.interest_b.labels.front(), best.a[0], best.a[1], best.b[0], best.b[1],
                             result.proposals.size());
}

// What a multi-party edit placed and wrote.
void report_party(const pipeline::PartyEdit& party, const std::filesystem::path& target, const pipeline::EditRunOptions& options) {
    for (const pipeline::PartyStage& stage : party.stages)
        for (const KeyEdit& k : stage.edit.keys)
            std::cout << fmt::format("key segment {}: {} against {}: {} x = {:.3f} m, y = {:.3f} m, theta = {:.1f} deg (L = {:.3f} m)\n", k.index,
                                     stage.object, fmt::join(stage.against, "+"), k.captured ? "captured placement" : "chosen", k.chosen.x, k.chosen.y,
                                     k.chosen.theta_deg, k.chosen.distance);
    std::cout << fmt::format("wrote {}/: {} objects, {} output frames (transforms.json, frames.csv{}{}, paths.svg, paths.png, views/key_N*.png, result.json)\n", target.string(),
                             party.names.size(), party.length(), options.glb ? ", scene.glb" : "", options.frames ? ", frames/NNNN.ply" : "");
}

void run_edit(const EditArguments& args) {
    const auto start = std::chrono::steady_clock::now();
    Scene scene = load_scene(args.scene, args.propose);
    if (!args.body.empty()) {
        for (SceneObject& o : scene.objects)
            if (!o.bvh.empty()) o.body = parse_body_kind(args.body, "--body");
        scene.a = scene.object(scene.a.name);  // the edited pair's copies follow
        scene.b = scene.object(scene.b.name);
    }
    Backend backend(args.backend, args.device);
    pipeline::Backends backends = backend.backends();
    if (args.propose && scene.segments.empty()) propose_into(scene, backends);
    std::vector<std::filesystem::path> inputs = scene_inputs(scene);
    if (!args.options.from_sweep.empty()) inputs.emplace_back(args.options.from_sweep);
    StagedOutput out(args.out, inputs);
    if (scene.multi_party()) {
        const pipeline::PartyEdit party = pipeline::edit_party_into(scene, backends, out.dir(), args.options, start);
        out.commit();
        report_party(party, out.target(), args.options);
        return;
    }
    const EditResult edit = pipeline::edit_scene_into(scene, backends, out.dir(), args.options, start);
    out.commit();

    for (const KeyEdit& k : edit.keys)
        std::cout << fmt::format("key segment {}: {} x = {:.3f} m, y = {:.3f} m, theta = {:.1f} deg (L = {:.3f} m)\n", k.index,
                                 k.captured ? "captured placement" : "chosen", k.chosen.x, k.chosen.y, k.chosen.theta_deg, k.chosen.distance);
    for (const TouchUp& t : edit.touch_ups)
        std::cout << (t.touches ? fmt::format("key segment {}: moved {:.3f} m so that the parts touch without contact_tolerance\n", t.key, t.moved_m)
                                : fmt::format("key segment {}: {}\n", t.key, t.note));
    std::cout << fmt::format("wrote {}/: {} output frames (transforms.json{}{}{}, paths.svg, paths.png, views/key_N.png, result.json)\n",
                             out.target().string(), edit.timeline.length(), args.options.glb ? ", scene.glb" : "",
                             args.options.glb && args.options.page ? ", index.html" : "", args.options.frames ? ", frames/NNNN.ply" : "");
}

void run_demo(EditArguments args) {
    args.scene = (shipped_data_dir() / "scenes" / "demo.toml").string();
    if (!std::filesystem::is_regular_file(args.scene))
        throw Error(fmt::format("{}: the demo scene is missing (set AMHV_DATA_DIR to the folder holding scenes/ and cmu/)", args.scene));
    std::cout << fmt::format("demo: {} (CMU 18_01 / 19_01: B's capture moved 4 m, turned 120 degrees, its take shifted by 20 frames)\n",
                             args.scene);
    run_edit(args);
    const std::string out = args.out;
    std::cout << fmt::format(
        "look at:\n"
        "  {0}/index.html         the scene playing, and the handshake's solution group: open it in a web browser\n"
        "  {0}/views/key_1.png    the handshake where the hands meet, seen across them, as the edit places the two performers\n"
        "  {0}/paths.png          root paths from above, with a legend: dashed = captured, solid = edited, thick = the handshake\n"
        "  {0}/scene.glb          the whole edited scene, animated: Blender (File > Import > glTF 2.0) or any glTF viewer\n"
        "  {0}/frames/NNNN.ply    both performers per output frame (A orange, B blue): MeshLab, Blender (File > Import > PLY) or ParaView\n"
        "  {0}/result.json        the solution group, the chosen pose, and \"truth\": how far both are from the real capture\n"
        "  {0}/transforms.json    per output frame and performer: source frame and rigid transform\n",
        out);
}

}  // namespace

void add_edit_command(CLI::App& app) {
    auto args = std::make_shared<EditArguments>();
    auto* edit = app.add_subcommand("edit", "Run the whole pipeline: aMHVs, sweep, one solution per key segment, transitional paths, the edited scene");
    edit->add_option("scene", args->scene, "Scene file (TOML)")->required();
    edit->add_option("--out", args->out, "Output folder (replaced as a whole when the run succeeds)")->required();
    add_backend_options(*edit, args->backend, args->device);
    edit->add_option("--from-sweep", args->options.from_sweep, "Reuse the solution groups of an earlier `amhv sweep` (or `amhv edit`) of this scene");
    edit->add_flag("--propose", args->propose, "A scene without key segments: propose them (amhv propose) and edit with the best");
    edit->add_flag("--allow-empty", args->options.allow_empty, "Keep B's captured placement in a key segment whose solution group is empty");
    edit->add_flag("--allow-transition-overlap", args->options.allow_transition_overlap,
                   "Keep the paper's transitional paths where the performers would pass through each other (still checked and reported)");
    edit->add_flag("!--no-frames", args->options.frames, "Skip frames/NNNN.ply");
    edit->add_flag("!--no-glb", args->options.glb, "Skip scene.glb (and the page, which plays it)");
    edit->add_flag("!--no-page", args->options.page, "Skip index.html and view/, the page that plays the scene and plots the groups");
    edit->add_flag("--maps", args->options.maps, "Also write each key segment's feasibility maps");
    edit->add_flag("--csv", args->options.csv, "Also write each solution group as segment_N/solutions.csv (text: gigabytes at fine sampling)");
    edit->add_flag("!--no-timings", args->options.timings, "Leave timings out of result.json (byte-identical reruns)");
    edit->callback([args] { run_edit(*args); });

    auto demo_args = std::make_shared<EditArguments>();
    demo_args->out = "out/demo";
    auto* demo = app.add_subcommand("demo", "Run the built-in demo: a real handshake restored from two separated CMU captures");
    demo->add_option("--out", demo_args->out, "Output folder")->capture_default_str();
    add_backend_options(*demo, demo_args->backend, demo_args->device);
    demo->add_flag("!--no-frames", demo_args->options.frames, "Skip frames/NNNN.ply");
    demo->add_flag("!--no-glb", demo_args->options.glb, "Skip scene.glb (and the page, which plays it)");
    demo->add_flag("!--no-page", demo_args->options.page, "Skip index.html and view/");
    demo->add_flag("!--no-timings", demo_args->options.timings, "Leave timings out of result.json");
    demo->add_option("--body", demo_args->body, "capsules (default) or skinned: the CC0 Mesh2Motion human fitted to each take");
    demo->callback([demo_args] { run_demo(*demo_args); });
}

}  // namespace amhv::cli
