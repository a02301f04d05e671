#include "src/results/result_json.hpp"

#include <cmath>
#include <fstream>
#include <limits>

#include <Eigen/Geometry>
#include <fmt/format.h>

#include "src/core/angles.hpp"
#include "src/core/error.hpp"
#include "src/io/files.hpp"
#include "src/results/group_vdb.hpp"
#include "src/io/json_problem.hpp"

namespace amhv::results {

namespace fs = std::filesystem;

Json solution_json(const Solution& s) {
    return {{"x", s.x}, {"y", s.y}, {"z", s.z}, {"theta_deg", s.theta_deg}, {"L", s.distance}, {"thetaA_deg", s.theta_a_deg}, {"thetaB_deg", s.theta_b_deg}};
}

// The natural choice's terms (docs/method.md section 7b): null where a term does not apply.
Json natural_terms_json(const NaturalTerms& t) {
    auto value = [](double v) { return std::isnan(v) ? Json(nullptr) : Json(v); };
    return {{"cost", t.cost()}, {"gaze", value(t.gaze)}, {"depth_m", value(t.depth_m)}, {"sliding_m", value(t.sliding_m)},
            {"crowding", value(t.crowding)}, {"reach", value(t.reach)},
            {"reach_offset_m", value(t.reach_offset_m)}, {"impact_gap_m", value(t.impact_gap_m)},
            {"impact_closing_m", value(t.impact_closing_m)}};
}

namespace {

nlohmann::json vec3(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

// The true pose of B relative to A in this key segment (docs/method.md section 4's form) and
// whether the group holds a solution within one voxel on x and y and one angle step of it.
Json truth_json(const Scene& scene, const SweepProblem& problem, const SolutionGroup& group) {
    const Placement& t = *scene.truth;
    const Eigen::Vector2d offset = truth_offset(t, problem.a.root, problem.b.root);
    const double h = problem.voxel, step = problem.angle_step_deg;
    const PoseDescriber describe = describer(problem);
    double nearest = std::numeric_limits<double>::infinity();
    bool within = false;
    group.for_each([&](const PoseIndex& p) {
        const Solution s = describe(p);
        const double turn = angles::degrees_apart(s.theta_deg, t.yaw_deg);
        const double dx = std::abs(s.x - offset.x()), dy = std::abs(s.y - offset.y());
        within = within || (dx <= h + 1e-9 && dy <= h + 1e-9 && turn <= step + 1e-9);
        if (turn <= step + 1e-9) nearest = std::min(nearest, std::hypot(dx, dy));
    });
    return {{"x", offset.x()},
            {"y", offset.y()},
            {"theta_deg", std::remainder(t.yaw_deg, 360.0)},
            {"in_group", within},
            {"nearest_solution_m", std::isinf(nearest) ? nlohmann::json(nullptr) : nlohmann::json(nearest)}};
}


// The keys for real captures as result.json records them (and --from-sweep compares them).
Json capture_keys_json(const KeySegment& segment) {
    return {{"contact_tolerance_m", segment.contact_tolerance},
            {"contact_frames", segment.contact_frames},
            {"z_range_m", segment.z_range ? Json(*segment.z_range) : Json(nullptr)},
            {"visibility_per_frame", segment.visibility.per_frame},
            {"visibility_frames", segment.visibility.frames}};
}

// The entry of key segment `key` in result.json, checked against the scene.
const nlohmann::json& matching_entry(const nlohmann::json& segments, const KeySegment& key, const std::string& where) {
    const nlohmann::json* s = nullptr;
    for (const auto& item : segments)
        if (json_integer<int>(item.at("index")) == key.index) s = &item;
    if (!s) fail(where, "has no key segment {}: sweep every segment (no --segment) before --from-sweep", key.index);
    auto frames = [](const nlohmann::json& j) { return std::array<int, 2>{json_integer<int>(j.at(0)), json_integer<int>(j.at(1))}; };
    if (frames(s->at("frames_a")) != key.a || frames(s->at("frames_b")) != key.b ||
        s->at("type").get<std::string>() != key.type.name() || json_integer<int>(s->at("tolerance")) != key.tolerance ||
        s->at("visibility").at("enabled").get<bool>() != key.visibility.enabled ||
        s->at("visibility").at("half_angle_deg").get<double>() != key.visibility.half_angle_deg ||
        s->at("interest").at("A").get<std::string>() != key.interest_a.describe() ||
        s->at("interest").at("B").get<std::string>() != key.interest_b.describe() ||
        s->at("fidelity").at("A").get<std::string>() != key.fidelity_a.describe() ||
        s->at("fidelity").at("B").get<std::string>() != key.fidelity_b.describe() ||
        (s->contains("limits") ? s->at("limits").get<std::string>() : std::string()) != describe_limits(key.intent) ||
        !s->contains("capture") || s->at("capture") != nlohmann::json::parse(capture_keys_json(key).dump()))
        fail(where, "key segment {} was swept with other frames, type, tolerance, visibility, parts, limits or contact keys than the scene says",
             key.index);
    return *s;
}

// The sampling result.json was swept with must be the scene's.
void check_sampling(const nlohmann::json& p, const Scene& scene, const std::string& where) {
    if (p.at("voxel_m").get<double>() != scene.sampling.voxel || p.at("angle_step_deg").get<double>() != scene.sampling.angle_step_deg)
        fail(where, "was swept at {} m / {} deg but the scene asks for {} m / {} deg", p.at("voxel_m").get<double>(),
             p.at("angle_step_deg").get<double>(), scene.sampling.voxel, scene.sampling.angle_step_deg);
    auto range_matches = [&](const char* key, const std::optional<std::array<double, 2>>& range) {
        const auto& node = p.at(key);
        return node.is_null() ? !range : (range && node.get<std::array<double, 2>>() == *range);
    };
    if (!range_matches("x_range_m", scene.sampling.x_range) || !range_matches("y_range_m", scene.sampling.y_range))
        fail(where, "was swept over another x_range / y_range than the scene's");
}

KeySweep key_sweep_of(const nlohmann::json& s, const KeySegment& key, const Scene& scene) {
    KeySweep k;
    k.index = key.index;
    const auto ra = s.at("root_m").at("A").get<std::array<double, 3>>(), rb = s.at("root_m").at("B").get<std::array<double, 3>>();
    k.root_a = Vec3(ra[0], ra[1], ra[2]);
    k.root_b = Vec3(rb[0], rb[1], rb[2]);
    const auto fa = s.at("facing").at("A").get<std::array<double, 2>>(), fb = s.at("facing").at("B").get<std::array<double, 2>>();
    k.describe = {scene.sampling.voxel, scene.sampling.angle_step_deg, Eigen::Vector2d(fa[0], fa[1]), Eigen::Vector2d(fb[0], fb[1])};
    k.poses_tested = json_integer<std::uint64_t>(s.at("poses_tested"));
    const auto& rej = s.at("rejected");
    k.rejected = {json_integer<std::uint64_t>(rej.at("contact")), json_integer<std::uint64_t>(rej.at("dictionary")), json_integer<std::uint64_t>(rej.at("fidelity")),
                  json_integer<std::uint64_t>(rej.at("visibility"))};
    return k;
}

// A group read back must lie inside the range its segment was swept over (result.json's entry):
// a pose outside it was not decided by this sweep, so the file is refused, not trusted.
void check_group(const SolutionGroup& group, const nlohmann::json& entry, const Scene& scene, const fs::path& file) {
    const double h = scene.sampling.voxel;
    const auto x_m = entry.at("range").at("x_m").get<std::array<double, 2>>(), y_m = entry.at("range").at("y_m").get<std::array<double, 2>>();
    const int i_first = int(std::lround(x_m[0] / h)), i_last = int(std::lround(x_m[1] / h));
    const int j_first = int(std::lround(y_m[0] / h)), j_last = int(std::lround(y_m[1] / h));
    for (const PoseRun& r : group.runs())
        if (r.i_first < i_first || r.i_last > i_last || r.j < j_first || r.j > j_last)
            fail(file.string(), "holds poses at x {}..{} m, y {} m (theta index {}), outside the range x [{}, {}] m, y [{}, {}] m the segment was swept over",
                 r.i_first * h, r.i_last * h, r.j * h, r.k, x_m[0], x_m[1], y_m[0], y_m[1]);
    if (group.size() != json_integer<std::uint64_t>(entry.at("solutions")))
        fail(file.string(), "holds {} poses but result.json says the group has {} solutions", group.size(), json_integer<std::uint64_t>(entry.at("solutions")));
}

// Per transitional segment: the frames checked, those where the bodies overlap before and after
// the separation, the largest overlap (voxels and cm^3), and the paper's smoothness objective.
Json transitions_json(const EditResult& edit) {
    Json out = Json::array();
    const double voxel_cm3 = std::pow(edit.voxel * 100, 3);
    for (const TransitionCheck& t : edit.transition_checks)
        out.push_back({{"segment", fmt::format("transition {}", t.timeline_segment / 2)},
                       {"frames_checked", t.frames},
                       {"frames_overlapping", t.overlapping},
                       {"max_overlap_voxels", t.max_overlap},
                       {"max_overlap_cm3", double(t.max_overlap) * voxel_cm3},
                       {"separation_rounds", t.rounds},
                       {"smoothness", t.smoothness},
                       {"before_separation", {{"frames_overlapping", t.overlapping_before},
                                              {"max_overlap_voxels", t.max_overlap_before},
                                              {"max_overlap_cm3", double(t.max_overlap_before) * voxel_cm3},
                                              {"smoothness", t.smoothness_before}}}});
    return out;
}

}  // namespace

Json result_header(const Scene& scene, const std::string& backend, const std::string& device) {
    Json json;
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
                                       {"w_A", w.w_a}, {"w_B", w.w_b}, {"mu", w.mu}, {"natural", w.natural}, {"a_rotations_deg", w.a_rotations_deg}}}};
    return json;
}

