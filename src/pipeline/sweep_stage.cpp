#include "src/pipeline/sweep_stage.hpp"

#include <chrono>
#include <future>
#include <iostream>

#include <unistd.h>

#include <fmt/format.h>

#include "src/core/clock.hpp"
#include "src/core/error.hpp"
#include "src/core/process.hpp"
#include "src/results/appearance_files.hpp"
#include "src/results/edit_files.hpp"
#include "src/results/feasibility_maps.hpp"
#include "src/results/group_vdb.hpp"
#include "src/results/scene_glb.hpp"
#include "src/results/solutions_csv.hpp"
#include "src/pipeline/probe_stage.hpp"
#include "src/pipeline/view_page.hpp"

namespace amhv::pipeline {

namespace fs = std::filesystem;

namespace {

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

}  // namespace

KeySweep key_sweep(const KeySegment& segment, const SweepProblem& problem, const SweepResult& result, SolutionGroup group) {
    KeySweep k;
    k.index = segment.index;
    k.root_a = problem.a.root;
    k.root_b = problem.b.root;
    k.describe = describer(problem);
    k.group = std::move(group);
    k.poses_tested = problem.range.size();
    k.rejected = result.rejected;
    return k;
}

namespace {

// `in_a_party`: a stage of a multi-party edit, whose result.json is not kept (the edit's error line
// names the nearest miss instead) and which amhv probe cannot take.
void report_segment(const KeySegment& segment, const SweepProblem& problem, const SweepResult& result, std::uint64_t limited,
                    std::size_t solutions, double sweep_seconds, bool in_a_party) {
    const std::string limits = segment.intent.limits() ? fmt::format(", limits {}", limited) : "";
    const char* why = in_a_party ? "the nearest miss follows" : "near_misses in result.json; amhv probe says why";
    if (solutions == 0)
        std::cout << fmt::format("segment {} ({}): no solution among {} poses; rejected by {}{} ({})\n", segment.index, segment.type.name(),
                                 problem.range.size(), rejection_counts(result.rejected), limits, why);
    else
        std::cout << fmt::format("segment {} ({}): {} solutions among {} poses ({:.2f} s sweep); rejected by {}{}\n", segment.index,
                                 segment.type.name(), solutions, problem.range.size(), sweep_seconds, rejection_counts(result.rejected), limits);
}

// The sweep's solutions within the editor's limits on the descriptors, decided on the host for
// both backends (exact: the descriptors are the poses' own).
SolutionGroup limited_group(const KeySegment& segment, const SweepProblem& problem, const SweepResult& result) {
    if (!segment.intent.limits()) return solution_group(result);
    const PoseDescriber describe = describer(problem);
    return solution_group(result, [&](const PoseIndex& p) { return within_limits(segment.intent, describe(p)); });
}

// With --from-sweep the groups come from files: the pose the DP chose in each key segment is swept
// again (one pose: the segment's volumes and one test per constraint, on the run's backend, which
// the tests hold equal to the reference; the reference's dense cones cost minutes at 5 mm), so
// that an edit never rests on a row that is not a solution of this scene.
void verify_chosen_poses(const Scene& scene, const EditResult& edit, ObjectSource& a, ObjectSource& b, Backends& backends,
                         const std::string& from_sweep) {
    static const char* kConstraint[] = {"contact", "the interaction dictionary", "fidelity", "visibility"};
    for (std::size_t s = 0; s < edit.keys.size(); ++s) {
        const KeyEdit& key = edit.keys[s];
        if (key.captured) continue;
        SweepProblem problem = build_segment(scene, scene.segments[s], a, b, backends.voxeliser).problem;
        const Solution& pose = key.chosen;
        const std::string where = fmt::format("{}/segment_{}/group.vdb", from_sweep, key.index);
        const PoseRange& r = problem.range;
        if (pose.i < r.i_first || pose.i > r.i_last || pose.j < r.j_first || pose.j > r.j_last || pose.l < r.z_first || pose.l > r.z_last)
            fail(where, "the chosen pose ({}, {}, z {}, {} deg) lies outside the poses key segment {} sweeps", pose.x, pose.y, pose.z, pose.theta_deg,
                 key.index);
        problem.range.i_first = problem.range.i_last = pose.i;
        problem.range.j_first = problem.range.j_last = pose.j;
        problem.range.z_first = problem.range.z_last = pose.l;
        problem.first_angle = pose.k;
        problem.angle_count = 1;
        const PoseOutcome outcome = backends.sweeper.sweep(problem).at(pose.i, pose.j, pose.k, pose.l);
        if (outcome != PoseOutcome::Solution)
            fail(where, "the chosen pose ({}, {}, {} deg) is not a solution of key segment {}: it fails {} (was the folder swept from this scene?)",
                 pose.x, pose.y, pose.theta_deg, key.index, kConstraint[int(outcome)]);
    }
}

}  // namespace

void finish_segment(const Scene& scene, const KeySegment& segment, const SweepProblem& problem, const SweepResult& result, const fs::path& out,
                    const SweepStageOptions& options, results::Json timings, SweepStage& stage) {
    auto t0 = std::chrono::steady_clock::now();
    const auto dir = out / fmt::format("segment_{}", segment.index);
    fs::create_directories(dir);
    SolutionGroup group = limited_group(segment, problem, result);
    const std::uint64_t limited = result.solutions - group.size();
    if (options.csv) write_solutions_csv(dir / "solutions.csv", group, describer(problem));
    const auto group_start = std::chrono::steady_clock::now();
    const results::GroupLattice lattice = results::group_lattice(scene, segment.index, problem.range);
    results::write_group_vdb(dir / "group.vdb", group, lattice);
    results::write_json_file(dir / "group_summary.json", results::group_summary(group, lattice));
    timings["group"] = seconds_since(group_start);
    const results::SegmentFiles files{options.maps, options.maps ? write_feasibility_maps(dir / "feasibility", problem, result) : 0,
                                      std::uint64_t(fs::file_size(dir / "group.vdb")), options.csv};
    timings["output"] = seconds_since(t0);
    stage.mhv_seconds += timings["mhv"].get<double>();
    stage.sweep_seconds += timings["sweep"].get<double>();
    stage.output_seconds += timings["output"].get<double>();

    stage.segments.push_back(
        results::sweep_segment_json(scene, segment, problem, result, group, limited, files, options.timings ? timings : results::Json(nullptr)));
    // An empty group says why: the poses that came nearest.
    if (group.empty()) stage.segments.back()["near_misses"] = near_misses(problem, result);
    report_segment(segment, problem, result, limited, group.size(), timings["sweep"].get<double>(), scene.a_sets_time);
    stage.sweeps.push_back(key_sweep(segment, problem, result, std::move(group)));
}

SweepStage run_sweep_stage(const Scene& scene, ObjectSource& a, ObjectSource& b, Voxeliser& voxeliser, Sweeper& sweeper, const fs::path& out,
                           const SweepStageOptions& options) {
    SweepStage stage;
    for (const KeySegment& segment : scene.segments) {
        if (options.only_segment && segment.index != options.only_segment) continue;
        release_freed_memory();  // the segment before's volumes and sweep
        results::Json timings;
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
        if (const auto stages = sweeper.stage_seconds(); stages.size() == 4)
            timings["sweep_stages"] = {{"contact", stages[0]}, {"dictionary", stages[1]}, {"fidelity", stages[2]}, {"visibility", stages[3]}};
        if (const double wait = sweeper.device_wait_seconds(); wait >= 0) timings["sweep_device_wait"] = wait;
        finish_segment(scene, segment, problem, result, out, options, std::move(timings), stage);
    }
    release_freed_memory();
    return stage;
}

SweepStage read_sweep_stage(const fs::path& dir, const Scene& scene) {
    results::SweepRecord record = results::read_sweep_folder(dir, scene);
    SweepStage stage;
    stage.sweeps = std::move(record.sweeps);
    stage.segments = std::move(record.segments);
    return stage;
}

SweepStage sweep_scene(const Scene& scene, Backends& backends, const fs::path& out, const SweepStageOptions& options,
                       std::chrono::steady_clock::time_point start) {
    ObjectSource a(scene.a, backends.skinner), b(scene.b, backends.skinner);
    results::Json json = results::result_header(scene, backends.backend, backends.device);
    SweepStage stage = run_sweep_stage(scene, a, b, backends.voxeliser, backends.sweeper, out, options);
    json["segments"] = stage.segments;
    if (options.timings) json["timings_s"] = {{"total", seconds_since(start)}};
    results::write_json_file(out / "result.json", json);
    return stage;
}

EditResult edit_scene_into(const Scene& scene, Backends& backends, const fs::path& out, const EditRunOptions& options,
                           std::chrono::steady_clock::time_point start) {
    ObjectSource a(scene.a, backends.skinner), b(scene.b, backends.skinner);
    results::Json json = results::result_header(scene, backends.backend, backends.device);
    json["from_sweep"] = options.from_sweep.empty() ? nlohmann::json(nullptr) : nlohmann::json(options.from_sweep);

    // aMHVs and sweep (or the groups of an earlier sweep).
    SweepStage stage = options.from_sweep.empty()
                           ? run_sweep_stage(scene, a, b, backends.voxeliser, backends.sweeper, out, {0, options.maps, options.timings, options.csv})
                           : read_sweep_stage(options.from_sweep, scene);

    EditOptions edit_options;
    edit_options.allow_empty = options.allow_empty;
    edit_options.allow_transition_overlap = options.allow_transition_overlap;
    edit_options.natural_sampled = kPagePlottedMembers;
    EditResult edit = edit_scene(scene, stage.sweeps, a, b, backends.voxeliser, edit_options);
    if (!options.from_sweep.empty()) verify_chosen_poses(scene, edit, a, b, backends, options.from_sweep);

    auto t0 = std::chrono::steady_clock::now();
    write_transforms_json(out / "transforms.json", scene, edit);
    // The natural scores of the members the page plots (docs/method.md section 7b).
    for (const NaturalReport& n : edit.natural) {
        const fs::path dir = out / fmt::format("segment_{}", n.key);
        fs::create_directories(dir);
        results::write_json_file(dir / "natural.json", {{"stride", n.stride}, {"costs", n.sampled}});
    }
    write_frame_checks_csv(out / "frames.csv", edit);
    results::EditFiles files;
    files.frames = options.frames;
    files.mesh_files = options.frames ? write_scene_frames(out / "frames", edit, a, b) : 0;
    files.obj_files = options.frames ? write_obj_frames(out / "frames", edit, a, b) : 0;
    // scene.glb is written on a thread of its own beside the pictures (which use both object
    // sources and every core): its meshes are gathered first, and the rest is one thread's work.
    const std::vector<GlbObject> glb_objects{{"A", &a, &edit.frames[0]}, {"B", &b, &edit.frames[1]}};
    std::future<SceneGlbReport> glb;
    if (options.glb)
        glb = std::async(std::launch::async, [&out, &glb_objects, meshes = gather_glb_meshes(glb_objects), fps = scene.a.fps] {
            return write_scene_glb(out / "scene.glb", glb_objects, meshes, fps);
        });
    write_paths_picture(out / "paths.svg", out / "paths.png", edit);
    files.views = write_key_and_eye_views(out / "views", scene, edit, a, b);
    files.bvh = write_edited_bvh(out, edit, a, b);
    files.characters = write_edited_characters(out, {"A", "B"}, {&edit.frames[0], &edit.frames[1]}, {&a, &b});
    if (glb.valid()) {
        const SceneGlbReport report = glb.get();
        files.glb = true;
        files.glb_bytes = report.bytes;
        files.glb_fps = scene.a.fps;
    }

    json["segments"] = stage.segments;
    results::add_edit(json, edit, files);
    const double output_seconds = seconds_since(t0) + stage.output_seconds;
    if (options.timings)
        json["timings_s"] = {{"mhv", stage.mhv_seconds + edit.roots_seconds}, {"sweep", stage.sweep_seconds}, {"natural", edit.natural_seconds}, {"dp", edit.dp_seconds},
                             {"path", edit.path_seconds}, {"check", edit.check_seconds}, {"output", output_seconds}, {"total", seconds_since(start)}};
    results::write_json_file(out / "result.json", json);
    if (options.page && options.glb) write_view_page(out, out);  // reads the files above
    return edit;
}

}  // namespace amhv::pipeline
