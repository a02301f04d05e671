#include "cli/sweep_stage.hpp"

#include <charconv>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <numbers>
#include <sstream>

#include <unistd.h>

#include <Eigen/Geometry>

#include "core/clock.hpp"
#include "core/error.hpp"
#include "io/sweep_output.hpp"

namespace amhv::cli {

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

nlohmann::json vec3(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

// The true pose of B relative to A in this key segment (METHOD.md section 4's form) and whether the
// group holds a solution within one voxel on x and y and one angle step of it.
nlohmann::ordered_json truth_json(const Scene& scene, const SweepProblem& problem, const std::vector<Solution>& group) {
    const Placement& t = *scene.truth;
    const double yaw = t.yaw_deg * std::numbers::pi / 180;
    const Eigen::Vector2d ca(problem.a.root.x(), problem.a.root.y()), cb(problem.b.root.x(), problem.b.root.y());
    const Eigen::Vector2d offset = Eigen::Rotation2Dd(yaw) * cb + Eigen::Vector2d(t.x, t.y) - ca;
    const double h = problem.voxel, step = problem.angle_step_deg;
    double nearest = std::numeric_limits<double>::infinity();
    bool within = false;
    for (const Solution& s : group) {
        const double turn = std::abs(std::remainder(s.theta_deg - t.yaw_deg, 360.0));
        const double dx = std::abs(s.x - offset.x()), dy = std::abs(s.y - offset.y());
        within = within || (dx <= h + 1e-9 && dy <= h + 1e-9 && turn <= step + 1e-9);
        if (turn <= step + 1e-9) nearest = std::min(nearest, std::hypot(dx, dy));
    }
    return {{"x", offset.x()},
            {"y", offset.y()},
            {"theta_deg", std::remainder(t.yaw_deg, 360.0)},
            {"in_group", within},
            {"nearest_solution_m", std::isinf(nearest) ? nlohmann::json(nullptr) : nlohmann::json(nearest)}};
}

}  // namespace

nlohmann::ordered_json result_header(const Scene& scene, const std::string& backend, const std::string& device) {
    nlohmann::ordered_json json;
    json["program"] = std::string("amhv ") + AMHV_VERSION;
    json["scene"] = scene.file.string();
    json["backend"] = backend;
    json["device"] = device;
    const Weights& w = scene.weights;
    json["parameters"] = {{"voxel_m", scene.sampling.voxel},
                          {"angle_step_deg", scene.sampling.angle_step_deg},
                          {"angles", scene.sampling.angles()},
                          {"x_range_m", scene.sampling.x_range ? nlohmann::json(*scene.sampling.x_range) : nlohmann::json(nullptr)},
                          {"y_range_m", scene.sampling.y_range ? nlohmann::json(*scene.sampling.y_range) : nlohmann::json(nullptr)},
                          {"weights", {{"lambda", w.lambda}, {"delta", w.delta}, {"alpha", w.alpha}, {"v_c", w.v_c}, {"r_c", w.r_c},
                                       {"w_A", w.w_a}, {"w_B", w.w_b}, {"mu", w.mu}, {"a_rotations_deg", w.a_rotations_deg}}}};
    return json;
}

SweepStage run_sweep_stage(const Scene& scene, ObjectSource& a, ObjectSource& b, Voxeliser& voxeliser, Sweeper& sweeper, const fs::path& out,
                           const SweepStageOptions& options) {
    SweepStage stage;
    for (const KeySegment& segment : scene.segments) {
        if (options.only_segment && segment.index != options.only_segment) continue;
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
        if (const auto stages = sweeper.stage_seconds(); stages.size() == 4)
            timings["sweep_stages"] = {{"contact", stages[0]}, {"dictionary", stages[1]}, {"fidelity", stages[2]}, {"visibility", stages[3]}};

        t0 = std::chrono::steady_clock::now();
        const auto dir = out / fmt::format("segment_{}", segment.index);
        fs::create_directories(dir);
        auto list = solutions(problem, result);
        write_solutions_csv(dir / "solutions.csv", list);
        int maps = options.maps ? write_feasibility_maps(dir / "feasibility", problem, result) : 0;
        timings["output"] = seconds_since(t0);
        stage.mhv_seconds += timings["mhv"].get<double>();
        stage.sweep_seconds += timings["sweep"].get<double>();
        stage.output_seconds += timings["output"].get<double>();

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
                      {"feasibility", options.maps ? nlohmann::json(fmt::format("segment_{}/feasibility/", segment.index)) : nlohmann::json(nullptr)},
                      {"feasibility_files", maps}};
        if (scene.truth) s["truth"] = truth_json(scene, problem, list);
        if (options.timings) s["timings_s"] = timings;
        stage.segments.push_back(s);

        KeySweep k;
        k.index = segment.index;
        k.root_a = problem.a.root;
        k.root_b = problem.b.root;
        k.facing_a = problem.a.facing;
        k.facing_b = problem.b.facing;
        k.solutions = std::move(list);
        k.poses_tested = problem.range.size();
        k.rejected = result.rejected;
        stage.sweeps.push_back(std::move(k));

        if (result.solutions == 0)
            std::cout << fmt::format("segment {} ({}): no solution among {} poses; rejected by {}\n", segment.index, segment.type.name(),
                                     problem.range.size(), rejection_counts(result.rejected));
        else
            std::cout << fmt::format("segment {} ({}): {} solutions among {} poses ({:.2f} s sweep); rejected by {}\n", segment.index,
                                     segment.type.name(), result.solutions, problem.range.size(), timings["sweep"].get<double>(),
                                     rejection_counts(result.rejected));
    }
    return stage;
}