Json sweep_segment_json(const Scene& scene, const KeySegment& segment, const SweepProblem& problem, const SweepResult& result,
                        const SolutionGroup& group, std::uint64_t limited, const SegmentFiles& files, const Json& timings) {
    Json s;
    s["index"] = segment.index;
    s["type"] = segment.type.name();
    s["frames_a"] = {segment.a[0], segment.a[1]};
    s["frames_b"] = {segment.b[0], segment.b[1]};
    s["normalised_frames"] = problem.frames();
    s["poses_tested"] = problem.range.size();
    s["solutions"] = group.size();
    s["rejected"] = {{"contact", result.rejected[0]}, {"dictionary", result.rejected[1]}, {"fidelity", result.rejected[2]},
                     {"visibility", result.rejected[3]}, {"limits", limited}};
    s["range"] = {{"x_m", {problem.range.i_first * problem.voxel, problem.range.i_last * problem.voxel}},
                  {"y_m", {problem.range.j_first * problem.voxel, problem.range.j_last * problem.voxel}},
                  {"z_m", {problem.range.z_first * problem.voxel, problem.range.z_last * problem.voxel}},
                  {"angles", problem.range.angles}};
    s["root_m"] = {{"A", vec3(problem.a.root)}, {"B", vec3(problem.b.root)}};
    s["facing"] = {{"A", {problem.a.facing.x(), problem.a.facing.y()}}, {"B", {problem.b.facing.x(), problem.b.facing.y()}}};
    s["tolerance"] = segment.tolerance;
    s["visibility"] = {{"enabled", segment.visibility.enabled}, {"half_angle_deg", segment.visibility.half_angle_deg},
                       {"range_m", segment.visibility.range}};
    s["interest"] = {{"A", segment.interest_a.describe()}, {"B", segment.interest_b.describe()}};
    s["fidelity"] = {{"A", segment.fidelity_a.describe()}, {"B", segment.fidelity_b.describe()}};
    s["capture"] = capture_keys_json(segment);
    if (segment.intent.limits()) s["limits"] = describe_limits(segment.intent);
    s["files"] = {{"group", fmt::format("segment_{}/group.vdb", segment.index)},
                  {"group_bytes", files.group_bytes},
                  {"group_summary", fmt::format("segment_{}/group_summary.json", segment.index)},
                  {"solutions", files.csv ? Json(fmt::format("segment_{}/solutions.csv", segment.index)) : Json(nullptr)},
                  {"feasibility", files.maps ? nlohmann::json(fmt::format("segment_{}/feasibility/", segment.index)) : nlohmann::json(nullptr)},
                  {"feasibility_files", files.feasibility_files}};
    if (scene.truth) s["truth"] = truth_json(scene, problem, group);
    if (!timings.is_null()) s["timings_s"] = timings;
    return s;
}

