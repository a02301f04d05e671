// Multi-party scenes (docs/method.md section 11): three or more objects, a pair per key segment,
// the placement order, and the sequential edit in which each object is placed against every object
// placed before it, which stay fixed.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <tiny_gltf.h>
#include <nlohmann/json.hpp>

#include "host/reference/pose_checks.hpp"
#include "host/reference/sweep_reference.hpp"
#include "host/reference/voxelise_reference.hpp"
#include "src/core/normalise.hpp"
#include "src/pipeline/party_stage.hpp"
#include "src/sweep/objects.hpp"
#include "src/sweep/sweep_vulkan.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"
#include "support.hpp"

namespace amhv {
namespace {

namespace fs = std::filesystem;

// The shipped three-person scene (data/scenes/trio.toml: the CMU handshake and a third performer
// from another capture who high-fives A), with its data paths absolute so that it can be written
// elsewhere; `extra_top` goes before its first table and `pair_c` replaces the high five's pair.
std::string trio_scene(const std::string& extra_top = "", const std::string& pair_c = "pair = [\"A\", \"C\"]") {
    std::string text = test::read_text(test::source_dir() / "data/scenes/trio.toml");
    const std::string cmu = fmt::format("\"{}", (test::source_dir() / "data/cmu").string());
    for (std::size_t at; (at = text.find("\"../cmu")) != std::string::npos;) text.replace(at, 7, cmu);
    const std::string high_five = "pair = [\"A\", \"C\"]";
    text.replace(text.find(high_five), high_five.size(), pair_c);
    return extra_top + "\n" + text;
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
    // The two-object commands say why they cannot, in one line, and write nothing.
    for (const char* command : {"sweep", "plan --shards 2"}) {
        const auto run = test::run_amhv(fmt::format("{} '{}' --out '{}'", command, (dir.path() / "trio.toml").string(), (dir.path() / "out").string()));
        EXPECT_EQ(test::one_line_error(run), 1) << run.output;
        EXPECT_NE(run.output.find("has 3 objects; `amhv " + std::string(command).substr(0, std::string(command).find(' ')) + "` takes two"),
                  std::string::npos) << run.output;
        EXPECT_FALSE(fs::exists(dir.path() / "out"));
    }
    const auto from_sweep = test::run_amhv(fmt::format("edit '{}' --from-sweep '{}' --out '{}'", (dir.path() / "trio.toml").string(),
                                                       dir.path().string(), (dir.path() / "out").string()));
    EXPECT_EQ(test::one_line_error(from_sweep), 1) << from_sweep.output;
    EXPECT_NE(from_sweep.output.find("--from-sweep reads a two-object sweep"), std::string::npos) << from_sweep.output;
    EXPECT_FALSE(fs::exists(dir.path() / "out"));
}

TEST(Party, BadPairsAndOrdersGetOneLineNamingTheKey) {
    test::TempDir dir;
    struct Case {
        std::string top, pair, expect;
        std::string from = "", to = "";  // a change to the scene's text
    };
    const Case cases[] = {
        {"", "", "segments[2].pair: is missing"},
        {"", "pair = [\"A\", \"D\"]", "names 'D', which is not one of the scene's objects"},
        {"", "pair = [\"C\", \"A\"]", "segments[2].a: frames 213..303 are beyond object C's frames 0..228"},
        {"order = [\"B\", \"A\", \"C\"]", "pair = [\"A\", \"C\"]", "order: must start with the anchor, A"},
        {"order = [\"A\", \"C\"]", "pair = [\"A\", \"C\"]", "order: must list every object once"},
        {"", "pair = [\"A\", \"C\"]", "gives the truth per object", "\n[truth.B]\n", "\n[truth]\n"},
    };
    for (const Case& c : cases) {
        // A top-level key must come before the first table: trio_scene puts it at the top of the file.
        std::string text = trio_scene(c.top, c.pair);
        if (!c.from.empty()) text.replace(text.find(c.from), c.from.size(), c.to);
        const fs::path scene = write_scene(dir, text);
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
    EXPECT_TRUE(fs::is_regular_file(out / "views/key_1.png") && fs::is_regular_file(out / "views/key_2.png"));
    // Eye views: each of a key segment's pair, seeing every other performer.
    for (const char* view : {"key_1_from_A.png", "key_1_from_B.png", "key_2_from_A.png", "key_2_from_C.png"})
        EXPECT_TRUE(fs::is_regular_file(out / "views" / view)) << view;
    EXPECT_FALSE(fs::exists(out / "views/key_2_from_B.png"));
    // Each key view looks at its pair's meeting with no performer in front of it.
    const auto views = nlohmann::json::parse(test::read_text(out / "result.json")).at("outputs").at("views");
    ASSERT_EQ(views.size(), 2u);
    for (const auto& view : views) EXPECT_EQ(view.at("camera").at("meeting_points_hidden").get<int>(), 0) << view.dump();
    // paths.svg: every performer's path, each with the key segments it takes part in.
    const std::string paths = test::read_text(out / "paths.svg");
    for (const char* legend : {">A (orange)<", ">B (blue)<", ">C (green)<", ">edited path<", ">captured path (at the editor's initial placement)<", ">x (m)<"})
        EXPECT_NE(paths.find(legend), std::string::npos) << legend;
    for (const char* label : {">A: key 1<", ">B: key 1<", ">A: key 2<", ">C: key 2<"}) EXPECT_NE(paths.find(label), std::string::npos) << label;
    EXPECT_EQ(paths.find(">B: key 2<"), std::string::npos);
    EXPECT_TRUE(fs::is_regular_file(out / "paths.png"));
    // The edited takes: A.bvh, B.bvh and C.bvh, each where transforms.json puts its frames.
    test::expect_edited_takes(out, {{"A", &loaded.object("A")}, {"B", &loaded.object("B")}, {"C", &loaded.object("C")}}, transforms);
    // scene.glb: valid for the Khronos validator, every performer on every frame.
    const auto valid = test::validate_gltf(out / "scene.glb");
    EXPECT_NE(valid.output.find(": 0 errors, 0 warnings"), std::string::npos) << valid.output;
    tinygltf::Model model;
    tinygltf::TinyGLTF loader;
    std::string error, warning;
    ASSERT_TRUE(loader.LoadBinaryFromFile(&model, &error, &warning, (out / "scene.glb").string())) << error;
    std::map<char, int> nodes;
    for (const tinygltf::Node& node : model.nodes) ++nodes[node.name[0]];
    EXPECT_EQ(nodes['A'], 303);
    EXPECT_EQ(nodes['B'], 303);
    EXPECT_EQ(nodes['C'], 303);
    ASSERT_EQ(model.materials.size(), 3u);
    EXPECT_EQ(model.materials[2].name, "C");
}

// The three-person edit on both backends at 3 cm and 6 degrees (coarse, so that the sanitizer job
// runs the whole edit for its host code in about 150 s instrumented, where the 1 cm scene above,
// left to the main job, took 270 s): every file is the same bytes, the placements, the check's rows, scene.glb, the edited
// takes and the pictures alike; result.json differs only where it names the backend.
TEST(Party, AThreePersonEditIsTheSameBytesOnBothBackends) {
    test::TempDir dir;
    std::string text = trio_scene();
    text.replace(text.find("voxel = 0.01"), 12, "voxel = 0.03");
    text.replace(text.find("angle_step_deg = 2.0"), 20, "angle_step_deg = 6.0");
    const fs::path scene = write_scene(dir, text);
    for (const char* backend : {"vulkan", "cpu"}) {
        const auto run = test::run_amhv(fmt::format("edit '{}' --backend {} --no-timings --no-page --out '{}'", scene.string(), backend,
                                                    (dir.path() / backend).string()));
        ASSERT_EQ(run.exit_code, 0) << run.output;
        EXPECT_NE(run.output.find("C against A+B"), std::string::npos) << run.output;
    }
    const fs::path vulkan = dir.path() / "vulkan", cpu = dir.path() / "cpu";
    std::size_t files = 0;
    for (const auto& entry : fs::recursive_directory_iterator(vulkan)) {
        if (!entry.is_regular_file()) continue;
        ++files;
        const fs::path name = fs::relative(entry.path(), vulkan);
        // result.json names the backend, and the marker lists result.json's size.
        if (name == "result.json" || name == ".amhv-output") continue;
        EXPECT_TRUE(test::read_text(entry.path()) == test::read_text(cpu / name)) << name;
    }
    std::size_t cpu_files = 0;
    for (const auto& entry : fs::recursive_directory_iterator(cpu)) cpu_files += entry.is_regular_file();
    EXPECT_EQ(cpu_files, files);
    EXPECT_GT(files, 303u);  // a PLY per output frame, and the rest
    auto result_vulkan = nlohmann::json::parse(test::read_text(vulkan / "result.json"));
    auto result_cpu = nlohmann::json::parse(test::read_text(cpu / "result.json"));
    EXPECT_EQ(result_cpu.at("backend"), "cpu");
    for (auto* result : {&result_vulkan, &result_cpu}) result->erase("backend"), result->erase("device");
    EXPECT_TRUE(result_vulkan == result_cpu);
    EXPECT_EQ(result_vulkan.at("stages")[1].at("against"), nlohmann::json({"A", "B"}));
}

// Acceptance: with A and B where the first placement put them, a brute force over the newcomer C's
// poses, each judged pair by pair (against A alone by the reference sweep of the A-C pair, against
// B by the per-frame overlap of B's placed body with C's whole body), finds exactly the poses the
// sequential method's sweep against the group found on Vulkan: none missed, none extra.
TEST(Party, BruteForceOverTheNewcomersPosesFindsWhatTheSequentialSweepFinds) {
    Scene scene = load_scene(test::source_dir() / "data/scenes/trio.toml");
    scene.sampling.voxel = 0.02;
    scene.sampling.angle_step_deg = 6;
    test::TempDir dir;
    std::vector<std::unique_ptr<ObjectSource>> sources;
    for (const std::string& name : scene.order) sources.push_back(std::make_unique<ObjectSource>(scene.object(name)));
    ReferenceVoxeliser voxeliser;
    gpu::VulkanSweeper vulkan(test::context());
    pipeline::Backends backends{voxeliser, vulkan, "vulkan", ""};
    pipeline::EditRunOptions options;
    options.allow_empty = true;
    const pipeline::PartyEdit party = pipeline::edit_party(scene, sources, backends, dir.path(), options);
    ASSERT_EQ(party.stages.size(), 2u);
    const pipeline::PartyStage& stage = party.stages[1];
    const KeySegment& key = stage.scene.segments.at(0);  // its A frames are the group's (output) frames

    pipeline::PartyEdit placed;
    placed.names = {"A", "B"};
    placed.frames = {party.frames[0], party.frames[1]};
    const auto group = pipeline::placed_group(scene, placed, "A", sources);
    const SweepProblem grouped = build_segment(stage.scene, key, *group, *sources[2], voxeliser).problem;

    // The A-C pair alone: A where the editor put it (its source frames), C resampled to A's timing.
    Scene pair_scene = stage.scene;
    pair_scene.a = scene.object("A");
    SweepProblem pair = build_segment(pair_scene, scene.segments.at(1), *sources[0], *sources[2], voxeliser).problem;
    pair.a.root = grouped.a.root;  // the same pose lattice (the partner's root)
    pair.range = grouped.range;
    const SweepResult pair_result = ReferenceSweeper().sweep(pair);

    // B where the first placement put it, on the key segment's normalised frames.
    const NormalisedPair frames = normalise_to_a(key.a[1] - key.a[0] + 1, key.b[1] - key.b[0] + 1);
    std::vector<MeshFrame> b_meshes(std::size_t(frames.length));
    std::vector<ObjectFrame> b_frames(std::size_t(frames.length));
    for (int m = 0; m < frames.length; ++m) {
        b_meshes[std::size_t(m)] = {placed_mesh(party.frames[1][std::size_t(key.a[0] + frames.frames_a[std::size_t(m)])], *sources[1]), "B"};
        b_frames[std::size_t(m)].whole = {&b_meshes[std::size_t(m)]};
    }
    ObjectParts whole;
    whole.interest = PartRule::Whole;
    whole.fidelity = PartRule::Whole;
    SweepProblem apart = grouped;
    apart.a = build_sweep_object("B", b_frames, whole, scene.sampling.voxel, voxeliser);
    apart.a.root = grouped.a.root;
    apart.b.fidelity = apart.b.whole;
    apart.visibility = false;
    const PoseSides sides(apart);

    const SolutionGroup& sequential = stage.sweep.sweeps.at(0).group;
    const PoseRange& r = grouped.range;
    std::uint64_t pair_solutions = 0, brute_solutions = 0, differing = 0;
    for (int l = r.z_first; l <= r.z_last; ++l)
        for (int k = 0; k < r.angles; ++k)
            for (int j = r.j_first; j <= r.j_last; ++j)
                for (int i = r.i_first; i <= r.i_last; ++i) {
                    bool feasible = pair_result.outcomes[pair_result.index(i, j, k, l)] == PoseOutcome::Solution;
                    pair_solutions += feasible;
                    feasible = feasible && keeps_apart(apart, sides, PoseLookup(apart, i, j, k, l));
                    brute_solutions += feasible;
                    differing += feasible != sequential.contains({i, j, k, l});
                }
    std::cout << fmt::format("{} poses: {} pass A alone, {} also keep out of B; the sequential sweep found {}\n", r.size(), pair_solutions,
                             brute_solutions, sequential.size());
    EXPECT_EQ(differing, 0u);
    EXPECT_EQ(brute_solutions, sequential.size());
    EXPECT_GT(brute_solutions, 0u);
    EXPECT_GT(pair_solutions, brute_solutions) << "B rules out none of the poses A alone allows: the test proves little";
}


// A placement with no solution stops the edit with one line naming the object, the objects it was
// placed against, the key segment, the constraint that emptied it and the pose that came nearest;
// nothing is written.
TEST(Party, AnEmptyPlacementNamesTheObjectTheSegmentAndItsNearestMiss) {
    test::TempDir dir;
    const std::string text = trio_scene() + "visibility = { enabled = true, half_angle_deg = 45.0 }\n";  // the high five's: A looks ahead
    const fs::path scene = write_scene(dir, text);
    const auto run = test::run_amhv(fmt::format("edit '{}' --no-frames --no-glb --out '{}'", scene.string(), (dir.path() / "out").string()));
    EXPECT_EQ(test::one_line_error(run), 1) << run.output;
    // (The counts depend on where the first stage put B, which the natural choice decides.)
    for (const char* expected : {"placing C against A, B: ", "key segment 2 (0&0b) has no solution", ", visibility ", "keep C's captured placement",
                                 "its nearest miss", "fails visibility", "(the nearest miss follows)"})
        EXPECT_NE(run.output.find(expected), std::string::npos) << expected << "\n" << run.output;
    EXPECT_EQ(run.output.find("amhv probe"), std::string::npos) << run.output;  // it takes two objects
    EXPECT_FALSE(fs::exists(dir.path() / "out"));
}

}  // namespace
}  // namespace amhv
