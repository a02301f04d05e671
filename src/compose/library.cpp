#include "src/compose/library.hpp"

#include <algorithm>
#include <cmath>

#include <toml++/toml.h>

#include "src/body/skeleton_roles.hpp"
#include "src/core/error.hpp"
#include "src/io/files.hpp"
#include "src/io/toml_reader.hpp"

namespace amhv::compose {

namespace fs = std::filesystem;

namespace {

constexpr std::size_t kMaxTakes = 256, kMaxExamples = 4096;

const toml::array* array_of_tables(TableReader& top, const std::string& key, std::size_t max) {
    const toml::node* node = top.get(key);
    const toml::array* array = node ? node->as_array() : nullptr;
    if (!array || array->empty()) top.error(key, node, "give at least one [[{}]] table", key);
    if (array->size() > max) top.error(key, node, "{} tables; a library may have at most {}", array->size(), max);
    for (std::size_t i = 0; i < array->size(); ++i)
        if (!array->get(i)->is_table()) top.error(fmt::format("{}[{}]", key, i + 1), array->get(i), "must be a table");
    return array;
}

// A frame of the file's clock to the library's.
int to_clock(int frame, double file_fps, double fps) { return int(std::lround(double(frame) * fps / file_fps)); }

// Same joints, same hierarchy, same channels: rotations of one take mean the same on the other.
void check_same_skeleton(const Library& library, const LibraryTake& take, const std::vector<std::string>& roles, const std::string& where) {
    const BvhMotion& first = library.takes.front().motion;
    const BvhMotion& other = take.motion;
    const std::string& name0 = library.takes.front().name;
    if (other.joints.size() != first.joints.size())
        fail(where, "take '{}' does not map joint by joint onto take '{}': {} joints against {}", take.name, name0, other.joints.size(), first.joints.size());
    for (std::size_t j = 0; j < first.joints.size(); ++j) {
        const BvhJoint& a = first.joints[j];
        const BvhJoint& b = other.joints[j];
        if (roles[j] != library.roles[j] || a.parent != b.parent || a.channels != b.channels || a.end_site != b.end_site)
            fail(where, "take '{}' does not map joint by joint onto take '{}': joint {} is '{}' ({}) there and '{}' ({}) here", take.name, name0, j + 1,
                 a.name, library.roles[j], b.name, roles[j]);
    }
}

// Compose rewrites every joint's rotation: each needs three distinct rotation channels, the root
// three position channels too.
void check_channels(const BvhMotion& motion, const std::string& where) {
    for (std::size_t j = 0; j < motion.joints.size(); ++j) {
        const BvhJoint& joint = motion.joints[j];
        if (joint.end_site) continue;
        int rotations = 0, positions = 0, seen = 0;
        for (BvhJoint::Channel c : joint.channels) {
            const int bit = 1 << int(c);
            if (seen & bit) fail(where, "joint '{}' repeats a channel: composing needs three distinct rotation channels per joint", joint.name);
            seen |= bit;
            (int(c) >= 3 ? rotations : positions)++;
        }
        if (rotations != 3) fail(where, "joint '{}' has {} rotation channels: composing needs three per joint", joint.name, rotations);
        if (j == 0 && positions != 3) fail(where, "the root '{}' has {} position channels: composing needs three", joint.name, positions);
    }
}

void read_take(TableReader& t, Library& library) {
    LibraryTake take;
    take.name = t.string("name").value_or("");
    if (take.name.empty()) t.error("name", t.get("name"), "give each take a name");
    for (const LibraryTake& other : library.takes)
        if (other.name == take.name) t.error("name", t.get("name"), "take '{}' is named twice", take.name);
    const auto bvh = t.string("bvh");
    if (!bvh) t.error("bvh", nullptr, "is missing: give the take's BVH file");
    fs::path path(*bvh);
    if (path.is_relative()) path = t.file().parent_path() / path;
    take.file = path.lexically_normal();
    if (!is_file(take.file)) t.error("bvh", t.get("bvh"), "'{}' is not a file", take.file.string());
    BvhLoadOptions options;
    if (auto tpose = t.string("tpose")) options.tpose = parse_tpose(*tpose, t.where("tpose", t.get("tpose")));
    BvhMotion motion = load_bvh(take.file, options);
    const double file_fps = motion.fps();
    if (library.takes.empty() && library.fps == 0) library.fps = file_fps;
    if (std::abs(file_fps - library.fps) > 1e-9) motion = resample_bvh(motion, library.fps);
    take.file_fps = file_fps;
    int first = motion.first_frame, last = motion.frame_count - 1;
    if (auto frames = t.frame_range("frames")) {
        const int a = to_clock((*frames)[0], file_fps, library.fps), b = to_clock((*frames)[1], file_fps, library.fps);
        if (a < first || b > last)
            t.error("frames", t.get("frames"), "[{}, {}] is outside the take's captured frames", (*frames)[0], (*frames)[1]);
        first = a;
        last = b;
    }
    const std::string where = t.where("bvh", t.get("bvh"));
    if (double(last - first + 1) < 2 * kMinExampleSeconds * library.fps)
        fail(where, "take '{}' has {} frames to use: fewer than {:.2f} s", take.name, last - first + 1, 2 * kMinExampleSeconds);
    check_channels(motion, where);
    take.motion = std::move(motion);
    take.first = first;
    take.last = last;
    const std::vector<std::string> roles = role_names(take.motion);
    if (library.takes.empty()) library.roles = roles;
    else check_same_skeleton(library, take, roles, where);
    t.finish();
    library.takes.push_back(std::move(take));
}

void read_example(TableReader& t, Library& library) {
    ActionExample example;
    const std::string take = t.string("take").value_or("");
    auto it = std::find_if(library.takes.begin(), library.takes.end(), [&](const LibraryTake& k) { return k.name == take; });
    if (it == library.takes.end()) t.error("take", t.get("take"), "'{}' is not a take of the library", take);
    example.take = int(it - library.takes.begin());
    example.action = t.string("action").value_or("");
    if (example.action.empty() || example.action.find_first_of(",:\n\"") != std::string::npos || example.action == "unknown")
        t.error("action", t.get("action"), "give the action a name (no commas, colons or quotes; 'unknown' is taken)");
    const auto frames = t.frame_range("frames");
    if (!frames) t.error("frames", nullptr, "is missing: give [first, last] in the take's own frame numbers");
    example.first = to_clock((*frames)[0], it->file_fps, library.fps);
    example.last = to_clock((*frames)[1], it->file_fps, library.fps);
    if (example.first < it->first || example.last > it->last)
        t.error("frames", t.get("frames"), "[{}, {}] lies outside the frames take '{}' uses", (*frames)[0], (*frames)[1], take);
    if (double(example.last - example.first + 1) < kMinExampleSeconds * library.fps)
        t.error("frames", t.get("frames"), "an example needs at least {:.2f} s", kMinExampleSeconds);
    t.finish();
    if (library.action_index(example.action) < 0) library.actions.push_back(example.action);
    library.examples.push_back(std::move(example));
}

}  // namespace

int Library::action_index(const std::string& name) const {
    auto it = std::find(actions.begin(), actions.end(), name);
    return it == actions.end() ? -1 : int(it - actions.begin());
}

Library read_library(const fs::path& file) {
    if (!is_file(file)) fail(file.string(), "no such library file");
    toml::table root;
    try {
        root = toml::parse(read_file_bytes(file, std::uintmax_t(1) << 24), file.string());
    } catch (const toml::parse_error& e) {
        fail(fmt::format("{}:{}", file.string(), e.source().begin.line), "{}", std::string(e.description()));
    }
    Library library;
    library.file = fs::absolute(file).lexically_normal();
    TableReader top(root, "", library.file);
    if (auto unit = top.string("unit")) library.units.metres_per_unit = parse_unit(*unit, top.where("unit", top.get("unit")));
    if (auto up = top.string("up")) library.units.up = parse_up_axis(*up, top.where("up", top.get("up")));
    library.fps = top.number("fps", 1, 1000).value_or(0);
    const toml::array* takes = array_of_tables(top, "takes", kMaxTakes);
    for (std::size_t i = 0; i < takes->size(); ++i) {
        TableReader t(*takes->get(i)->as_table(), fmt::format("takes[{}]", i + 1), library.file);
        read_take(t, library);
    }
    const toml::array* examples = array_of_tables(top, "examples", kMaxExamples);
    for (std::size_t i = 0; i < examples->size(); ++i) {
        TableReader t(*examples->get(i)->as_table(), fmt::format("examples[{}]", i + 1), library.file);
        read_example(t, library);
    }
    top.finish();
    return library;
}

}  // namespace amhv::compose