namespace {

Json natural_json(const NaturalReport& n) {
    Json out = {{"weight", n.weight}, {"chosen", natural_terms_json(n.chosen)}};
    out["runner_up"] = nullptr;
    if (n.has_runner_up) {
        out["runner_up"] = natural_terms_json(n.runner_up);
        out["runner_up"]["pose"] = solution_json(n.runner_up_pose);
    }
    if (n.has_truth) out["truth"] = natural_terms_json(n.truth);
    return out;
}

}  // namespace

void add_edit(Json& json, const EditResult& edit, const EditFiles& files) {
    for (std::size_t i = 0; i < edit.keys.size(); ++i) {
        const KeyEdit& k = edit.keys[i];
        auto& s = json["segments"][i];
        s["chosen"] = solution_json(k.chosen);
        s["chosen"]["captured_placement"] = k.captured;
        if (s.contains("truth")) {
            const double dx = k.chosen.x - s["truth"]["x"].get<double>(), dy = k.chosen.y - s["truth"]["y"].get<double>();
            s["truth"]["chosen_error_m"] = std::hypot(dx, dy);
            s["truth"]["chosen_error_deg"] = angles::degrees_apart(k.chosen.theta_deg, s["truth"]["theta_deg"].get<double>());
        }
        for (const NaturalReport& n : edit.natural)
            if (n.key == k.index) s["natural"] = natural_json(n);
        for (const TouchUp& t : edit.touch_ups)
            if (t.key == k.index) s["touch_up"] = {{"touches", t.touches}, {"moved_m", t.moved_m}, {"note", t.note.empty() ? Json(nullptr) : Json(t.note)}};
        s["edit"] = {{"a_rotation_deg", angles::degrees(k.a_rotation_rad)},
                     {"a_translation_m", {k.a_translation.x(), k.a_translation.y()}},
                     {"root_a_m", {k.root_a.x(), k.root_a.y()}},
                     {"root_b_m", {k.root_b.x(), k.root_b.y()}},
                     {"yaw_a_deg", angles::degrees(k.yaw_a)},
                     {"yaw_b_deg", angles::degrees(k.yaw_b)}};
    }
    json["dp"] = {{"cost", edit.choice.cost}, {"unary", edit.choice.unary}, {"pairwise", edit.choice.pairwise}, {"choices_tried", edit.choices_tried}};
    Json paths = Json::array();
    for (const PathReport& p : edit.paths)
        paths.push_back({{"segment", fmt::format("transition {}", p.timeline_segment / 2)},
                         {"object", p.object == 0 ? "A" : "B"},
                         {"frames", p.frames},
                         {"root_residual", p.root_cost},
                         {"facing_residual", p.facing_cost},
                         {"max_shift_m", p.max_shift_m}});
    json["paths"] = paths;
    json["transitions"] = transitions_json(edit);
    json["output"] = {{"frames", edit.timeline.length()},
                      {"frame_checks", "frames.csv"},
                      {"transforms", "transforms.json"},
                      {"meshes", files.frames ? nlohmann::json("frames/NNNN.ply") : nlohmann::json(nullptr)},
                      {"mesh_files", files.mesh_files},
                      {"scene", files.glb ? nlohmann::json("scene.glb") : nlohmann::json(nullptr)},
                      {"scene_bytes", files.glb_bytes},
                      {"scene_fps", files.glb ? nlohmann::json(files.glb_fps) : nlohmann::json(nullptr)},
                      {"bvh", files.bvh},
                      {"characters", files.characters},
                      {"paths", {"paths.svg", "paths.png"}},
                      {"views", files.views}};
    if (files.obj_files > 0) json["output"]["obj_files"] = files.obj_files;
}

