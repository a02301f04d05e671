#include "src/io/files.hpp"
#include "src/scene/scene.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <set>
#include <sstream>

#include <fmt/ranges.h>
#include <toml++/toml.h>

#include "src/core/error.hpp"
#include "src/core/normalise.hpp"
#include "src/io/bvh.hpp"
#include "src/body/skeleton_roles.hpp"
#include "src/io/character_file.hpp"
#include "src/io/toml_reader.hpp"

namespace amhv {

namespace fs = std::filesystem;

namespace {


std::string resolve(const fs::path& scene_file, const std::string& path) {
    fs::path p(path);
    if (p.is_relative()) p = scene_file.parent_path() / p;
    return p.lexically_normal().string();
}

// floor = "auto" or a height in metres (scene axes): where the capture's floor is, so that it is
// moved to z = 0.
void read_floor(TableReader& t, SceneObject& o) {
    const toml::node* node = t.get("floor");
    if (!node) return;
    if (node->is_string()) {
        if (node->value<std::string>().value() != "auto") t.error("floor", node, "must be \"auto\" or a height in metres");
        o.floor_auto = true;
        return;
    }
    o.floor_m = t.number("floor", -100, 100);
    o.units.lift = -*o.floor_m;
}

// A character's frames: its animation sampled at `fps` (default 30), frame 0 at the animation's start.
void read_character_frames(TableReader& t, const toml::node* source_node, SceneObject& o) {
    if (!is_file(o.character)) t.error("character", source_node, "'{}' is not a file", o.character);
    o.animation = t.string("animation");
    const std::optional<double> fps = t.number("fps", 1, 1000, false);
    try {
        o.character_file = std::make_shared<const CharacterFile>(read_character(o.character, o.animation, fps));
    } catch (const Error& e) {
        fail(t.where("character", source_node), "{}", e.what());
    }
    const CharacterFile& file = *o.character_file;
    o.animation = file.animation;
    o.fps = file.fps;
    // Roles given by joint name, for rigs whose names do not say.
    TableReader joints = t.table("joints");
    for (const std::string& name : joints.keys_in_file_order()) {
        const std::string role = *joints.string(name);
        const auto& vocabulary = role_vocabulary();
        if (std::find(vocabulary.begin(), vocabulary.end(), role) == vocabulary.end())
            joints.error(name, joints.get(name), "'{}' is not a role (roles: {})", printable(role), fmt::join(vocabulary, ", "));
        if (std::none_of(file.nodes.begin(), file.nodes.end(), [&](const CharacterNode& n) { return n.name == name; }))
            joints.error(name, joints.get(name), "names no joint of {}", o.character);
        o.joint_roles[name] = role;
    }
    joints.finish();
    o.frame_first = 0;
    o.frame_last = file.frame_count() - 1;
}

SceneObject read_object(TableReader& objects, const std::string& name) {
    TableReader t = objects.table(name, true);
    SceneObject o;
    o.name = name;
    o.anchor = t.boolean("anchor").value_or(false);
    auto meshes = t.string("meshes");
    auto bvh = t.string("bvh");
    auto character = t.string("character");
    if (int(meshes.has_value()) + int(bvh.has_value()) + int(character.has_value()) != 1)
        t.error("meshes", nullptr, "give exactly one of 'meshes' (a mesh sequence), 'bvh' (a take) and 'character' (an animated glTF, FBX or Collada file)");
    if (meshes) o.meshes = resolve(t.file(), *meshes);
    if (bvh) o.bvh = resolve(t.file(), *bvh);
    if (character) o.character = resolve(t.file(), *character);
    // A BVH: CMU's unit and y up; a character: glTF's metres and y up; meshes: metres, z up.
    const std::string default_unit = bvh ? "0.0564444" : "m", default_up = (bvh || character) ? "y" : "z";
    o.units.metres_per_unit = parse_unit(t.string("unit").value_or(default_unit), t.where("unit", t.get("unit")));
    o.units.up = parse_up_axis(t.string("up").value_or(default_up), t.where("up", t.get("up")));
    if (auto axes = t.string("axes")) {
        if (t.has("up")) t.error("axes", t.get("axes"), "give one of 'up' and 'axes' ('up' is shorthand for an axes map)");
        o.units.axes = parse_axes(*axes, t.where("axes", t.get("axes")));
    }
    read_floor(t, o);
    if (auto labels = t.string("labels")) {
        if (!meshes) t.error("labels", t.get("labels"), "a {} body already has part labels (head, torso, left_hand, ...)", bvh ? "BVH" : "character's");
        o.labels = resolve(t.file(), *labels);
    }
    if (auto track = t.string("track")) o.track = resolve(t.file(), *track);
    if (auto root = t.string("files_root")) {
        if (!meshes) t.error("files_root", t.get("files_root"), "only a mesh sequence names other files (materials, textures)");
        o.files_root = resolve(t.file(), *root);
        if (!is_folder(o.files_root)) t.error("files_root", t.get("files_root"), "'{}' is not a folder", o.files_root.string());
    }
    o.facing_deg = t.number("facing_deg", -360, 360);
    TableReader placement = t.table("placement");
    o.placement.x = placement.number("x", -1e4, 1e4).value_or(0);
    o.placement.y = placement.number("y", -1e4, 1e4).value_or(0);
    o.placement.yaw_deg = placement.number("yaw_deg", -360, 360).value_or(0);
    placement.finish();

    // The frames available.
    const toml::node* source_node = t.get(bvh ? "bvh" : character ? "character" : "meshes");
    if (character) {
        read_character_frames(t, source_node, o);
    } else if (bvh) {
        if (!is_file(o.bvh)) t.error("bvh", source_node, "'{}' is not a file", o.bvh);
        if (auto tpose = t.string("tpose")) o.tpose = parse_tpose(*tpose, t.where("tpose", t.get("tpose")));
        if (auto body = t.string("body")) o.body = parse_body_kind(*body, t.where("body", t.get("body")));
        const std::optional<double> fps = t.number("fps", 1, 1000, false);
        const BvhMotion motion = load_bvh(o.bvh, BvhLoadOptions{o.tpose, fps.value_or(0)});
        o.tpose = motion.first_frame > 0 ? TPose::Skip : TPose::Keep;  // what auto found
        o.fps = motion.fps();
        o.frame_first = motion.first_frame;
        o.frame_last = motion.frame_count - 1;
    } else {
        std::vector<FrameFile> frames;
        try {
            frames = list_frames(o.meshes, std::nullopt);
        } catch (const Error& e) {
            fail(t.where("meshes", source_node), "{}", e.what());
        }
        if (frames.empty()) t.error("meshes", source_node, "'{}' names no mesh file", o.meshes);
        o.frame_first = frames.front().number;
        o.frame_last = frames.back().number;
    }
    if (!character && t.has("animation")) t.error("animation", t.get("animation"), "only a character has animations");
    if (!character && t.has("joints")) t.error("joints", t.get("joints"), "only a character's joints are given roles by name");
    if (!bvh) {
        if (t.has("tpose")) t.error("tpose", t.get("tpose"), "only a BVH object has a T-pose frame");
        if (t.has("body")) t.error("body", t.get("body"), "only a BVH object gets a body built for it (a mesh sequence is its own body)");
        if (!character)
            if (auto fps = t.number("fps", 0, 1000, false)) o.fps = *fps;
    }
    // The frames the edit covers (default: all there are); key segments must lie inside.
    if (auto range = t.frame_range("frames")) {
        if ((*range)[0] < o.frame_first || (*range)[1] > o.frame_last)
            t.error("frames", t.get("frames"), "frames {}..{} are beyond the {} frames {}..{}", (*range)[0], (*range)[1],
                    bvh ? "BVH's" : character ? "animation's" : "sequence's",
                    o.frame_first, o.frame_last);
        o.frame_first = (*range)[0];
        o.frame_last = (*range)[1];
    }
    t.finish();
    return o;
}

PartSpec read_part(TableReader& parent, const std::string& key, const SceneObject& object, PartSpec fallback, bool fidelity) {
    const toml::node* node = parent.get(key);
    if (!node) return fallback;
    PartSpec part;
    if (node->is_string()) {
        std::string word = node->value<std::string>().value();
        if (word == "whole") part.kind = PartSpec::Kind::Whole;
        else if (word == "whole_minus_interest" && fidelity) part.kind = PartSpec::Kind::WholeMinusInterest;
        else parent.error(key, node, "'{}' is not a part; use \"whole\"{}, or a table with meshes, parts, parts_except or box", word,
                          fidelity ? ", \"whole_minus_interest\"" : "");
        return part;
    }
    if (!node->is_table()) parent.error(key, node, "must be a string or a table");
    TableReader t(*node->as_table(), parent.key_path(key), parent.file());
    int given = int(t.has("meshes")) + int(t.has("parts")) + int(t.has("parts_except")) + int(t.has("box"));
    if (given != 1) t.error("", node, "give exactly one of meshes, parts, parts_except and box");
    if (auto meshes = t.string("meshes")) {
        part.kind = PartSpec::Kind::Meshes;
        part.meshes = resolve(t.file(), *meshes);
    } else if (t.has("parts") || t.has("parts_except")) {
        const bool except = t.has("parts_except");
        part.kind = except ? PartSpec::Kind::PartsExcept : PartSpec::Kind::Parts;
        part.labels = t.strings(except ? "parts_except" : "parts");
        if (object.bvh.empty() && object.character.empty() && object.labels.empty())
            t.error(except ? "parts_except" : "parts", node, "object {} has no part labels (give it 'labels' or use a BVH)", object.name);
    } else {
        TableReader box = t.table("box");
        auto min = box.numbers<3>("min"), max = box.numbers<3>("max");
        if (!min || !max) box.error("min", nullptr, "a box needs min = [x, y, z] and max = [x, y, z] (metres, z up)");
        part.kind = PartSpec::Kind::Box;
        part.box.min = Vec3((*min)[0], (*min)[1], (*min)[2]);
        part.box.max = Vec3((*max)[0], (*max)[1], (*max)[2]);
        if (!(part.box.min.array() < part.box.max.array()).all()) box.error("max", box.get("max"), "must be above min on every axis");
        box.finish();
    }
    t.finish();
    return part;
}

void read_parts(TableReader& segment, const std::string& key, const Scene& scene, const std::array<std::string, 2>& pair, PartSpec& a,
                PartSpec& b, PartSpec fallback) {
    TableReader t = segment.table(key);
    a = read_part(t, pair[0], scene.object(pair[0]), fallback, key == "fidelity");
    b = read_part(t, pair[1], scene.object(pair[1]), fallback, key == "fidelity");
    t.finish();
}

}  // namespace

std::string PartSpec::describe() const {
    auto join = [](const std::vector<std::string>& v) {
        std::string s;
        for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
        return s;
    };
    switch (kind) {
        case Kind::Whole: return "whole";
        case Kind::WholeMinusInterest: return "whole_minus_interest";
        case Kind::Meshes: return "meshes " + meshes;
        case Kind::Parts: return "parts " + join(labels);
        case Kind::PartsExcept: return "parts_except " + join(labels);
        default: return fmt::format("box [{}, {}, {}] - [{}, {}, {}]", box.min.x(), box.min.y(), box.min.z(), box.max.x(), box.max.y(), box.max.z());
    }
}

int Sampling::angles() const { return int(std::lround(360.0 / angle_step_deg)); }

namespace {

// prefer = { distance_m, thetaA_deg, thetaB_deg, weight } and limits = { distance_m = [lo, hi],
// thetaA_deg = [lo, hi], thetaB_deg = [lo, hi] }, every key optional.
void read_real_capture_keys(TableReader& t, KeySegment& k) {
    if (k.type.near) {
        // How near: A's part grows by it, as contact_tolerance grows it (docs/method.md section 5).
        if (t.has("contact_tolerance"))
            t.error("contact_tolerance", t.get("contact_tolerance"), "does not apply to type near: within_m says how near the parts come");
        const auto within = t.number("within_m", 0, 0.5);
        if (!within || !(*within > 0))
            t.error("within_m", within ? t.get("within_m") : t.get("type"),
                    "type near needs within_m, the distance in metres (above 0, at most 0.5) within which the parts pass");
        k.contact_tolerance = *within;
    } else {
        if (t.has("within_m")) t.error("within_m", t.get("within_m"), "applies to type near only (this key segment is {})", k.type.name());
        k.contact_tolerance = t.number("contact_tolerance", 0, 0.5).value_or(0);
    }
    if (auto f = t.number("contact_frames", 0, 1, false)) {
        if (!(k.type.lateral_pair() && k.type.variant == 'a'))
            t.error("contact_frames", t.get("contact_frames"), "applies to type 0&0a only (this key segment is {})", k.type.name());
        k.contact_frames = *f;
    }
    if (auto z = t.numbers<2>("z_range")) {
        if (!((*z)[0] <= (*z)[1]) || (*z)[0] < -1 || (*z)[1] > 1)
            t.error("z_range", t.get("z_range"), "must be [low, high] in metres within [-1, 1]");
        k.z_range = z;
    }
}

void read_intent(TableReader& segment, Intent& intent) {
    TableReader prefer = segment.table("prefer");
    intent.distance_m = prefer.number("distance_m", 0, 100);
    intent.theta_a_deg = prefer.number("thetaA_deg", -180, 180);
    intent.theta_b_deg = prefer.number("thetaB_deg", -180, 180);
    intent.weight = prefer.number("weight", 0, 1e6).value_or(1.0);
    prefer.finish();
    TableReader limits = segment.table("limits");
    auto bounds = [&](const char* key, double lo, double hi) {
        auto r = limits.numbers<2>(key);
        if (r && ((*r)[0] > (*r)[1] || (*r)[0] < lo || (*r)[1] > hi))
            limits.error(key, limits.get(key), "must be [low, high] within [{}, {}]", lo, hi);
        return r;
    };
    intent.distance_limits_m = bounds("distance_m", 0, 100);
    intent.theta_a_limits_deg = bounds("thetaA_deg", -180, 180);
    intent.theta_b_limits_deg = bounds("thetaB_deg", -180, 180);
    limits.finish();
}


constexpr int kMaxObjects = 16;
constexpr int kMaxSegments = 1000;

// Object names become file names (transforms.json keys, frames' comments): letters, digits, _ and -.
bool valid_object_name(const std::string& name) {
    if (name.empty() || name.size() > 32) return false;
    return std::all_of(name.begin(), name.end(), [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-'; });
}

// [objects.NAME], two or more, in file order; one of them the anchor (anchor = true, else the first).
void read_objects(TableReader& top, Scene& scene) {
    TableReader objects = top.table("objects", true);
    const std::vector<std::string> names = objects.keys_in_file_order();
    if (names.size() < 2 || names.size() > std::size_t(kMaxObjects))
        top.error("objects", top.get("objects"), "a scene needs 2 to {} objects ([objects.A], [objects.B], ...), not {}", kMaxObjects, names.size());
    for (const std::string& name : names) {
        if (!valid_object_name(name))
            objects.error(name, objects.get(name), "'{}' is not an object name: use 1 to 32 letters, digits, '_' or '-'", name);
        scene.objects.push_back(read_object(objects, name));
    }
    objects.finish();
    const auto anchors = std::count_if(scene.objects.begin(), scene.objects.end(), [](const SceneObject& o) { return o.anchor; });
    if (anchors > 1) top.error("objects", top.get("objects"), "{} objects say anchor = true; one object stays fixed", anchors);
    if (anchors == 0) scene.objects.front().anchor = true;
}

// A key segment's pair: given as pair = ["A", "C"], or in a two-object scene [anchor, other].
std::array<std::string, 2> read_pair(TableReader& t, const toml::node& segment, const Scene& scene) {
    if (!t.has("pair")) {
        if (scene.multi_party())
            t.error("pair", &segment, "is missing: a scene of {} objects names each key segment's pair, e.g. pair = [\"{}\", \"{}\"]", scene.objects.size(),
                    scene.objects[0].name, scene.objects[1].name);
        const SceneObject& anchor = scene.objects[0].anchor ? scene.objects[0] : scene.objects[1];
        const SceneObject& other = &anchor == &scene.objects[0] ? scene.objects[1] : scene.objects[0];
        return {anchor.name, other.name};
    }
    const std::vector<std::string> names = t.strings("pair");
    if (names.size() != 2 || names[0] == names[1]) t.error("pair", t.get("pair"), "must name two different objects");
    for (const std::string& name : names)
        if (std::none_of(scene.objects.begin(), scene.objects.end(), [&](const SceneObject& o) { return o.name == name; }))
            t.error("pair", t.get("pair"), "names '{}', which is not one of the scene's objects", name);
    return {names[0], names[1]};
}

// Each object's key segments must be in order in its own frames and must not overlap.
void check_segment_order(TableReader& t, const Scene& scene, const KeySegment& k) {
    for (int side = 0; side < 2; ++side) {
        const std::string& name = k.pair[std::size_t(side)];
        const char* key = side == 0 ? "a" : "b";
        const std::array<int, 2>& range = side == 0 ? k.a : k.b;
        for (auto prev = scene.segments.rbegin(); prev != scene.segments.rend(); ++prev) {
            if (prev->pair[0] != name && prev->pair[1] != name) continue;
            const std::array<int, 2>& before = prev->pair[0] == name ? prev->a : prev->b;
            if (range[0] <= before[1])
                t.error(key, t.get(key), "overlaps or comes before key segment {}: key segments must be in order and must not overlap", prev->index);
            break;
        }
    }
}

void read_visibility(TableReader& t, VisibilitySpec& v) {
    TableReader vis = t.table("visibility");
    v.enabled = vis.boolean("enabled").value_or(false);
    v.half_angle_deg = vis.number("half_angle_deg", 0, 90, false).value_or(30);
    v.range = vis.number("range", 0, 1000).value_or(0);
    v.per_frame = vis.boolean("per_frame").value_or(false);
    if (auto f = vis.number("frames", 0, 1, false)) {
        if (!v.per_frame) vis.error("frames", vis.get("frames"), "applies to per-frame visibility only; add per_frame = true");
        v.frames = *f;
    }
    if (v.per_frame && !v.enabled) vis.error("per_frame", vis.get("per_frame"), "needs enabled = true");
    vis.finish();
}

KeySegment read_segment(TableReader& t, const toml::node& node, const Scene& scene, int index) {
    KeySegment k;
    k.index = index;
    k.line = t.line(&node);
    k.pair = read_pair(t, node, scene);
    auto a = t.frame_range("a"), b = t.frame_range("b");
    if (!a || !b) t.error(a ? "b" : "a", &node, "is missing: the key segment's frame range as [first, last]");
    k.a = *a;
    k.b = *b;
    for (auto [range, name, key] : {std::tuple{k.a, k.pair[0], "a"}, std::tuple{k.b, k.pair[1], "b"}}) {
        const SceneObject& object = scene.object(name);
        if (range[0] < object.frame_first || range[1] > object.frame_last)
            t.error(key, t.get(key), "frames {}..{} are beyond object {}'s frames {}..{}", range[0], range[1], object.name, object.frame_first,
                    object.frame_last);
    }
    auto type = t.string("type");
    if (!type) t.error("type", &node, "is missing: the interaction type (e.g. \"+&-\", \"0&0a\")");
    k.type = parse_interaction_type(*type, t.where("type", t.get("type")));
    k.tolerance = t.integer("tolerance", 0, 1000).value_or(0);
    read_visibility(t, k.visibility);
    read_real_capture_keys(t, k);
    read_intent(t, k.intent);
    read_parts(t, "interest", scene, k.pair, k.interest_a, k.interest_b, PartSpec{PartSpec::Kind::Whole});
    read_parts(t, "fidelity", scene, k.pair, k.fidelity_a, k.fidelity_b,
               PartSpec{k.type.near ? PartSpec::Kind::Whole : PartSpec::Kind::WholeMinusInterest});
    if (k.type.near && (k.fidelity_a.kind != PartSpec::Kind::Whole || k.fidelity_b.kind != PartSpec::Kind::Whole))
        t.error("fidelity", t.get("fidelity"), "a near key keeps the whole bodies apart: its fidelity is \"whole\" on both sides (or not given)");
    int tau = normalise_pair(k.a[1] - k.a[0] + 1, k.b[1] - k.b[0] + 1).length;
    if (tau > 500) t.error("a", t.get("a"), "the pair normalises to {} frames; a key segment may have at most 500", tau);
    check_segment_order(t, scene, k);
    t.finish();
    return k;
}

// How many key segments pair `name` with an object of `placed`.
int segments_with(const Scene& scene, const std::string& name, const std::vector<std::string>& placed) {
    auto in = [&](const std::string& n) { return std::find(placed.begin(), placed.end(), n) != placed.end(); };
    int count = 0;
    for (const KeySegment& k : scene.segments) count += (k.pair[0] == name && in(k.pair[1])) || (k.pair[1] == name && in(k.pair[0]));
    return count;
}

// The placement order (docs/method.md section 11): `order = [...]` as given (the anchor first), or
// the anchor and then, one at a time, the object with the most key segments with the objects
// already placed (ties: file order). Each pair must name the object placed first first.
void resolve_order(TableReader& top, Scene& scene, bool unplaced_ok) {
    const auto anchor = std::find_if(scene.objects.begin(), scene.objects.end(), [](const SceneObject& o) { return o.anchor; });
    if (top.has("order")) {
        scene.order = top.strings("order");
        scene.order_rule = "as the scene's order gives it";
        std::vector<std::string> sorted = scene.order, names;
        for (const SceneObject& o : scene.objects) names.push_back(o.name);
        std::sort(sorted.begin(), sorted.end());
        std::sort(names.begin(), names.end());
        if (sorted != names) top.error("order", top.get("order"), "must list every object once");
        if (scene.order.front() != anchor->name) top.error("order", top.get("order"), "must start with the anchor, {}", anchor->name);
    } else {
        scene.order = {anchor->name};
        scene.order_rule = "the anchor first, then each time the object with the most key segments with the objects already placed (ties: file order)";
        while (scene.order.size() < scene.objects.size()) {
            const SceneObject* best = nullptr;
            int most = -1;
            for (const SceneObject& o : scene.objects) {
                if (std::find(scene.order.begin(), scene.order.end(), o.name) != scene.order.end()) continue;
                const int count = segments_with(scene, o.name, scene.order);
                if (count > most) best = &o, most = count;
            }
            scene.order.push_back(best->name);
        }
    }
    for (std::size_t n = 1; n < scene.order.size() && !unplaced_ok; ++n) {
        const std::vector<std::string> placed(scene.order.begin(), scene.order.begin() + std::ptrdiff_t(n));
        if (segments_with(scene, scene.order[n], placed) == 0)
            top.error("segments", top.get("segments"), "object {} has no key segment with an object placed before it (order: {}): nothing places it",
                      scene.order[n], fmt::join(scene.order, ", "));
    }
    auto position = [&](const std::string& name) { return std::find(scene.order.begin(), scene.order.end(), name) - scene.order.begin(); };
    for (const KeySegment& k : scene.segments)
        if (position(k.pair[0]) > position(k.pair[1]))
            fail(fmt::format("{}:{}: segments[{}].pair", scene.file.string(), k.line, k.index),
                 "[{}, {}] puts {} first, but {} is placed before it (order: {}): write the pair as [{}, {}] with a and b, interest and fidelity swapped",
                 k.pair[0], k.pair[1], k.pair[0], k.pair[1], fmt::join(scene.order, ", "), k.pair[1], k.pair[0]);
    scene.a = scene.object(scene.order[0]);
    scene.b = scene.object(scene.order[1]);
}

Placement read_placement(TableReader& t) {
    Placement p;
    p.x = t.number("x", -1e4, 1e4).value_or(0);
    p.y = t.number("y", -1e4, 1e4).value_or(0);
    p.yaw_deg = t.number("yaw_deg", -360, 360).value_or(0);
    t.finish();
    return p;
}

// [truth] (two objects: B's capture frame in A's) or [truth.NAME] per object (its capture frame in
// the anchor's).
void read_truth(TableReader& top, Scene& scene) {
    if (!top.has("truth")) return;
    TableReader truth = top.table("truth");
    const toml::table& table = *top.get("truth")->as_table();
    const bool per_object = std::any_of(table.begin(), table.end(), [](const auto& entry) { return entry.second.is_table(); });
    if (!per_object) {
        if (scene.multi_party())
            top.error("truth", top.get("truth"), "a scene of {} objects gives the truth per object: [truth.NAME] with x, y and yaw_deg", scene.objects.size());
        scene.truth = read_placement(truth);
        return;
    }
    for (const std::string& name : truth.keys_in_file_order()) {
        if (std::find(scene.order.begin() + 1, scene.order.end(), name) == scene.order.end())
            truth.error(name, truth.get(name), "'{}' is not an object placed against the anchor {}", name, scene.order.front());
        TableReader t = truth.table(name);
        scene.truths[name] = read_placement(t);
    }
    truth.finish();
    if (!scene.multi_party() && scene.truths.count(scene.b.name)) scene.truth = scene.truths.at(scene.b.name);
}
}  // namespace

Scene load_scene(const fs::path& file, bool segments_optional) {
    if (!is_file(file)) fail(file.string(), "no such scene file");
    toml::table root;
    try {
        root = toml::parse_file(file.string());
    } catch (const toml::parse_error& e) {
        fail(fmt::format("{}:{}", file.string(), e.source().begin.line), "{}", std::string(e.description()));
    }
    Scene scene;
    scene.file = fs::absolute(file).lexically_normal();
    TableReader top(root, "", scene.file);

    TableReader sampling = top.table("sampling");
    scene.sampling.voxel = sampling.number("voxel", 0, 1, false).value_or(0.01);
    if (scene.sampling.voxel < 0.001) sampling.error("voxel", sampling.get("voxel"), "{} m is below the 1 mm the solver supports", scene.sampling.voxel);
    scene.sampling.angle_step_deg = sampling.number("angle_step_deg", 0.01, 180).value_or(2.0);
    double steps = 360.0 / scene.sampling.angle_step_deg;
    if (std::abs(steps - std::round(steps)) > 1e-9)
        sampling.error("angle_step_deg", sampling.get("angle_step_deg"), "{} does not divide 360", scene.sampling.angle_step_deg);
    for (const char* key : {"x_range", "y_range"}) {
        auto r = sampling.numbers<2>(key);
        if (r && (*r)[0] > (*r)[1]) sampling.error(key, sampling.get(key), "first value is above the second");
        if (r && (std::abs((*r)[0]) > 1000 || std::abs((*r)[1]) > 1000))
            sampling.error(key, sampling.get(key), "must lie within 1 km of A's root ([-1000, 1000] metres)");
        (std::string(key) == "x_range" ? scene.sampling.x_range : scene.sampling.y_range) = r;
    }
    sampling.finish();

    TableReader weights = top.table("weights");
    Weights& w = scene.weights;
    w.lambda = weights.number("lambda", 0, 1e6).value_or(w.lambda);
    w.delta = weights.number("delta", 0, 1).value_or(w.delta);
    w.alpha = weights.number("alpha", 0, 1e6).value_or(w.alpha);
    w.v_c = weights.number("v_c", 0, 100).value_or(w.v_c);
    w.r_c = weights.number("r_c", 0, 10).value_or(w.r_c);
    w.w_a = weights.number("w_A", 0, 1e12, false).value_or(w.w_a);
    w.w_b = weights.number("w_B", 0, 1e12, false).value_or(w.w_b);
    w.mu = weights.number("mu", 0, 1e6).value_or(w.mu);
    w.natural = weights.number("natural", 0, 1e6).value_or(w.natural);
    if (weights.has("a_rotations_deg")) {
        const toml::node* node = weights.get("a_rotations_deg");
        const toml::array* array = node->as_array();
        if (!array || array->empty()) weights.error("a_rotations_deg", node, "must be a non-empty array of angles in degrees");
        w.a_rotations_deg.clear();
        for (const toml::node& item : *array) {
            if (!item.is_number() || !(std::abs(item.value<double>().value()) <= 180))  // NaN fails too
                weights.error("a_rotations_deg", node, "must hold angles in degrees within [-180, 180]");
            w.a_rotations_deg.push_back(item.value<double>().value());
        }
    }
    weights.finish();

    read_objects(top, scene);
    const toml::node* segments_node = top.get("segments");
    const toml::array* segments = segments_node ? segments_node->as_array() : nullptr;
    if ((!segments || segments->empty()) && !segments_optional)
        top.error("segments", segments_node, "give at least one key segment pair as [[segments]] with a, b and type (amhv propose finds some)");
    if (segments_node && !segments) top.error("segments", segments_node, "must be an array of tables: [[segments]]");
    if (segments && segments->size() > std::size_t(kMaxSegments)) top.error("segments", segments_node, "{} key segments; a scene may have at most {}", segments->size(), kMaxSegments);
    for (std::size_t s = 0; segments && s < segments->size(); ++s) {
        const toml::node& node = *segments->get(s);
        if (!node.is_table()) top.error(fmt::format("segments[{}]", s + 1), &node, "must be a table");
        TableReader t(*node.as_table(), fmt::format("segments[{}]", s + 1), file);
        scene.segments.push_back(read_segment(t, node, scene, int(s) + 1));
    }
    resolve_order(top, scene, scene.segments.empty() && segments_optional && scene.objects.size() == 2);
    read_truth(top, scene);
    top.finish();
    return scene;
}

const SceneObject& Scene::object(const std::string& name) const {
    for (const SceneObject& o : objects)
        if (o.name == name) return o;
    throw Error(fmt::format("{}: no object named '{}'", file.string(), name));
}

Scene load_two_object_scene(const fs::path& file, const std::string& command, bool segments_optional) {
    Scene scene = load_scene(file, segments_optional);
    if (scene.multi_party())
        fail(scene.file.string(), "has {} objects; `amhv {}` takes two. Each object after the second is swept against the edit of the ones placed "
             "before it, so a multi-party scene is swept and edited in one run: amhv edit", scene.objects.size(), command);
    return scene;
}

std::string resolved_toml(const Scene& scene) {
    auto vec = [](const Vec3& v) { return toml::array{v.x(), v.y(), v.z()}; };
    auto part_node = [&](const PartSpec& p) {
        toml::table t;
        switch (p.kind) {
            case PartSpec::Kind::Whole: t.insert("rule", "whole"); break;
            case PartSpec::Kind::WholeMinusInterest: t.insert("rule", "whole_minus_interest"); break;
            case PartSpec::Kind::Meshes: t.insert("meshes", p.meshes); break;
            case PartSpec::Kind::Parts:
            case PartSpec::Kind::PartsExcept: {
                toml::array labels;
                for (const auto& l : p.labels) labels.push_back(l);
                t.insert(p.kind == PartSpec::Kind::Parts ? "parts" : "parts_except", labels);
                break;
            }
            case PartSpec::Kind::Box: t.insert("box", toml::table{{"min", vec(p.box.min)}, {"max", vec(p.box.max)}}); break;
        }
        return t;
    };
    toml::table root;
    toml::table sampling{{"voxel", scene.sampling.voxel}, {"angle_step_deg", scene.sampling.angle_step_deg}, {"angles", scene.sampling.angles()}};
    if (scene.sampling.x_range) sampling.insert("x_range", toml::array{(*scene.sampling.x_range)[0], (*scene.sampling.x_range)[1]});
    if (scene.sampling.y_range) sampling.insert("y_range", toml::array{(*scene.sampling.y_range)[0], (*scene.sampling.y_range)[1]});
    root.insert("sampling", sampling);
    const Weights& w = scene.weights;
    toml::array rotations;
    for (double r : w.a_rotations_deg) rotations.push_back(r);
    root.insert("weights", toml::table{{"lambda", w.lambda}, {"delta", w.delta}, {"alpha", w.alpha}, {"v_c", w.v_c}, {"r_c", w.r_c},
                                       {"w_A", w.w_a}, {"w_B", w.w_b}, {"mu", w.mu}, {"natural", w.natural}, {"a_rotations_deg", rotations}});
    toml::table objects;
    for (const SceneObject& object : scene.objects) {
        const SceneObject* o = &object;
        toml::table t;
        // Two-object scenes with the anchor first print as before (their hashes stay the same).
        if (scene.multi_party() || (o->anchor && o != &scene.objects.front())) t.insert("anchor", o->anchor);
        if (!o->meshes.empty()) t.insert("meshes", o->meshes);
        if (!o->bvh.empty()) t.insert("bvh", o->bvh);
        if (!o->character.empty()) t.insert("character", o->character), t.insert("animation", *o->animation);
        if (!o->joint_roles.empty()) {
            toml::table roles;
            for (const auto& [joint, role] : o->joint_roles) roles.insert(joint, role);
            t.insert("joints", roles);
        }
        t.insert("unit", o->units.metres_per_unit);
        if (o->units.axes) t.insert("axes", o->units.axes->describe());
        else t.insert("up", std::string(1, "xyz"[int(o->units.up)]));
        if (o->floor_auto) t.insert("floor", "auto");
        else if (o->floor_m) t.insert("floor", *o->floor_m);
        t.insert("fps", o->fps);
        if (!o->bvh.empty()) t.insert("tpose", std::string(to_string(o->tpose)));
        if (o->body == BodyKind::Skinned) t.insert("body", to_string(o->body));  // absent for capsules: older scenes hash as before
        t.insert("frames", toml::array{o->frame_first, o->frame_last});
        if (!o->labels.empty()) t.insert("labels", o->labels);
        if (!o->track.empty()) t.insert("track", o->track);
        if (!o->files_root.empty()) t.insert("files_root", o->files_root.string());
        if (o->facing_deg) t.insert("facing_deg", *o->facing_deg);
        t.insert("placement", toml::table{{"x", o->placement.x}, {"y", o->placement.y}, {"yaw_deg", o->placement.yaw_deg}});
        objects.insert(o->name, t);
    }
    root.insert("objects", objects);
    if (scene.truth) root.insert("truth", toml::table{{"x", scene.truth->x}, {"y", scene.truth->y}, {"yaw_deg", scene.truth->yaw_deg}});
    if (scene.multi_party()) {
        toml::array order;
        for (const std::string& name : scene.order) order.push_back(name);
        root.insert("order", order);
        toml::table truths;
        for (const auto& [name, t] : scene.truths) truths.insert(name, toml::table{{"x", t.x}, {"y", t.y}, {"yaw_deg", t.yaw_deg}});
        if (!truths.empty()) root.insert("truth", truths);
    }
    toml::array segments;
    for (const KeySegment& k : scene.segments) {
        NormalisedPair pair = normalise_pair(k.a[1] - k.a[0] + 1, k.b[1] - k.b[0] + 1);
        segments.push_back(toml::table{
            {"a", toml::array{k.a[0], k.a[1]}},
            {"b", toml::array{k.b[0], k.b[1]}},
            {"normalised_frames", pair.length},
            {"type", k.type.name()},
            {"tolerance", k.tolerance},
            {k.type.near ? "within_m" : "contact_tolerance", k.contact_tolerance},
            {"contact_frames", k.contact_frames},
            {"visibility", toml::table{{"enabled", k.visibility.enabled},
                                       {"half_angle_deg", k.visibility.half_angle_deg},
                                       {"range", k.visibility.range},
                                       {"per_frame", k.visibility.per_frame},
                                       {"frames", k.visibility.frames}}},
            {"interest", toml::table{{k.pair[0], part_node(k.interest_a)}, {k.pair[1], part_node(k.interest_b)}}},
            {"fidelity", toml::table{{k.pair[0], part_node(k.fidelity_a)}, {k.pair[1], part_node(k.fidelity_b)}}},
        });
        toml::table& entry = *segments.back().as_table();
        if (scene.multi_party()) entry.insert("pair", toml::array{k.pair[0], k.pair[1]});
        if (k.z_range) entry.insert("z_range", toml::array{(*k.z_range)[0], (*k.z_range)[1]});
        const Intent& in = k.intent;
        if (in.prefers()) {
            toml::table prefer{{"weight", in.weight}};
            if (in.distance_m) prefer.insert("distance_m", *in.distance_m);
            if (in.theta_a_deg) prefer.insert("thetaA_deg", *in.theta_a_deg);
            if (in.theta_b_deg) prefer.insert("thetaB_deg", *in.theta_b_deg);
            entry.insert("prefer", prefer);
        }
        if (in.limits()) {
            toml::table limits;
            in.for_each_limit([&](const char* key, const std::optional<std::array<double, 2>>& r) {
                if (r) limits.insert(key, toml::array{(*r)[0], (*r)[1]});
            });
            entry.insert("limits", limits);
        }
    }
    root.insert("segments", segments);
    std::ostringstream out;
    out << "# " << scene.file.string() << ", resolved: every default filled in\n" << root << "\n";
    return out.str();
}

namespace {

// A folder stays itself; a printf pattern or a file stands for the folder it lies in as well.
void add_input(std::vector<std::filesystem::path>& inputs, const std::string& path) {
    if (path.empty()) return;
    inputs.emplace_back(path);
    if (path.find('%') != std::string::npos) inputs.push_back(std::filesystem::path(path).parent_path());
}

}  // namespace

std::vector<std::filesystem::path> scene_inputs(const Scene& scene) {
    std::vector<std::filesystem::path> inputs{scene.file};
    for (const SceneObject& object : scene.objects)
        for (const std::string* path : {&object.meshes, &object.bvh, &object.character, &object.labels, &object.track}) add_input(inputs, *path);
    for (const KeySegment& segment : scene.segments)
        for (const PartSpec* part : {&segment.interest_a, &segment.interest_b, &segment.fidelity_a, &segment.fidelity_b})
            if (part->kind == PartSpec::Kind::Meshes) add_input(inputs, part->meshes);
    return inputs;
}

}  // namespace amhv
