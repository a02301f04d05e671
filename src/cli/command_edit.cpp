// `amhv edit`: the whole pipeline, from a scene file to the edited two-person scene.
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <cmath>
#include <fstream>
#include <iostream>
#include <numbers>

#include <nlohmann/json.hpp>

#include "cli/backend.hpp"
#include "cli/commands.hpp"
#include "cli/sweep_stage.hpp"
#include "core/clock.hpp"
#include "core/error.hpp"
#include "edit/edit.hpp"
#include "io/edit_output.hpp"
#include "io/output_dir.hpp"

namespace amhv::cli {

namespace {

struct EditArguments {
    std::string scene, out, backend = "vulkan", from_sweep;
    int device = -1;
    bool allow_empty = false, frames = true, maps = false, timings = true;
};

double degrees(double radians) { return radians * 180 / std::numbers::pi; }

nlohmann::ordered_json solution_json(const Solution& s) {
    return {{"x", s.x}, {"y", s.y}, {"theta_deg", s.theta_deg}, {"L", s.distance}, {"thetaA_deg", s.theta_a_deg}, {"thetaB_deg", s.theta_b_deg}};
}

// views/key_N.png and the output frame each shows.
nlohmann::ordered_json views_json(const std::vector<int>& frames) {
    nlohmann::ordered_json views = nlohmann::ordered_json::array();
    for (std::size_t i = 0; i < frames.size(); ++i) views.push_back({{"file", fmt::format("views/key_{}.png", i + 1)}, {"output_frame", frames[i]}});
    return views;
}

void run_edit(const EditArguments& args) {
    const auto start = std::chrono::steady_clock::now();
    Scene scene = load_scene(args.scene);
    Backend backend(args.backend, args.device);
    ObjectSource a(scene.a), b(scene.b);
    StagedOutput out(args.out);

    nlohmann::ordered_json json = result_header(scene, args.backend, backend.device());
    json["from_sweep"] = args.from_sweep.empty() ? nlohmann::json(nullptr) : nlohmann::json(args.from_sweep);

    // aMHVs and sweep (or the groups of an earlier sweep).
    SweepStage stage = args.from_sweep.empty()
                           ? run_sweep_stage(scene, a, b, backend.voxeliser(), backend.sweeper(), out.dir(), {0, args.maps, args.timings})
                           : read_sweep_stage(args.from_sweep, scene);

    EditOptions options;
    options.allow_empty = args.allow_empty;
    EditResult edit = edit_scene(scene, stage.sweeps, a, b, backend.voxeliser(), options);

    auto t0 = std::chrono::steady_clock::now();
    write_transforms_json(out.dir() / "transforms.json", scene, edit);
    const int frame_files = args.frames ? write_scene_frames(out.dir() / "frames", edit, a, b) : 0;
    write_paths_picture(out.dir() / "paths.svg", out.dir() / "paths.png", edit);
    const std::vector<int> views = write_key_views(out.dir() / "views", edit, a, b);

    json["segments"] = stage.segments;
    for (std::size_t i = 0; i < edit.keys.size(); ++i) {
        const KeyEdit& k = edit.keys[i];
        auto& s = json["segments"][i];
        s["chosen"] = solution_json(k.chosen);
        s["chosen"]["captured_placement"] = k.captured;
        if (s.contains("truth")) {
            const double dx = k.chosen.x - s["truth"]["x"].get<double>(), dy = k.chosen.y - s["truth"]["y"].get<double>();
            s["truth"]["chosen_error_m"] = std::hypot(dx, dy);
            s["truth"]["chosen_error_deg"] = std::abs(std::remainder(k.chosen.theta_deg - s["truth"]["theta_deg"].get<double>(), 360.0));
        }
        s["edit"] = {{"a_rotation_deg", degrees(k.a_rotation_rad)},
                     {"a_translation_m", {k.a_translation.x(), k.a_translation.y()}},
                     {"root_a_m", {k.root_a.x(), k.root_a.y()}},
                     {"root_b_m", {k.root_b.x(), k.root_b.y()}},
                     {"yaw_a_deg", degrees(k.yaw_a)},
                     {"yaw_b_deg", degrees(k.yaw_b)}};
    }
    json["dp"] = {{"cost", edit.choice.cost}, {"unary", edit.choice.unary}, {"pairwise", edit.choice.pairwise}};
    nlohmann::ordered_json paths = nlohmann::ordered_json::array();
    for (const PathReport& p : edit.paths)
        paths.push_back({{"segment", fmt::format("transition {}", p.timeline_segment / 2)},
                         {"object", p.object == 0 ? "A" : "B"},
                         {"frames", p.frames},
                         {"root_residual", p.root_cost},
                         {"facing_residual", p.facing_cost},
                         {"max_shift_m", p.max_shift_m}});
    json["paths"] = paths;
    json["output"] = {{"frames", edit.timeline.length()},
                      {"transforms", "transforms.json"},
                      {"meshes", args.frames ? nlohmann::json("frames/NNNN.ply") : nlohmann::json(nullptr)},
                      {"mesh_files", frame_files},
                      {"paths", {"paths.svg", "paths.png"}},
                      {"views", views_json(views)}};
    const double output_seconds = seconds_since(t0) + stage.output_seconds;
    if (args.timings)
        json["timings_s"] = {{"mhv", stage.mhv_seconds + edit.roots_seconds}, {"sweep", stage.sweep_seconds}, {"dp", edit.dp_seconds},
                             {"path", edit.path_seconds}, {"output", output_seconds}, {"total", seconds_since(start)}};
    std::ofstream(out.dir() / "result.json") << json.dump(2) << '\n';
    out.commit();

    for (const KeyEdit& k : edit.keys)
        std::cout << fmt::format("key segment {}: {} x = {:.3f} m, y = {:.3f} m, theta = {:.1f} deg (L = {:.3f} m)\n", k.index,
                                 k.captured ? "captured placement" : "chosen", k.chosen.x, k.chosen.y, k.chosen.theta_deg, k.chosen.distance);
    std::cout << fmt::format("wrote {}/: {} output frames (transforms.json{}, paths.svg, paths.png, views/key_N.png, result.json)\n", out.target().string(),
                             edit.timeline.length(), args.frames ? ", frames/NNNN.ply" : "");
}

// The shipped data: AMHV_DATA_DIR in the environment, else the source tree's data/.
std::filesystem::path data_dir() {
    if (const char* env = std::getenv("AMHV_DATA_DIR")) return env;
    return AMHV_DATA_DIR;
}

void run_demo(EditArguments args) {
    args.scene = (data_dir() / "scenes" / "demo.toml").string();
    if (!std::filesystem::is_regular_file(args.scene))
        throw Error(fmt::format("{}: the demo scene is missing (set AMHV_DATA_DIR to the folder holding scenes/ and cmu/)", args.scene));
    std::cout << fmt::format("demo: {} (CMU 18_01 / 19_01: B's capture moved 4 m, turned 120 degrees, its take shifted by 20 frames)\n",
                             args.scene);
    run_edit(args);
    const std::string out = args.out;
    std::cout << fmt::format(
        "look at:\n"
        "  {0}/views/key_1.png    the middle of the handshake from the side, as the edit places the two performers\n"
        "  {0}/paths.png          root paths from above: dashed = captured, solid = edited, thick = the handshake\n"
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
    edit->add_option("--from-sweep", args->from_sweep, "Reuse the solution groups of an earlier `amhv sweep` (or `amhv edit`) of this scene");
    edit->add_flag("--allow-empty", args->allow_empty, "Keep B's captured placement in a key segment whose solution group is empty");
    edit->add_flag("!--no-frames", args->frames, "Skip frames/NNNN.ply");
    edit->add_flag("--maps", args->maps, "Also write each key segment's feasibility maps");
    edit->add_flag("!--no-timings", args->timings, "Leave timings out of result.json (byte-identical reruns)");
    edit->callback([args] { run_edit(*args); });

    auto demo_args = std::make_shared<EditArguments>();
    demo_args->out = "out/demo";
    auto* demo = app.add_subcommand("demo", "Run the built-in demo: a real handshake restored from two separated CMU captures");
    demo->add_option("--out", demo_args->out, "Output folder")->capture_default_str();
    add_backend_options(*demo, demo_args->backend, demo_args->device);
    demo->add_flag("!--no-frames", demo_args->frames, "Skip frames/NNNN.ply");
    demo->add_flag("!--no-timings", demo_args->timings, "Leave timings out of result.json");
    demo->callback([demo_args] { run_demo(*demo_args); });
}

}  // namespace amhv::cli