SweepRecord read_sweep_folder(const fs::path& dir, const Scene& scene) {
    const fs::path file = dir / "result.json";
    const std::string where = file.string();
    if (!fs::exists(file)) fail(where, "cannot open: --from-sweep needs the folder written by `amhv sweep` (or `amhv edit`)");
    const std::string text = read_file_bytes(file, std::uintmax_t(1) << 30);
    nlohmann::json json;
    try {
        json = nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {
        fail(where, "is {}", json_problem(e));
    }
    SweepRecord record;
    try {
        check_sampling(json.at("parameters"), scene, where);
        for (const KeySegment& key : scene.segments) {
            const nlohmann::json& s = matching_entry(json.at("segments"), key, where);
            KeySweep k = key_sweep_of(s, key, scene);
            const fs::path group_file = dir / fmt::format("segment_{}", key.index) / "group.vdb";
            const auto z_m = s.at("range").at("z_m").get<std::array<double, 2>>();
            PoseRange heights;
            heights.z_first = int(std::lround(z_m[0] / scene.sampling.voxel));
            heights.z_last = int(std::lround(z_m[1] / scene.sampling.voxel));
            k.group = read_group_vdb(group_file, group_lattice(scene, key.index, heights));
            check_group(k.group, s, scene, group_file);
            record.segments.push_back(Json::parse(s.dump()));
            record.sweeps.push_back(std::move(k));
        }
    } catch (const nlohmann::json::exception& e) {
        fail(where, "is not a sweep's result.json ({})", json_problem(e));
    }
    return record;
}

void write_json_file(const fs::path& path, const Json& json) {
    write_file(path, json.dump(2) + '\n');
}

}  // namespace amhv::results