SweepStage read_sweep_stage(const fs::path& dir, const Scene& scene) {
    const fs::path file = dir / "result.json";
    const std::string where = file.string();
    std::ifstream in(file);
    if (!in) fail(where, "cannot open: --from-sweep needs the folder written by `amhv sweep` (or `amhv edit`)");
    nlohmann::json json;
    try {
        json = nlohmann::json::parse(in);
    } catch (const nlohmann::json::exception& e) {
        fail(where, "is not valid JSON ({})", e.what());
    }
    SweepStage stage;
    try {
        const auto& p = json.at("parameters");
        if (p.at("voxel_m").get<double>() != scene.sampling.voxel || p.at("angle_step_deg").get<double>() != scene.sampling.angle_step_deg)
            fail(where, "was swept at {} m / {} deg but the scene asks for {} m / {} deg", p.at("voxel_m").get<double>(),
                 p.at("angle_step_deg").get<double>(), scene.sampling.voxel, scene.sampling.angle_step_deg);
        auto range_matches = [&](const char* key, const std::optional<std::array<double, 2>>& range) {
            const auto& node = p.at(key);
            return node.is_null() ? !range : (range && node.get<std::array<double, 2>>() == *range);
        };
        if (!range_matches("x_range_m", scene.sampling.x_range) || !range_matches("y_range_m", scene.sampling.y_range))
            fail(where, "was swept over another x_range / y_range than the scene's");
        const auto& segments = json.at("segments");
        for (const KeySegment& key : scene.segments) {
            const nlohmann::json* s = nullptr;
            for (const auto& item : segments)
                if (item.at("index").get<int>() == key.index) s = &item;
            if (!s) fail(where, "has no key segment {}: sweep every segment (no --segment) before --from-sweep", key.index);
            if (s->at("frames_a").get<std::array<int, 2>>() != key.a || s->at("frames_b").get<std::array<int, 2>>() != key.b ||
                s->at("type").get<std::string>() != key.type.name() || s->at("tolerance").get<int>() != key.tolerance ||
                s->at("visibility").at("enabled").get<bool>() != key.visibility.enabled ||
                s->at("visibility").at("half_angle_deg").get<double>() != key.visibility.half_angle_deg ||
                s->at("interest").at("A").get<std::string>() != key.interest_a.describe() ||
                s->at("interest").at("B").get<std::string>() != key.interest_b.describe() ||
                s->at("fidelity").at("A").get<std::string>() != key.fidelity_a.describe() ||
                s->at("fidelity").at("B").get<std::string>() != key.fidelity_b.describe())
                fail(where, "key segment {} was swept with other frames, type, tolerance, visibility or parts than the scene says", key.index);
            KeySweep k;
            k.index = key.index;
            const auto ra = s->at("root_m").at("A").get<std::array<double, 3>>(), rb = s->at("root_m").at("B").get<std::array<double, 3>>();
            k.root_a = Vec3(ra[0], ra[1], ra[2]);
            k.root_b = Vec3(rb[0], rb[1], rb[2]);
            const auto fa = s->at("facing").at("A").get<std::array<double, 2>>(), fb = s->at("facing").at("B").get<std::array<double, 2>>();
            k.facing_a = Eigen::Vector2d(fa[0], fa[1]);
            k.facing_b = Eigen::Vector2d(fb[0], fb[1]);
            k.poses_tested = s->at("poses_tested").get<std::uint64_t>();
            const auto& rej = s->at("rejected");
            k.rejected = {rej.at("contact").get<std::uint64_t>(), rej.at("dictionary").get<std::uint64_t>(),
                          rej.at("fidelity").get<std::uint64_t>(), rej.at("visibility").get<std::uint64_t>()};

            // The solution group: x, y on the lattice of edge h, theta on the angle steps.
            const fs::path csv = dir / fmt::format("segment_{}", key.index) / "solutions.csv";
            std::ifstream rows(csv);
            if (!rows) fail(csv.string(), "cannot open the solution group");
            std::string line;
            int number = 0;
            const int angles = scene.sampling.angles();
            while (std::getline(rows, line)) {
                ++number;
                if (number == 1) {
                    if (line.rfind("x,y,theta_deg", 0) != 0) fail(csv.string() + ":1", "expected the header x,y,theta_deg,L,thetaA_deg,thetaB_deg");
                    continue;
                }
                if (!line.empty() && line.back() == '\r') line.pop_back();
                if (line.empty()) continue;
                // Six comma-separated numbers (std::from_chars: exact, and far faster than streams
                // on groups of millions of rows).
                Solution sol;
                double* fields[] = {&sol.x, &sol.y, &sol.theta_deg, &sol.distance, &sol.theta_a_deg, &sol.theta_b_deg};
                const char* at = line.data();
                const char* end = line.data() + line.size();
                bool ok = true;
                for (int f = 0; f < 6 && ok; ++f) {
                    while (at < end && *at == ' ') ++at;
                    const auto [next, error] = std::from_chars(at, end, *fields[f]);
                    ok = error == std::errc() && (f < 5 ? next < end && *next == ',' : next == end);
                    at = next + 1;
                }
                if (!ok || !std::isfinite(sol.x + sol.y + sol.theta_deg)) fail(fmt::format("{}:{}", csv.string(), number), "expected six numbers");
                sol.i = int(std::lround(sol.x / scene.sampling.voxel));
                sol.j = int(std::lround(sol.y / scene.sampling.voxel));
                sol.k = int(((std::lround(sol.theta_deg / scene.sampling.angle_step_deg) % angles) + angles) % angles);
                k.solutions.push_back(sol);
            }
            if (k.solutions.size() != s->at("solutions").get<std::uint64_t>())
                fail(csv.string(), "has {} rows but result.json says the group has {} solutions", k.solutions.size(),
                     s->at("solutions").get<std::uint64_t>());
            stage.segments.push_back(nlohmann::ordered_json::parse(s->dump()));
            stage.sweeps.push_back(std::move(k));
        }
    } catch (const nlohmann::json::exception& e) {
        fail(where, "is not a sweep's result.json ({})", e.what());
    }
    return stage;
}

}  // namespace amhv::cli
