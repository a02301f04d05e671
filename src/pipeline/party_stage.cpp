#include "src/pipeline/party_stage.hpp"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "src/core/angles.hpp"
#include "src/core/clock.hpp"
#include "src/core/error.hpp"
#include "src/io/json_problem.hpp"
#include "src/edit/frame_check.hpp"
#include "src/results/edit_files.hpp"
#include "src/results/key_views.hpp"
#include "src/results/party_files.hpp"
#include "src/results/scene_glb.hpp"

namespace amhv::pipeline {

namespace fs = std::filesystem;

namespace {

std::size_t index_of(const std::vector<std::string>& names, const std::string& name) {
    return std::size_t(std::find(names.begin(), names.end(), name) - names.begin());
}

// Where the edit put an object at each output frame, as a group member reads it.
std::vector<MemberFrame> member_frames(const std::vector<ObjectFrameEdit>& frames) {
    std::vector<MemberFrame> out;
    out.reserve(frames.size());
    for (const ObjectFrameEdit& f : frames) out.push_back({f.source, f.yaw, f.translation, f.lift, f.edited_root, f.edited_facing});
    return out;
}

// The output frames [first, last] where `frames` (an object's, along the output) play source frames
// `range`: one run, since an object's source frames never go back along the output.
std::array<int, 2> output_range(const std::vector<ObjectFrameEdit>& frames, const std::array<int, 2>& range) {
    int first = -1, last = -1;
    for (int k = 0; k < int(frames.size()); ++k)
        if (frames[std::size_t(k)].source >= range[0] && frames[std::size_t(k)].source <= range[1]) {
            if (first < 0) first = k;
            last = k;
        }
    return {first, last};
}

// A stage scene's pair: the placed side (the anchor alone, or the group) is fixed; its w_A infinite.
Scene stage_scene_base(const Scene& scene, const SceneObject& a, const std::string& newcomer) {
    Scene s;
    s.file = scene.file;
    s.sampling = scene.sampling;
    s.weights = scene.weights;
    s.weights.w_a = std::numeric_limits<double>::infinity();
    s.weights.a_rotations_deg = {0.0};
    s.a = a;
    s.b = scene.object(newcomer);
    s.b.anchor = false;
    s.objects = {s.a, s.b};
    s.order = {s.a.name, s.b.name};
    s.a_sets_time = true;
    return s;
}

// The truth of `newcomer` for a stage whose A is the scene frame (a group): the anchor's placement
// composed with the newcomer's truth in the anchor's capture frame.
std::optional<Placement> stage_truth(const Scene& scene, const std::string& newcomer, bool group) {
    const auto it = scene.truths.find(newcomer);
    if (it == scene.truths.end()) return std::nullopt;
    if (!group) return it->second;
    const Placement& anchor = scene.object(scene.order.front()).placement;
    const double psi = angles::radians(anchor.yaw_deg);
    Placement t;
    t.x = std::cos(psi) * it->second.x - std::sin(psi) * it->second.y + anchor.x;
    t.y = std::sin(psi) * it->second.x + std::cos(psi) * it->second.y + anchor.y;
    t.yaw_deg = anchor.yaw_deg + it->second.yaw_deg;
    return t;
}

// The key segments that place `newcomer`, their placed side's frames as output frames of the edit so
// far (`placed`: null for the first stage, whose placed side is the anchor itself).
std::vector<KeySegment> stage_segments(const Scene& scene, const std::string& newcomer, const PartyEdit* placed, const std::string& group) {
    std::vector<KeySegment> out;
    for (KeySegment k : scene.segments) {
        if (k.pair[1] != newcomer) continue;
        const std::string where = fmt::format("{}:{}: segments[{}]", scene.file.string(), k.line, k.index);
        if (placed) {
            const std::array<int, 2> range = output_range(placed->frames[index_of(placed->names, k.pair[0])], k.a);
            if (range[0] < 0)
                fail(where, "object {}'s frames {}..{} are not in the scene placed so far ({}); {} cannot be placed against them", k.pair[0], k.a[0],
                     k.a[1], fmt::join(placed->names, ", "), newcomer);
            k.a = range;
            if (!out.empty() && k.a[0] <= out.back().a[1])
                fail(where, "object {}'s frames {}..{} play at output frames {}..{} of the scene placed so far, which overlap or come before "
                     "key segment {}'s; the key segments that place {} must follow each other in time",
                     k.pair[0], scene.segments[std::size_t(k.index - 1)].a[0], scene.segments[std::size_t(k.index - 1)].a[1], k.a[0], k.a[1],
                     out.back().index, newcomer);
        }
        k.pair = {placed ? group : k.pair[0], newcomer};
        out.push_back(k);
    }
    return out;
}

// A placed group of every object placed so far, `partner` first.
std::unique_ptr<ObjectSource> make_group(const PartyEdit& placed, const std::string& partner, const SceneObject& spec,
                                         std::vector<std::unique_ptr<ObjectSource>>& sources, const std::vector<std::string>& order) {
    std::vector<GroupMember> members;
    std::vector<std::size_t> indices{index_of(placed.names, partner)};
    for (std::size_t o = 0; o < placed.names.size(); ++o)
        if (placed.names[o] != partner) indices.push_back(o);
    for (std::size_t o : indices) members.push_back({sources[index_of(order, placed.names[o])].get(), member_frames(placed.frames[o])});
    return std::make_unique<ObjectSource>(spec, std::move(members));
}

SceneObject group_spec(const Scene& scene, const PartyEdit& placed) {
    SceneObject g;
    g.name = fmt::format("{}", fmt::join(placed.names, "+"));
    g.anchor = true;
    g.fps = scene.object(scene.order.front()).fps;
    g.frame_first = 0;
    g.frame_last = placed.length() - 1;
    return g;
}

// Sweeps one stage's key segments, each against a group whose partner is its own pair's.
SweepStage sweep_stage(const PartyStage& stage, const Scene& scene, const PartyEdit* placed, std::vector<std::unique_ptr<ObjectSource>>& sources,
                       std::vector<std::unique_ptr<ObjectSource>>& groups, Backends& backends, const fs::path& out, const EditRunOptions& options) {
    SweepStage all;
    ObjectSource& b = *sources[index_of(scene.order, stage.object)];
    for (const KeySegment& k : stage.scene.segments) {
        ObjectSource* a = sources[index_of(scene.order, scene.order.front())].get();
        if (placed) {
            const std::string& partner = scene.segments[std::size_t(k.index - 1)].pair[0];
            groups.push_back(make_group(*placed, partner, stage.scene.a, sources, scene.order));
            a = groups.back().get();
        }
        SweepStage one = run_sweep_stage(stage.scene, *a, b, backends.voxeliser, backends.sweeper, out, {k.index, options.maps, options.timings, options.csv});
        all.sweeps.insert(all.sweeps.end(), std::make_move_iterator(one.sweeps.begin()), std::make_move_iterator(one.sweeps.end()));
        for (auto& s : one.segments) all.segments.push_back(std::move(s));
        all.mhv_seconds += one.mhv_seconds;
        all.sweep_seconds += one.sweep_seconds;
        all.output_seconds += one.output_seconds;
    }
    return all;
}

// The edit so far with `stage` added: the placed objects follow the group's frames along the stage's
// output; the newcomer its own.
void add_stage(PartyEdit& party, const PartyStage& stage, bool first) {
    if (first) {
        party.names = {stage.scene.a.name, stage.object};
        party.frames = {stage.edit.frames[0], stage.edit.frames[1]};
        return;
    }
    for (auto& frames : party.frames) {
        std::vector<ObjectFrameEdit> along;
        along.reserve(stage.edit.frames[0].size());
        for (const ObjectFrameEdit& g : stage.edit.frames[0]) along.push_back(frames[std::size_t(g.source)]);
        frames = std::move(along);
    }
    party.names.push_back(stage.object);
    party.frames.push_back(stage.edit.frames[1]);
}

// The pose that came nearest in the first empty group of a stage, for its error (result.json is not
// kept when the edit stops, and `amhv probe` takes two objects).
std::string nearest_miss(const SweepStage& sweep) {
    for (const results::Json& s : sweep.segments) {
        if (!s.contains("near_misses") || s["near_misses"].empty()) continue;
        const results::Json& m = s["near_misses"][0];
        return fmt::format("; its nearest miss, x = {:.2f} m, y = {:.2f} m, theta = {:.0f} deg, fails {} on {} of {} frames", m["x"].get<double>(),
                           m["y"].get<double>(), m["theta_deg"].get<double>(), m["fails"].get<std::string>(), m["frames_failed"].size(),
                           json_integer<int>(m["frames"]));
    }
    return "";
}

// One stage's edit; an error names the object being placed and the ones it is placed against.
EditResult edit_stage(const PartyStage& stage, ObjectSource& a, ObjectSource& b, Backends& backends, const EditOptions& options) {
    try {
        return edit_scene(stage.scene, stage.sweep.sweeps, a, b, backends.voxeliser, options);
    } catch (const Error& e) {
        throw Error(fmt::format("placing {} against {}: {}{}", stage.object, fmt::join(stage.against, ", "), e.what(), nearest_miss(stage.sweep)));
    }
}

// The middle output frame of every key segment (a stage's output frames are the final ones: the
// later stages keep the group's timing), with its pair.
std::vector<KeyView> key_views(const Scene& scene, const PartyEdit& party) {
    std::vector<KeyView> views;
    for (const PartyStage& stage : party.stages)
        for (const TimelineSegment& segment : stage.edit.timeline.segments) {
            if (!segment.key || segment.length == 0) continue;
            const KeySegment& key = scene.segments[std::size_t(segment.key - 1)];
            views.push_back({segment.key, segment.first + segment.length / 2, index_of(party.names, key.pair[0]), index_of(party.names, key.pair[1]),
                             segment.first, segment.first + segment.length - 1});
        }
    std::sort(views.begin(), views.end(), [](const KeyView& x, const KeyView& y) { return x.key < y.key; });
    return views;
}

// Every object with the key segments it takes part in (the output frames of each), for paths.svg.
std::vector<PathsObject> paths_objects(const Scene& scene, const PartyEdit& party) {
    std::vector<PathsObject> objects;
    for (std::size_t o = 0; o < party.names.size(); ++o) objects.push_back({party.names[o], &party.frames[o], {}});
    for (const PartyStage& stage : party.stages)
        for (const TimelineSegment& segment : stage.edit.timeline.segments) {
            if (!segment.key || segment.length == 0) continue;
            for (const std::string& name : scene.segments[std::size_t(segment.key - 1)].pair)
                objects[index_of(party.names, name)].keys.push_back({segment.key, segment.first, segment.length});
        }
    for (auto& object : objects) std::sort(object.keys.begin(), object.keys.end());
    return objects;
}

}  // namespace

PartyEdit edit_party(const Scene& scene, std::vector<std::unique_ptr<ObjectSource>>& sources, Backends& backends, const fs::path& out,
                     const EditRunOptions& options) {
    PartyEdit party;
    std::vector<std::unique_ptr<ObjectSource>> groups;
    for (std::size_t n = 1; n < scene.order.size(); ++n) {
        const bool first = n == 1;
        PartyStage stage;
        stage.object = scene.order[n];
        stage.against.assign(scene.order.begin(), scene.order.begin() + std::ptrdiff_t(n));
        std::cout << fmt::format("placing {} against {}\n", stage.object, fmt::join(stage.against, ", "));
        const SceneObject a = first ? scene.object(scene.order.front()) : group_spec(scene, party);
        stage.scene = stage_scene_base(scene, a, stage.object);
        stage.scene.truth = stage_truth(scene, stage.object, !first);
        stage.scene.segments = stage_segments(scene, stage.object, first ? nullptr : &party, a.name);
        groups.clear();
        stage.sweep = sweep_stage(stage, scene, first ? nullptr : &party, sources, groups, backends, out, options);
        EditOptions edit_options;
        edit_options.allow_empty = options.allow_empty;
        edit_options.allow_transition_overlap = options.allow_transition_overlap;
        edit_options.fixed_a = true;
        ObjectSource& a_source = first ? *sources.front() : *groups.front();
        stage.edit = edit_stage(stage, a_source, *sources[n], backends, edit_options);
        add_stage(party, stage, first);
        party.stages.push_back(std::move(stage));
    }
    return party;
}

std::unique_ptr<ObjectSource> placed_group(const Scene& scene, const PartyEdit& placed, const std::string& partner,
                                           std::vector<std::unique_ptr<ObjectSource>>& sources) {
    return make_group(placed, partner, group_spec(scene, placed), sources, scene.order);
}

std::vector<PairCheck> check_pairs(const PartyEdit& edit, std::vector<std::unique_ptr<ObjectSource>>& sources, double voxel, Voxeliser& voxeliser) {
    std::vector<int> frames(std::size_t(edit.length()));
    for (int k = 0; k < edit.length(); ++k) frames[std::size_t(k)] = k;
    // The first placement checked its pair at every frame, and the later ones keep its timing.
    const std::vector<FrameCheck>* first = edit.stages.empty() ? nullptr : &edit.stages.front().edit.frame_checks;
    std::vector<PairCheck> out;
    for (std::size_t i = 0; i < edit.names.size(); ++i)
        for (std::size_t j = i + 1; j < edit.names.size(); ++j) {
            if (i == 0 && j == 1 && first && int(first->size()) == edit.length()) {
                for (const FrameCheck& c : *first) out.push_back({c.frame, i, j, c.overlap, c.gap_m});
                continue;
            }
            EditResult pair;
            pair.frames = {edit.frames[i], edit.frames[j]};
            for (const FrameCheck& c : check_frames(pair, frames, *sources[i], *sources[j], voxel, voxeliser))
                out.push_back({c.frame, i, j, c.overlap, c.gap_m});
        }
    std::sort(out.begin(), out.end(), [](const PairCheck& x, const PairCheck& y) {
        return std::tie(x.frame, x.first, x.second) < std::tie(y.frame, y.first, y.second);
    });
    return out;
}

PartyEdit edit_party_into(const Scene& scene, Backends& backends, const fs::path& out, const EditRunOptions& options,
                          std::chrono::steady_clock::time_point start) {
    if (!options.from_sweep.empty())
        fail(scene.file.string(), "--from-sweep reads a two-object sweep; a scene of {} objects sweeps each object against the ones placed before it, "
             "so it is edited in one run", scene.objects.size());
    std::vector<std::unique_ptr<ObjectSource>> sources;  // in placement order
    for (const std::string& name : scene.order) sources.push_back(std::make_unique<ObjectSource>(scene.object(name), backends.skinner));
    PartyEdit party = edit_party(scene, sources, backends, out, options);
    auto t0 = std::chrono::steady_clock::now();
    const std::vector<PairCheck> checks = check_pairs(party, sources, scene.sampling.voxel, backends.voxeliser);
    const double check_seconds = seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    results::PartyFiles files;
    results::write_party_transforms_json(out / "transforms.json", scene, party.names, party.frames);
    results::write_pair_checks_csv(out / "frames.csv", party.names, checks, scene.sampling.voxel);
    std::vector<ObjectSource*> pointers;
    for (auto& s : sources) pointers.push_back(s.get());
    if (options.frames) files.mesh_files = results::write_party_frames(out / "frames", party.names, party.frames, pointers);
    std::vector<const std::vector<ObjectFrameEdit>*> frame_lists;
    for (const auto& frames : party.frames) frame_lists.push_back(&frames);
    std::vector<KeyView> views = key_views(scene, party);
    choose_meeting_frames(scene, views, frame_lists, pointers);
    const std::vector<KeyCamera> cameras = write_key_views(out / "views", scene, party.names, views, frame_lists, pointers);
    write_eye_views(out / "views", scene, party.names, views, frame_lists, pointers);
    write_paths_picture(out / "paths.svg", out / "paths.png", paths_objects(scene, party));
    const std::vector<std::string> bvh = write_edited_bvh(out, party.names, frame_lists, pointers);
    const std::vector<std::string> characters = write_edited_characters(out, party.names, frame_lists, pointers);
    results::Json outputs = {{"frames", options.frames}, {"bvh", bvh}, {"characters", characters}, {"scene_glb", nullptr}, {"views", key_views_json(views, cameras, party.names)}};
    if (options.glb) {
        std::vector<GlbObject> objects;
        for (std::size_t o = 0; o < party.names.size(); ++o) objects.push_back({party.names[o], pointers[o], &party.frames[o]});
        const double fps = scene.object(scene.order.front()).fps;
        outputs["scene_glb"] = {{"bytes", write_scene_glb(out / "scene.glb", objects, fps).bytes}, {"fps", fps}};
    }
    results::Json json = results::result_header(scene, backends.backend, backends.device);
    json["order"] = scene.order;
    json["order_rule"] = scene.order_rule;
    json["stages"] = results::Json::array();
    for (const PartyStage& stage : party.stages) {
        results::Json s = {{"object", stage.object}, {"against", stage.against}, {"segments", stage.sweep.segments}};
        results::add_edit(s, stage.edit, {});
        s.erase("output");  // the files are the whole scene's ("outputs" below), not the stage's
        json["stages"].push_back(s);
    }
    json["output_frames"] = party.length();
    json["pairs"] = results::pair_summary(party.names, checks, scene.sampling.voxel);
    json["outputs"] = outputs;
    if (options.timings) {
        double mhv = 0, sweep = 0, dp = 0, path = 0, check = check_seconds;
        for (const PartyStage& s : party.stages)
            mhv += s.sweep.mhv_seconds + s.edit.roots_seconds, sweep += s.sweep.sweep_seconds, dp += s.edit.dp_seconds, path += s.edit.path_seconds,
                check += s.edit.check_seconds;
        json["timings_s"] = {{"mhv", mhv}, {"sweep", sweep}, {"dp", dp}, {"path", path}, {"check", check}, {"output", seconds_since(t0)},
                             {"total", seconds_since(start)}};
    }
    results::write_json_file(out / "result.json", json);
    return party;
}

}  // namespace amhv::pipeline
