#include "src/pipeline/view_page.hpp"


#include <cstdlib>
#include <fstream>
#include <iostream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "src/core/error.hpp"
#include "src/io/files.hpp"
#include "src/pipeline/solutions_export.hpp"
#include "src/io/json_problem.hpp"
#include "embedded/page_files.h"

namespace amhv::pipeline {

namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

// The three.js files the page loads, from the package folder to view/.
constexpr std::array<std::pair<const char*, const char*>, 3> kThreeFiles{{
    {"build/three.min.js", "three.min.js"},
    {"examples/js/loaders/GLTFLoader.js", "GLTFLoader.js"},
    {"examples/js/controls/OrbitControls.js", "OrbitControls.js"},
}};

std::string base64(const std::string& bytes) {
    static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    out.reserve((bytes.size() + 2) / 3 * 4);
    for (std::size_t i = 0; i < bytes.size(); i += 3) {
        const std::uint32_t a = static_cast<unsigned char>(bytes[i]);
        const std::uint32_t b = i + 1 < bytes.size() ? static_cast<unsigned char>(bytes[i + 1]) : 0u;
        const std::uint32_t c = i + 2 < bytes.size() ? static_cast<unsigned char>(bytes[i + 2]) : 0u;
        const std::uint32_t v = a << 16 | b << 8 | c;
        out += kAlphabet[v >> 18 & 63];
        out += kAlphabet[v >> 12 & 63];
        out += i + 1 < bytes.size() ? kAlphabet[v >> 6 & 63] : '=';
        out += i + 2 < bytes.size() ? kAlphabet[v & 63] : '=';
    }
    return out;
}

Json read_json(const fs::path& file) {
    try {
        return Json::parse(read_file_bytes(file));
    } catch (const Json::exception& e) {
        fail(file.string(), "is not the JSON amhv wrote ({})", json_problem(e));
    }
}

// The natural scores of the plotted members (segment_N/natural.json, written by the edit), or
// null when the edit wrote none or they do not match the group's stride and count.
Json natural_costs(const fs::path& file, std::uint64_t stride, std::size_t rows) {
    if (!is_file(file)) return nullptr;
    const Json natural = read_json(file);
    if (!natural.is_object() || !natural.contains("stride") || !natural.contains("costs") || !natural["costs"].is_array() ||
        natural["stride"] != stride || natural["costs"].size() != rows)
        fail(file.string(), "does not match the group it scores (stride {}, {} members shown)", stride, rows);
    for (const Json& c : natural["costs"])
        if (!c.is_number()) fail(file.string(), "holds a score that is not a number");
    return natural["costs"];
}

// Every group member up to kPagePlottedMembers, else every n-th by rank: x, y, z, theta, L,
// thetaA, thetaB, and the natural score when the edit wrote them (`edit_dir`).
Json group_rows(const fs::path& dir, const fs::path& edit_dir, const Json& segment) {
    const int index = json_integer<int>(segment.at("index"));
    const GroupRead group = read_group(dir, index);
    const std::uint64_t members = group.group.size();
    const std::uint64_t stride = sample_stride(members, kPagePlottedMembers);
    Json rows = Json::array();
    std::uint64_t rank = 0;
    group.group.for_each([&](const PoseIndex& p) {
        if (rank++ % stride) return;
        const Solution s = group.describe(p);
        rows.push_back({s.x, s.y, s.z, s.theta_deg, s.distance, s.theta_a_deg, s.theta_b_deg});
    });
    Json out = {{"index", index}, {"members", members}, {"shown", rows.size()}, {"stride", stride}, {"voxel", group.lattice.voxel},
                {"angle_step_deg", group.lattice.angle_step_deg}, {"rows", std::move(rows)}};
    const Json costs = natural_costs(edit_dir / fmt::format("segment_{}", index) / "natural.json", stride, out["shown"].get<std::size_t>());
    if (!costs.is_null())
        for (std::size_t r = 0; r < costs.size(); ++r) out["rows"][r].push_back(costs[r]);
    const fs::path montage = fs::path(fmt::format("segment_{}", index)) / "feasibility" / "montage.png";
    if (is_file(dir / montage)) out["montage"] = montage.generic_string();
    return out;
}

// view/data.js: result.json as written, transforms.json's segments and roots, the groups' members.
std::string page_data(const fs::path& dir) {
    const Json result = read_json(dir / "result.json");
    if (!result.contains("output") || !result.at("output").contains("scene_fps") || !result.at("output").at("scene_fps").is_number())
        fail((dir / "result.json").string(), "names no scene.glb with its frame rate (an `amhv sweep` folder, an edit written with --no-glb, "
                                             "or by an amhv before the page): the page is for the output of `amhv edit`");
    const Json transforms = read_json(dir / "transforms.json");
    Json roots = Json::array();
    for (const Json& frame : transforms.at("output"))
        roots.push_back({frame.at("A").at("root")[0], frame.at("A").at("root")[1], frame.at("B").at("root")[0], frame.at("B").at("root")[1]});
    // The groups are where the edit found them: its own folder, or the sweep it reused.
    fs::path groups_dir = dir;
    if (result.contains("from_sweep") && result.at("from_sweep").is_string()) {
        groups_dir = result.at("from_sweep").get<std::string>();
        if (!is_folder(groups_dir))
            fail((dir / "result.json").string(), "reused the sweep in '{}', which holds the groups the page plots and is gone", groups_dir.string());
    }
    Json groups = Json::array();
    for (const Json& segment : result.at("segments")) groups.push_back(group_rows(groups_dir, dir, segment));
    const Json data = {{"result", result},
                       {"transforms", {{"frames", transforms.at("frames")}, {"segments", transforms.at("segments")}}},
                       {"roots", std::move(roots)},
                       {"groups", std::move(groups)},
                       {"fps", result.at("output").at("scene_fps")}};
    return "window.AMHV_DATA = " + data.dump() + ";\n";
}

}  // namespace

fs::path three_js_dir() {
    if (const char* env = std::getenv("AMHV_THREE_DIR")) return env;
    return AMHV_THREE_DIR;
}

PageReport write_view_page(const fs::path& dir, const fs::path& out) {
    const fs::path glb = dir / "scene.glb";
    if (!is_file(dir / "result.json")) fail(dir.string(), "has no result.json: the page is for the output of `amhv edit`");
    const fs::path three = three_js_dir();
    for (const auto& [from, to] : kThreeFiles)
        if (!is_file(three / from))
            fail((three / from).string(), "is missing: the page needs three.js r147 (tools/setup.sh installs it from npm; or pass --no-page)");
    const std::string data = page_data(dir);  // refuses a folder that is no edit's
    if (!is_file(glb)) fail(glb.string(), "is missing: the page plays it (run `amhv edit` without --no-glb)");
    const fs::path view = out / "view";
    fs::create_directories(view);
    for (const auto& [from, to] : kThreeFiles) fs::copy_file(three / from, view / to, fs::copy_options::overwrite_existing);
    write_file(view / "data.js", data);
    write_file(view / "scene.js", "window.AMHV_GLB = \"" + base64(read_file_bytes(glb)) + "\";\n");
    write_file(view / "view.js", embedded::k_view_js);
    write_file(out / "index.html", embedded::k_index_html);
    PageReport report;
    report.bytes = fs::file_size(out / "index.html");
    for (const auto& entry : fs::directory_iterator(view)) report.bytes += entry.file_size();
    return report;
}

}  // namespace amhv::pipeline
