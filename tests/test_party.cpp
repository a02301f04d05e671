// Multi-party scenes (docs/method.md section 11): three or more objects, a pair per key segment,
// the placement order, and the sequential edit in which each object is placed against every object
// placed before it, which stay fixed.
#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "host/reference/voxelise_reference.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"
#include "support.hpp"

namespace amhv {
namespace {

namespace fs = std::filesystem;

// The CMU handshake (18_01 / 19_01) and a third performer from another capture (20_11, resampled to
// 120 fps) who high-fives A after the handshake.
std::string trio_scene(const std::string& extra_top = "", const std::string& pair_c = "pair = [\"A\", \"C\"]") {
    const std::string cmu = (test::source_dir() / "data/cmu").string();
    return fmt::format(R"(
{extra}
[sampling]
voxel = 0.01
angle_step_deg = 2.0

[objects.A]
bvh = "{cmu}/18_01.bvh"
frames = [1, 303]

[objects.B]
bvh = "{cmu}/19_01.bvh"
frames = [1, 303]
placement = {{ x = 4.0, y = -3.0, yaw_deg = 120.0 }}

[objects.C]
bvh = "{cmu}/20_11.bvh"
fps = 120.0
placement = {{ x = -3.0, y = 2.0, yaw_deg = -60.0 }}

[[segments]]
pair = ["A", "B"]
a = [108, 147]
b = [108, 147]
type = "0&0a"
interest = {{ A = {{ parts = ["right_hand"] }}, B = {{ parts = ["right_hand"] }} }}
fidelity = {{ A = {{ parts_except = ["right_upper_arm", "right_forearm", "right_hand"] }}, B = {{ parts_except = ["right_upper_arm", "right_forearm", "right_hand"] }} }}
visibility = {{ enabled = true, half_angle_deg = 30.0 }}
prefer = {{ distance_m = 0.7, thetaA_deg = 0.0, thetaB_deg = 0.0 }}

[[segments]]
{pair_c}
a = [196, 286]
b = [80, 170]
type = "0&0b"
interest = {{ A = {{ parts = ["right_hand"] }}, C = {{ parts = ["right_hand"] }} }}
fidelity = {{ A = {{ parts_except = ["right_upper_arm", "right_forearm", "right_hand"] }}, C = {{ parts_except = ["right_upper_arm", "right_forearm", "right_hand"] }} }}
visibility = {{ enabled = true, half_angle_deg = 45.0 }}
prefer = {{ distance_m = 0.9 }}
)",
                       fmt::arg("extra", extra_top), fmt::arg("cmu", cmu), fmt::arg("pair_c", pair_c));
}

fs::path write_scene(const test::TempDir& dir, const std::string& text) {
    const fs::path path = dir.path() / "trio.toml";
    std::ofstream(path) << text;
    return path;
}

TEST(Party, SceneNamesEveryObjectAndFindsThePlacementOrder) {
    test::TempDir dir;
    const Scene scene = load_scene(write_scene(dir, trio_scene()));
    ASSERT_EQ(scene.objects.size(), 3u);
    EXPECT_TRUE(scene.multi_party());
    EXPECT_EQ(scene.order, (std::vector<std::string>{"A", "B", "C"}));
    EXPECT_EQ(scene.segments[1].pair[0], "A");
    EXPECT_EQ(scene.segments[1].pair[1], "C");
    EXPECT_EQ(scene.object("C").frame_last, 228);  // 58 frames at 30 fps, resampled to 120 fps
    const std::string check = test::run_amhv(fmt::format("check '{}'", (dir.path() / "trio.toml").string())).output;
    EXPECT_NE(check.find("# placement order: A, B, C (the anchor first"), std::string::npos) << check;
}

TEST(Party, BadPairsAndOrdersGetOneLineNamingTheKey) {
    test::TempDir dir;
    struct Case {
        std::string top, pair, expect;
    };
    const Case cases[] = {
        {"", "", "segments[2].pair: is missing"},
        {"", "pair = [\"A\", \"D\"]", "names 'D', which is not one of the scene's objects"},
        {"", "pair = [\"C\", \"A\"]", "segments[2].a: frames 196..286 are beyond object C's frames 0..228"},
        {"order = [\"B\", \"A\", \"C\"]", "pair = [\"A\", \"C\"]", "order: must start with the anchor, A"},
        {"order = [\"A\", \"C\"]", "pair = [\"A\", \"C\"]", "order: must list every object once"},
        {"[truth]\nx = 0.0", "pair = [\"A\", \"C\"]", "gives the truth per object"},
    };
    for (const Case& c : cases) {
        // A top-level key must come before the first table: put it at the top of the file.
        const fs::path scene = write_scene(dir, trio_scene(c.top.rfind("[truth]", 0) == 0 ? "" : c.top, c.pair) +
                                                    (c.top.rfind("[truth]", 0) == 0 ? "\n" + c.top + "\n" : ""));
        const auto run = test::run_amhv(fmt::format("check '{}'", scene.string()));
        EXPECT_EQ(test::one_line_error(run), 1) << c.expect << "\n" << run.output;
        EXPECT_NE(run.output.find(c.expect), std::string::npos) << run.output;
    }
}

bool whole_body(const std::string&) { return true; }
bool off_right_arm(const std::string& part) { return part != "right_upper_arm" && part != "right_forearm" && part != "right_hand"; }

// The shipped three-person scene (data/scenes/trio.toml): A stays where it was captured at every
// frame; B and C are placed; every object is in every output frame. Re-voxelised from
// transforms.json alone by the CPU reference: no two performers' bodies, bar the right arms that
// shake and slap hands, share a voxel at any frame, and C's whole body never meets B's.
TEST(Party, TheThreePersonSceneKeepsEveryPairApart) {
    test::TempDir dir;
    const fs::path scene = test::source_dir() / "data/scenes/trio.toml";
    const fs::path out = dir.path() / "out";
    const auto run = test::run_amhv(fmt::format("edit '{}' --no-timings --out '{}'", scene.string(), out.string()));
    ASSERT_EQ(run.exit_code, 0) << run.output;
    EXPECT_NE(run.output.find("placing C against A, B"), std::string::npos) << run.output;
    const auto transforms = nlohmann::json::parse(test::read_text(out / "transforms.json"));
    ASSERT_EQ(transforms.at("order"), nlohmann::json({"A", "B", "C"}));
    const auto& frames = transforms.at("output");
    ASSERT_EQ(frames.size(), 303u);  // A's timing is kept: none of its frames is dropped
    const Scene loaded = load_scene(scene);
    ObjectSource a(loaded.object("A")), b(loaded.object("B")), c(loaded.object("C"));
    ReferenceVoxeliser voxeliser;
    int previous_a = 0;
    for (const auto& f : frames) {
        SCOPED_TRACE(f.at("frame").dump());
        EXPECT_EQ(f.at("A").at("x").get<double>(), 0.0);
        EXPECT_EQ(f.at("A").at("yaw_deg").get<double>(), 0.0);
        EXPECT_EQ(f.at("A").at("source").get<int>(), previous_a + 1);  // every frame of A in turn
        previous_a = f.at("A").at("source").get<int>();
        const MeshFrame body_a = test::moved_parts(a, f.at("A"), off_right_arm), body_b = test::moved_parts(b, f.at("B"), off_right_arm);
        const MeshFrame body_c = test::moved_parts(c, f.at("C"), off_right_arm), whole_c = test::moved_parts(c, f.at("C"), whole_body);
        EXPECT_EQ(test::shared_voxels(body_a, body_b, 0.03, voxeliser), 0u);
        EXPECT_EQ(test::shared_voxels(body_a, body_c, 0.03, voxeliser), 0u);
        EXPECT_EQ(test::shared_voxels(test::moved_parts(b, f.at("B"), whole_body), whole_c, 0.03, voxeliser), 0u);
    }
    const auto result = nlohmann::json::parse(test::read_text(out / "result.json"));
    ASSERT_EQ(result.at("stages").size(), 2u);
    EXPECT_EQ(result.at("stages")[1].at("against"), nlohmann::json({"A", "B"}));
    EXPECT_EQ(result.at("pairs")[2].at("pair"), "B&C");
    EXPECT_EQ(result.at("pairs")[2].at("overlapping_frames"), 0);
    std::ifstream csv(out / "frames.csv");
    std::string line;
    std::getline(csv, line);
    EXPECT_EQ(line, "frame,pair,overlap_voxels,overlap_cm3,gap_mm");
    int rows = 0;
    while (std::getline(csv, line)) ++rows;
    EXPECT_EQ(rows, 3 * 303);
    EXPECT_EQ(std::distance(fs::directory_iterator(out / "frames"), fs::directory_iterator()), 303);
}

}  // namespace
}  // namespace amhv
