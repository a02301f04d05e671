// `amhv check` and `amhv sweep`: scene validation and the constraint satisfaction stage.
#include <chrono>
#include <fstream>
#include <iostream>

#include <unistd.h>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "cli/backend.hpp"
#include "cli/commands.hpp"
#include "core/error.hpp"
#include "io/output_dir.hpp"
#include "io/sweep_output.hpp"
#include "scene/scene.hpp"
#include "scene/segment.hpp"

namespace amhv::cli {

namespace {

struct SweepArguments {
    std::string scene, out, backend = "vulkan";
    int segment = 0;  // 0: all
    int device = -1;
    bool require_solutions = false, maps = true, timings = true;
};

double seconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// A one-line progress bar on stderr, only when stderr is a terminal.
class ProgressBar {
public:
    explicit ProgressBar(std::string label) : label_(std::move(label)), enabled_(isatty(STDERR_FILENO) == 1) {}
    ~ProgressBar() {
        if (enabled_ && drawn_) std::cerr << "\r\033[K" << std::flush;
    }
    void operator()(int done, int total) {
        if (!enabled_ || total <= 0) return;
        const int width = 30, filled = done * width / total;
        std::cerr << fmt::format("\r{} [{}{}] {}/{} angles", label_, std::string(std::size_t(filled), '#'),
                                 std::string(std::size_t(width - filled), '.'), done, total)
                  << std::flush;
        drawn_ = true;
    }

private:
    std::string label_;
    bool enabled_;
    bool drawn_ = false;
};

nlohmann::json vec3(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

void run_check(const std::string& file) {
    Scene scene = load_scene(file);
    std::cout << resolved_toml(scene);
}

void run_sweep(const SweepArguments& args) {
    const auto start = std::chrono::steady_clock::now();
    Scene scene = load_scene(args.scene);
    if (args.segment < 0 || args.segment > int(scene.segments.size()))
        throw Error(fmt::format("--segment: {} is not a key segment of {} (1..{})", args.segment, args.scene, scene.segments.size()));

    Backend backend(args.backend, args.device);
    Voxeliser& voxeliser = backend.voxeliser();
    Sweeper& sweeper = backend.sweeper();

    ObjectSource a(scene.a), b(scene.b);
    StagedOutput out(args.out);
    nlohmann::ordered_json json;
    json["program"] = std::string("amhv ") + AMHV_VERSION;
    json["scene"] = scene.file.string();
    json["backend"] = args.backend;
    json["device"] = backend.device();
    const Weights& w = scene.weights;
    json["parameters"] = {{"voxel_m", scene.sampling.voxel},
                          {"angle_step_deg", scene.sampling.angle_step_deg},
                          {"angles", scene.sampling.angles()},
                          {"x_range_m", scene.sampling.x_range ? nlohmann::json(*scene.sampling.x_range) : nlohmann::json(nullptr)},
                          {"y_range_m", scene.sampling.y_range ? nlohmann::json(*scene.sampling.y_range) : nlohmann::json(nullptr)},
                          {"weights", {{"lambda", w.lambda}, {"delta", w.delta}, {"alpha", w.alpha}, {"v_c", w.v_c}, {"r_c", w.r_c},
                                       {"w_A", w.w_a}, {"w_B", w.w_b}, {"mu", w.mu}, {"a_rotations_deg", w.a_rotations_deg}}}};
    json["segments"] = nlohmann::json::array();
    std::vector<int> empty_segments;
    for (const KeySegment& segment : scene.segments) {
        if (args.segment && segment.index != args.segment) continue;
        nlohmann::ordered_json timings;
        auto t0 = std::chrono::steady_clock::now();
        SegmentBuild build = build_segment(scene, segment, a, b, voxeliser);
        timings["mhv"] = seconds_since(t0);
        const SweepProblem& problem = build.problem;

        t0 = std::chrono::steady_clock::now();
        ProgressBar bar(fmt::format("segment {} ({})", segment.index, segment.type.name()));
        sweeper.progress = [&bar](int done, int total) { bar(done, total); };
        SweepResult result = sweeper.sweep(problem);
        sweeper.progress = nullptr;
        timings["sweep"] = seconds_since(t0);

        t0 = std::chrono::steady_clock::now();
        const auto dir = out.dir() / fmt::format("segment_{}", segment.index);
        std::filesystem::create_directories(dir);
        auto list = solutions(problem, result);
        write_solutions_csv(dir / "solutions.csv", list);
        int maps = args.maps ? write_feasibility_maps(dir / "feasibility", problem, result) : 0;
        timings["output"] = seconds_since(t0);

        nlohmann::ordered_json s;
        s["index"] = segment.index;
        s["type"] = segment.type.name();
        s["frames_a"] = {segment.a[0], segment.a[1]};
        s["frames_b"] = {segment.b[0], segment.b[1]};
        s["normalised_frames"] = problem.frames();
        s["poses_tested"] = problem.range.size();
        s["solutions"] = result.solutions;
        s["rejected"] = {{"contact", result.rejected[0]}, {"dictionary", result.rejected[1]}, {"fidelity", result.rejected[2]},
                         {"visibility", result.rejected[3]}};
        s["range"] = {{"x_m", {problem.range.i_first * problem.voxel, problem.range.i_last * problem.voxel}},
                      {"y_m", {problem.range.j_first * problem.voxel, problem.range.j_last * problem.voxel}},
                      {"angles", problem.range.angles}};
        s["root_m"] = {{"A", vec3(problem.a.root)}, {"B", vec3(problem.b.root)}};
        s["facing"] = {{"A", {problem.a.facing.x(), problem.a.facing.y()}}, {"B", {problem.b.facing.x(), problem.b.facing.y()}}};
        s["tolerance"] = segment.tolerance;
        s["visibility"] = {{"enabled", segment.visibility.enabled}, {"half_angle_deg", segment.visibility.half_angle_deg},
                           {"range_m", segment.visibility.range}};
        s["interest"] = {{"A", segment.interest_a.describe()}, {"B", segment.interest_b.describe()}};
        s["fidelity"] = {{"A", segment.fidelity_a.describe()}, {"B", segment.fidelity_b.describe()}};
        s["files"] = {{"solutions", fmt::format("segment_{}/solutions.csv", segment.index)},
                      {"feasibility", args.maps ? nlohmann::json(fmt::format("segment_{}/feasibility/", segment.index)) : nlohmann::json(nullptr)},
                      {"feasibility_files", maps}};
        if (args.timings) s["timings_s"] = timings;
        json["segments"].push_back(s);

        const std::string counts = fmt::format("contact {}, dictionary {}, fidelity {}, visibility {}", result.rejected[0], result.rejected[1],
                                               result.rejected[2], result.rejected[3]);
        if (result.solutions == 0) {
            empty_segments.push_back(segment.index);
            std::cout << fmt::format("segment {} ({}): no solution among {} poses; rejected by {}\n", segment.index, segment.type.name(),
                                     problem.range.size(), counts);
        } else {
            std::cout << fmt::format("segment {} ({}): {} solutions among {} poses ({:.2f} s sweep); rejected by {}\n", segment.index,
                                     segment.type.name(), result.solutions, problem.range.size(), timings["sweep"].get<double>(), counts);
        }
    }
    if (args.timings) json["timings_s"] = {{"total", seconds_since(start)}};
    std::ofstream(out.dir() / "result.json") << json.dump(2) << '\n';
    out.commit();
    std::cout << fmt::format("wrote {}/ (result.json, segment_N/solutions.csv{})\n", out.target().string(),
                             args.maps ? ", segment_N/feasibility/" : "");
    if (args.require_solutions && !empty_segments.empty())
        throw Error(fmt::format("--require-solutions: key segment {} has no solution", empty_segments.front()));
}

}  // namespace

void add_scene_commands(CLI::App& app) {
    auto check_file = std::make_shared<std::string>();
    auto* check = app.add_subcommand("check", "Validate a scene file and print it with every default filled in");
    check->add_option("scene", *check_file, "Scene file (TOML)")->required();
    check->callback([check_file] { run_check(*check_file); });

    auto args = std::make_shared<SweepArguments>();
    auto* sweep = app.add_subcommand("sweep", "Find every placement of B around A that satisfies each key segment's constraints");
    sweep->add_option("scene", args->scene, "Scene file (TOML)")->required();
    sweep->add_option("--out", args->out, "Output folder (replaced as a whole when the run succeeds)")->required();
    sweep->add_option("--backend", args->backend, "vulkan or cpu (the plain reference)")->capture_default_str();
    sweep->add_option("--segment", args->segment, "Only key segment N (1-based)");
    sweep->add_option("--device", args->device, "Vulkan device index (see `amhv devices`)");
    sweep->add_flag("--require-solutions", args->require_solutions, "Exit non-zero when a key segment has no solution");
    sweep->add_flag("!--no-maps", args->maps, "Skip the feasibility maps");
    sweep->add_flag("!--no-timings", args->timings, "Leave timings out of result.json (byte-identical reruns)");
    sweep->callback([args] { run_sweep(*args); });
}

}  // namespace amhv::cli
