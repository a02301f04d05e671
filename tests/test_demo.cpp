// Acceptance of the built-in demo (issue: motion capture input and a real two-person demo): the
// CMU handshake, separated as if captured apart, restored by `amhv demo`. The solution group holds
// the true relative placement; in the edited scene the right hands touch at every handshake frame
// and the bodies (all but the right arms) never share a voxel at any output frame.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <cairo.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "host/reference/voxelise_reference.hpp"
#include "src/io/bvh.hpp"
#include "src/io/mesh_sequence.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"
#include "support.hpp"

namespace amhv {
namespace {

namespace fs = std::filesystem;

bool right_hand(const std::string& name) { return name == "right_hand"; }
bool whole_body(const std::string&) { return true; }
bool fidelity_part(const std::string& name) { return name != "right_hand" && name != "right_forearm" && name != "right_upper_arm"; }

// Pixels of a PNG within `radius` of its centre shaded in performer `colour`'s hue (0: A, orange,
// red well above blue; 1: B, blue, blue well above red).
int pixels_of(const fs::path& png, int colour, double radius) {
    cairo_surface_t* image = cairo_image_surface_create_from_png(png.c_str());
    EXPECT_EQ(cairo_surface_status(image), CAIRO_STATUS_SUCCESS) << png;
    const int width = cairo_image_surface_get_width(image), height = cairo_image_surface_get_height(image);
    int count = 0;
    for (int y = 0; y < height; ++y) {
        const auto* row = reinterpret_cast<const std::uint32_t*>(cairo_image_surface_get_data(image) + y * cairo_image_surface_get_stride(image));
        for (int x = 0; x < width; ++x) {
            const int r = int(row[x] >> 16 & 255), b = int(row[x] & 255);
            if (std::hypot(x - width / 2.0, y - height / 2.0) <= radius) count += colour == 0 ? r > b + 60 : b > r + 60;
        }
    }
    cairo_surface_destroy(image);
    return count;
}

TEST(Demo, RestoresARealHandshakeFromSeparatedCaptures) {
    test::TempDir dir;
    const fs::path out = dir.path() / "demo";
    auto run = test::run_amhv(fmt::format("demo --no-frames --no-timings --out '{}'", out.string()));
    ASSERT_EQ(run.exit_code, 0) << run.output;
    EXPECT_NE(run.output.find("paths.png"), std::string::npos) << run.output;

    const auto result = nlohmann::json::parse(test::read_text(out / "result.json"));
    const auto& segment = result.at("segments").at(0);
    const auto& truth = segment.at("truth");
    EXPECT_TRUE(truth.at("in_group").get<bool>()) << truth.dump();
    EXPECT_LE(truth.at("nearest_solution_m").get<double>(), 0.01 * std::sqrt(2.0));
    // The scene states no intent: the natural choice (docs/method.md section 7b) puts B within 5 cm
    // and 6 degrees of where it was captured (0.41 m and 76 degrees with the paper's objective alone).
    EXPECT_LE(truth.at("chosen_error_m").get<double>(), 0.05) << truth.dump();
    EXPECT_LE(truth.at("chosen_error_deg").get<double>(), 6.0 + 1e-9) << truth.dump();
    EXPECT_EQ(segment.at("natural").at("weight").get<double>(), 10.0);

    const Scene scene = load_scene(test::source_dir() / "data/scenes/demo.toml");
    ObjectSource a(scene.a), b(scene.b);
    ReferenceVoxeliser voxeliser;
    const auto transforms = nlohmann::json::parse(test::read_text(out / "transforms.json"));
    int handshake_frames = 0;
    for (const auto& frame : transforms.at("output")) {
        const int k = frame.at("frame").get<int>();
        if (frame.at("segment").get<std::string>() == "key 1") {
            ++handshake_frames;
            // Touching at the sweep's resolution: the sweep pulls B's voxels onto A's lattice, so the
            // hands re-voxelised in the scene meet within one voxel.
            EXPECT_GT(test::shared_voxels(test::moved_parts(a, frame.at("A"), right_hand), test::moved_parts(b, frame.at("B"), right_hand), scene.sampling.voxel,
                                    voxeliser, 1),
                      0u)
                << "the right hands do not touch at output frame " << k;
        }
        EXPECT_EQ(test::shared_voxels(test::moved_parts(a, frame.at("A"), fidelity_part), test::moved_parts(b, frame.at("B"), fidelity_part), scene.sampling.voxel, voxeliser), 0u)
            << "the bodies interpenetrate at output frame " << k << " (" << frame.at("segment").get<std::string>() << ")";
        // Transitions: the whole bodies never share a voxel (re-voxelised here from transforms.json,
        // independent of the edit's own check).
        if (frame.at("segment").get<std::string>().rfind("transition", 0) == 0) {
            EXPECT_EQ(test::shared_voxels(test::moved_parts(a, frame.at("A"), whole_body), test::moved_parts(b, frame.at("B"), whole_body), scene.sampling.voxel, voxeliser), 0u)
                << "the whole bodies overlap at transitional output frame " << k;
        }
    }
    EXPECT_EQ(handshake_frames, 40);
    // The edit found them overlapping on the paper's paths and separated them.
    int before = 0;
    for (const auto& t : result.at("transitions")) {
        EXPECT_EQ(t.at("frames_overlapping").get<int>(), 0) << t.dump();
        before += t.at("before_separation").at("frames_overlapping").get<int>();
    }
    EXPECT_GT(before, 0);
    const std::string checks = test::read_text(out / "frames.csv");
    EXPECT_EQ(std::count(checks.begin(), checks.end(), '\n'), 284);  // the header and 283 output frames
    // The paper's first-person views: each performer sees the other inside its view cone's circle.
    for (const auto& [file, colour] : {std::pair{"key_1_from_A.png", 1}, std::pair{"key_1_from_B.png", 0}})
        EXPECT_GT(pixels_of(out / "views" / file, colour, 170), 2000) << file;
    // The key view looks at the handshake: no body hides where the hands meet.
    for (const auto& view : result.at("output").at("views")) EXPECT_EQ(view.at("camera").at("meeting_points_hidden").get<int>(), 0) << view.dump();
    // The whole scene in one glTF file the Khronos validator accepts.
    const auto valid = test::validate_gltf(out / "scene.glb");
    EXPECT_EQ(valid.exit_code, 0) << valid.output;
    EXPECT_NE(valid.output.find(": 0 errors"), std::string::npos) << valid.output;
    test::expect_edited_takes(out, {{"A", &scene.a}, {"B", &scene.b}}, transforms);
}

// The second real pair (CMU 20/21, a high five while passing), read as shipped: no T-pose, other
// joint names, Z X Y arm channels. Separated like the demo, the solution group holds the truth
// (within one voxel); the scene states no `prefer`, and the natural score's choice lies within
// 15 cm and 6 degrees of the capture (docs/method.md, 7b, reports it), and the edited right hands
// meet at some frame of the high five while the bodies never interpenetrate.
TEST(Demo, RestoresARealHighFiveFromAnotherSkeleton) {
    test::TempDir dir;
    const fs::path out = dir.path() / "highfive";
    const fs::path scene_file = test::source_dir() / "data/scenes/highfive.toml";
    auto run = test::run_amhv(fmt::format("edit '{}' --no-frames --no-timings --out '{}'", scene_file.string(), out.string()));
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const auto result = nlohmann::json::parse(test::read_text(out / "result.json"));
    const auto& segment = result.at("segments").at(0);
    const auto& truth = segment.at("truth");
    EXPECT_TRUE(truth.at("in_group").get<bool>()) << truth.dump();
    EXPECT_LE(truth.at("chosen_error_m").get<double>(), 0.15) << truth.dump();
    EXPECT_LE(truth.at("chosen_error_deg").get<double>(), 6.0 + 1e-9) << truth.dump();
    EXPECT_FALSE(segment.at("natural").at("chosen").at("reach").is_null()) << segment.at("natural").dump();
    for (const auto& view : result.at("output").at("views")) EXPECT_EQ(view.at("camera").at("meeting_points_hidden").get<int>(), 0) << view.dump();

    const Scene scene = load_scene(scene_file);
    EXPECT_EQ(scene.a.tpose, TPose::Keep);  // no converter T-pose: frame 0 is motion
    ObjectSource a(scene.a), b(scene.b);
    EXPECT_EQ(a.label_names().size(), 16u);  // the capsule body: 14 parts and the two shoulders
    ReferenceVoxeliser voxeliser;
    const auto transforms = nlohmann::json::parse(test::read_text(out / "transforms.json"));
    int touching = 0, key_frames = 0;
    for (const auto& frame : transforms.at("output")) {
        if (frame.at("segment").get<std::string>() == "key 1") {
            ++key_frames;
            touching += test::shared_voxels(test::moved_parts(a, frame.at("A"), right_hand), test::moved_parts(b, frame.at("B"), right_hand), scene.sampling.voxel,
                                      voxeliser, 1) > 0;
        }
        EXPECT_EQ(test::shared_voxels(test::moved_parts(a, frame.at("A"), fidelity_part), test::moved_parts(b, frame.at("B"), fidelity_part), scene.sampling.voxel, voxeliser), 0u)
            << "the bodies interpenetrate at output frame " << frame.at("frame").get<int>();
    }
    EXPECT_EQ(key_frames, 9);
    EXPECT_GE(touching, 1);
    const auto valid = test::validate_gltf(out / "scene.glb");
    EXPECT_EQ(valid.exit_code, 0) << valid.output;
}

}  // namespace
}  // namespace amhv
