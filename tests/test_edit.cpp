// `amhv edit` end to end (docs/method.md sections 7, 8 and 10) on two small separately captured
// performers: the timeline, the chosen pose reproduced by the per-frame transforms, the meshes,
// reuse of a sweep, both backends, byte-identical reruns, and the empty-group rules.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <fstream>
#include <numbers>
#include <random>
#include <set>
#include <sstream>

#include <unistd.h>

#include <fmt/format.h>
#include <cairo.h>
#include <gtest/gtest.h>
#include <tiny_gltf.h>
#include <nlohmann/json.hpp>

#include "src/body/shapes.hpp"
#include "src/edit/edit.hpp"
#include "src/edit/frame_check.hpp"
#include "src/edit/timeline.hpp"
#include "host/reference/voxelise_reference.hpp"
#include "src/voxelise/voxelise_vulkan.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"
#include "support.hpp"

namespace amhv {
namespace {

namespace fs = std::filesystem;
using test::read_text;

// A's root walks along +x, stands still over frames 15..24 while reaching forward with a hand,
// then walks on (40 frames). B was captured elsewhere and later (45 frames): it walks along +y and
// stands over frames 20..29 reaching along +y. B's capture frame is placed 5 m away.
// A step of 2 cm a frame, standing still for frames stop_first..stop_last.
double walk(int f, int stop_first, int stop_last) {
    const double step = 0.02;
    if (f < stop_first) return step * f;
    if (f <= stop_last) return step * stop_first;
    return step * (stop_first + f - stop_last);
}

// Where each performer of EditFixture stands at frame f (A: 40 frames, B: 45): by default A walks
// along x and stops for frames 15-24, B along y and stops for 20-29.
struct FixtureWalks {
    std::function<Eigen::Vector2d(int)> a = [](int f) { return Eigen::Vector2d(walk(f, 15, 24), 0); };
    std::function<Eigen::Vector2d(int)> b = [](int f) { return Eigen::Vector2d(0, walk(f, 20, 29)); };
};

struct EditFixture {
    test::TempDir dir;
    fs::path scene;

    // `b_floor`: B's capture sits this much higher (a camera that disagrees on the floor).
    explicit EditFixture(const std::string& type = "0&0a", const std::string& extra = "", double b_floor = 0, const FixtureWalks& walks = FixtureWalks()) {
        const fs::path root = dir.path();
        for (const char* sub : {"a", "a_labels", "b", "b_labels"}) fs::create_directories(root / sub);
        auto body = [](const Eigen::Vector2d& at, const Eigen::Vector2d& forward, double floor, const fs::path& mesh, const fs::path& labels) {
            const Eigen::Vector2d hand = at + 0.3 * forward;
            test::write_labelled_obj(mesh, labels, {{"body", shapes::capsule({at.x(), at.y(), 0.4 + floor}, {at.x(), at.y(), 1.4 + floor}, 0.2, 3, 10)},
                                                    {"hand", shapes::sphere({hand.x(), hand.y(), 1.2 + floor}, 0.06, 6, 10)}});
        };
        for (int f = 0; f < 40; ++f) body(walks.a(f), {1, 0}, 0, root / "a" / fmt::format("{:04d}.obj", f), root / "a_labels" / fmt::format("{:04d}.txt", f));
        for (int f = 0; f < 45; ++f)
            body(walks.b(f), {0, 1}, b_floor, root / "b" / fmt::format("{:04d}.obj", f), root / "b_labels" / fmt::format("{:04d}.txt", f));
        scene = root / "scene.toml";
        std::ofstream(scene) << fmt::format(R"([sampling]
voxel = 0.03
angle_step_deg = 30

[objects.A]
meshes = "a/%04d.obj"
labels = "a_labels/%04d.txt"
facing_deg = 0

[objects.B]
meshes = "b/%04d.obj"
labels = "b_labels/%04d.txt"
facing_deg = 90
placement = {{ x = 5.0, y = 1.0, yaw_deg = 0.0 }}

[[segments]]
a = [15, 24]
b = [20, 29]
type = "{}"
interest = {{ A = {{ parts = ["hand"] }}, B = {{ parts = ["hand"] }} }}
fidelity = {{ A = {{ parts = ["body"] }}, B = {{ parts = ["body"] }} }}
{}
)",
                                            type, extra);
    }
    std::string quoted() const { return fmt::format("'{}'", scene.string()); }
};

nlohmann::json read_json(const fs::path& p) { return nlohmann::json::parse(read_text(p)); }

Eigen::Vector2d apply(const nlohmann::json& t, const Eigen::Vector2d& p) {
    const double yaw = t.at("yaw_deg").get<double>() * std::numbers::pi / 180;
    return Eigen::Rotation2Dd(yaw) * p + Eigen::Vector2d(t.at("x").get<double>(), t.at("y").get<double>());
}

// Pixels of a picture's left `share` that are shaded orange (red over blue by `margin`) and blue.
std::pair<int, int> orange_and_blue(cairo_surface_t* picture, double share, int margin) {
    int orange = 0, blue = 0;
    for (int y = 0; y < cairo_image_surface_get_height(picture); ++y) {
        const auto* row = reinterpret_cast<const std::uint32_t*>(cairo_image_surface_get_data(picture) + y * cairo_image_surface_get_stride(picture));
        for (int x = 0; x < int(cairo_image_surface_get_width(picture) * share); ++x) {
            const int r = int(row[x] >> 16 & 255), b = int(row[x] & 255);
            orange += r > b + margin;
            blue += b > r + margin;
        }
    }
    return {orange, blue};
}

// B's first vertex in an edited frame's PLY (A's vertices come first; the header says how many).
Vec3 first_vertex_of_b(const fs::path& ply_file) {
    const std::string ply = read_text(ply_file);
    const std::size_t header_end = ply.find("end_header\n") + 11;
    std::istringstream header(ply.substr(0, header_end));
    std::string line;
    std::size_t a_vertices = 0;
    while (std::getline(header, line))
        if (line.rfind("comment object B: vertices ", 0) == 0) a_vertices = std::stoul(line.substr(27));
    EXPECT_GT(a_vertices, 0u);
    float stored[3];
    std::memcpy(stored, ply.data() + header_end + a_vertices * 15, sizeof(stored));
    return Vec3(stored[0], stored[1], stored[2]);
}

// The first vertex of an OBJ file.
Vec3 first_obj_vertex(const fs::path& obj_file) {
    std::ifstream obj(obj_file);
    std::string tag;
    double x = 0, y = 0, z = 0;
    while (obj >> tag && tag != "v") {}
    obj >> x >> y >> z;
    return Vec3(x, y, z);
}

// scene.glb holds every output frame of both performers as its own node, named by performer,
// output frame and source frame, shown only on its frame by a STEP scale animation at A's frame
// rate; its vertices are the PLY frames' (y-up); the validator accepts it; --no-glb skips it.
TEST(Edit, SceneGlbPlaysEveryOutputFrame) {
    EditFixture fixture;
    const fs::path out = fixture.dir.path() / "edit";
    auto run = test::run_amhv("edit " + fixture.quoted() + " --out '" + out.string() + "' --no-timings");
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const auto valid = test::validate_gltf(out / "scene.glb");
    EXPECT_EQ(valid.exit_code, 0) << valid.output;
    EXPECT_NE(valid.output.find(": 0 errors, 0 warnings"), std::string::npos) << valid.output;
    const auto result = read_json(out / "result.json");
    EXPECT_EQ(result.at("output").at("scene"), "scene.glb");
    EXPECT_EQ(result.at("output").at("scene_bytes").get<std::uint64_t>(), fs::file_size(out / "scene.glb"));

    tinygltf::Model model;
    tinygltf::TinyGLTF loader;
    std::string error, warning;
    ASSERT_TRUE(loader.LoadBinaryFromFile(&model, &error, &warning, (out / "scene.glb").string())) << error;
    const auto transforms = read_json(out / "transforms.json");
    const int frames = transforms.at("frames").get<int>();
    ASSERT_EQ(model.nodes.size(), std::size_t(2 * frames + 1));
    ASSERT_EQ(model.animations.size(), 1u);
    EXPECT_EQ(model.animations[0].channels.size(), std::size_t(2 * frames));
    const double fps = 25;  // the fixture's mesh sequences: the default rate
    for (int k : {0, 20, frames - 1})
        for (int o = 0; o < 2; ++o) {
            const int n = 2 * k + o;
            const int source = transforms.at("output").at(std::size_t(k)).at(o == 0 ? "A" : "B").at("source").get<int>();
            EXPECT_EQ(model.nodes[std::size_t(n)].name, fmt::format("{} frame {:04d} src {:04d}", "AB"[o], k, source));
            const tinygltf::AnimationChannel& channel = model.animations[0].channels[std::size_t(n)];
            EXPECT_EQ(channel.target_node, n);
            EXPECT_EQ(channel.target_path, "scale");
            const tinygltf::AnimationSampler& sampler = model.animations[0].samplers[std::size_t(channel.sampler)];
            EXPECT_EQ(sampler.interpolation, "STEP");
            const tinygltf::Accessor& times = model.accessors[std::size_t(sampler.input)];
            const auto* t = reinterpret_cast<const float*>(model.buffers[0].data.data() + model.bufferViews[std::size_t(times.bufferView)].byteOffset);
            EXPECT_FLOAT_EQ(t[k > 0 ? 1 : 0], float(k / fps)) << k;  // shown from its frame's time
        }
    // Frame 20's B: its first vertex is the PLY's, with z up turned to y up.
    const tinygltf::Mesh& mesh = model.meshes[std::size_t(model.nodes[41].mesh)];
    const tinygltf::Accessor& positions = model.accessors[std::size_t(mesh.primitives[0].attributes.at("POSITION"))];
    const auto* p = reinterpret_cast<const float*>(model.buffers[0].data.data() + model.bufferViews[std::size_t(positions.bufferView)].byteOffset);
    const Vec3 ply = first_vertex_of_b(out / "frames/0020.ply");
    EXPECT_FLOAT_EQ(p[0], float(ply.x()));
    EXPECT_FLOAT_EQ(p[1], float(ply.z()));
    EXPECT_FLOAT_EQ(p[2], float(-ply.y()));

    auto skipped = test::run_amhv("edit " + fixture.quoted() + " --no-glb --no-frames --out '" + (fixture.dir.path() / "none").string() + "'");
    ASSERT_EQ(skipped.exit_code, 0) << skipped.output;
    EXPECT_FALSE(fs::exists(fixture.dir.path() / "none" / "scene.glb"));
    EXPECT_TRUE(read_json(fixture.dir.path() / "none" / "result.json").at("output").at("scene").is_null());
}

// A transition that runs B through A: A stands; after the handshake B, facing A, walks on at 4 cm a
// frame, straight through where A stands. The paper's paths put one inside the other; the edit
// separates them (checked here from transforms.json alone, re-voxelised by the CPU reference) or
// names the transition it cannot free. The check is the same on both backends, frame by frame.
TEST(Edit, ATransitionThroughThePartnerIsSeparated) {
    FixtureWalks walks;
    walks.a = [](int) { return Eigen::Vector2d(0, 0); };
    walks.b = [](int f) { return Eigen::Vector2d(0, f < 30 ? 0.0 : 0.04 * (f - 29)); };
    EditFixture fixture("0&0a", "prefer = { distance_m = 0.6, thetaA_deg = 0.0, thetaB_deg = 0.0 }", 0, walks);
    const fs::path root = fixture.dir.path();
    const fs::path& scene = fixture.scene;
    const std::string quoted = fmt::format("'{}'", scene.string());
    for (const char* backend : {"vulkan", "cpu"}) {
        auto run = test::run_amhv(fmt::format("edit {} --backend {} --allow-transition-overlap --no-frames --no-glb --no-timings --out '{}'", quoted,
                                              backend, (root / backend).string()));
        ASSERT_EQ(run.exit_code, 0) << run.output;
    }
    EXPECT_EQ(read_text(root / "cpu/frames.csv"), read_text(root / "vulkan/frames.csv"));
    const auto kept = read_json(root / "vulkan/result.json").at("transitions");
    ASSERT_EQ(kept.size(), 2u);
    EXPECT_GT(kept[1].at("frames_overlapping").get<int>(), 3) << kept.dump();  // the paper's path runs B through A
    EXPECT_EQ(kept[1].at("separation_rounds").get<int>(), 0);

    auto run = test::run_amhv(fmt::format("edit {} --no-frames --no-glb --no-timings --out '{}'", quoted, (root / "separated").string()));
    if (run.exit_code != 0) {
        EXPECT_NE(run.output.find("transition 1 (output frames"), std::string::npos) << run.output;
        EXPECT_NE(run.output.find("--allow-transition-overlap"), std::string::npos) << run.output;
        return;
    }
    const auto result = read_json(root / "separated/result.json");
    for (const auto& t : result.at("transitions")) EXPECT_EQ(t.at("frames_overlapping").get<int>(), 0) << t.dump();
    EXPECT_GT(result.at("transitions")[1].at("separation_rounds").get<int>(), 0);
    EXPECT_EQ(test::overlapping_transitional_frames(scene, root / "separated/transforms.json", 0.03), std::vector<int>{});
}

TEST(Edit, TimelineNormalisesEveryPairOfSegments) {
    EditFixture fixture;
    const Timeline t = make_timeline(load_scene(fixture.scene));
    ASSERT_EQ(t.segments.size(), 3u);
    EXPECT_EQ(t.segments[0].length, 15);  // A 0..14 (15), B 0..19 (20)
    EXPECT_EQ(t.segments[1].length, 10);
    EXPECT_EQ(t.segments[2].length, 15);  // A 25..39 (15), B 30..44 (15)
    EXPECT_EQ(t.length(), 40);
    EXPECT_EQ(t.frame_b[1], 1);   // floor(1 * 20 / 15)
    EXPECT_EQ(t.frame_b[14], 18);  // floor(14 * 20 / 15)
    EXPECT_EQ(t.frame_a[15], 15);
    EXPECT_EQ(t.frame_b[15], 20);
    EXPECT_EQ(t.frame_a[39], 39);
    EXPECT_EQ(t.frame_b[39], 44);
}

TEST(Edit, TransformsReproduceTheChosenPoseAndTheMeshesFollowThem) {
    EditFixture fixture;
    const fs::path out = fixture.dir.path() / "edit";
    auto run = test::run_amhv("edit " + fixture.quoted() + " --out '" + out.string() + "' --no-timings --csv");
    ASSERT_EQ(run.exit_code, 0) << run.output;
    EXPECT_NE(run.output.find("key segment 1: chosen"), std::string::npos) << run.output;
    for (const char* f : {"result.json", "transforms.json", "paths.svg", "paths.png", "views/key_1.png", "segment_1/solutions.csv",
                          "frames/0000.ply", "frames/0039.ply"})
        EXPECT_TRUE(fs::exists(out / f)) << f;
    EXPECT_FALSE(fs::exists(out / "frames/0040.ply"));
    // The key view shows both objects: shaded orange (red > blue) and shaded blue (blue > red) pixels.
    cairo_surface_t* view = cairo_image_surface_create_from_png((out / "views/key_1.png").c_str());
    ASSERT_EQ(cairo_surface_status(view), CAIRO_STATUS_SUCCESS);
    EXPECT_EQ(cairo_image_surface_get_width(view), 800);
    const auto [orange, blue] = orange_and_blue(view, 1.0, 60);
    cairo_surface_destroy(view);
    EXPECT_GT(orange, 1000);
    EXPECT_GT(blue, 1000);

    const auto result = read_json(out / "result.json");
    const auto transforms = read_json(out / "transforms.json");
    const auto& seg = result.at("segments").at(0);
    ASSERT_GT(seg.at("solutions").get<int>(), 0);
    const auto& chosen = seg.at("chosen");
    // The chosen pose is one row of the solution group.
    const std::string row = fmt::format("{:.6f},{:.6f},{:.6f},{:.6f},", chosen.at("x").get<double>(), chosen.at("y").get<double>(),
                                        chosen.at("z").get<double>(), chosen.at("theta_deg").get<double>());
    EXPECT_NE(read_text(out / "segment_1/solutions.csv").find(fmt::format("\n{}", row)), std::string::npos) << row;
    ASSERT_EQ(transforms.at("frames").get<int>(), 40);
    ASSERT_EQ(transforms.at("output").size(), 40u);

    // Over the key segment, A^-1 B is the sweep's pose: p -> R(theta) (p - C^B) + C^A + (x, y).
    const auto ra = seg.at("root_m").at("A"), rb = seg.at("root_m").at("B");
    const Eigen::Vector2d ca(ra[0].get<double>(), ra[1].get<double>()), cb(rb[0].get<double>(), rb[1].get<double>());
    const double theta = chosen.at("theta_deg").get<double>() * std::numbers::pi / 180;
    const Eigen::Vector2d offset(chosen.at("x").get<double>(), chosen.at("y").get<double>());
    for (int k = 15; k < 25; ++k) {
        const auto& frame = transforms.at("output").at(std::size_t(k));
        EXPECT_EQ(frame.at("segment").get<std::string>(), "key 1");
        EXPECT_EQ(frame.at("A").at("source").get<int>(), k);
        EXPECT_EQ(frame.at("B").at("source").get<int>(), k + 5);
        for (const Eigen::Vector2d& p : {Eigen::Vector2d(0.1, 0.7), Eigen::Vector2d(-1.3, 0.2)}) {
            const Eigen::Vector2d in_scene = apply(frame.at("B"), p);
            const double yaw_a = frame.at("A").at("yaw_deg").get<double>() * std::numbers::pi / 180;
            const Eigen::Vector2d in_a = Eigen::Rotation2Dd(-yaw_a) * (in_scene - Eigen::Vector2d(frame.at("A").at("x").get<double>(),
                                                                                                  frame.at("A").at("y").get<double>()));
            const Eigen::Vector2d expected = Eigen::Rotation2Dd(theta) * (p - cb) + ca + offset;
            EXPECT_NEAR((in_a - expected).norm(), 0, 1e-5) << "frame " << k;  // roots as the sweep used them: 1/4096 voxel
        }
    }
    // Transitional frames move smoothly: no jump between consecutive edited roots beyond walking speed.
    for (const char* o : {"A", "B"})
        for (int k = 1; k < 40; ++k) {
            const auto& r0 = transforms.at("output").at(std::size_t(k - 1)).at(o).at("root");
            const auto& r1 = transforms.at("output").at(std::size_t(k)).at(o).at("root");
            EXPECT_LT(std::hypot(r1[0].get<double>() - r0[0].get<double>(), r1[1].get<double>() - r0[1].get<double>()), 0.08)
                << o << " frame " << k;
        }
    EXPECT_EQ(result.at("paths").size(), 4u);  // two transitional segments, two objects
    EXPECT_FALSE(result.contains("timings_s"));

    // Frame 20's PLY: B's first vertex is B's source frame 25 vertex 0 moved by B's transform.
    const Vec3 stored = first_vertex_of_b(out / "frames/0020.ply");
    const Vec3 source = first_obj_vertex(fixture.dir.path() / "b/0025.obj");
    const Eigen::Vector2d moved = apply(transforms.at("output").at(20).at("B"), {source.x(), source.y()});
    EXPECT_NEAR(stored.x(), moved.x(), 1e-5);
    EXPECT_NEAR(stored.y(), moved.y(), 1e-5);
    EXPECT_NEAR(stored.z(), source.z(), 1e-5);
}

// Two captures that disagree on the floor by 15 cm: no planar placement joins the hands; z_range
// finds B lowered, the edit lowers B by the chosen z over the key segment (transforms and PLY), and
// holds it through the transitions around it.
TEST(Edit, ZRangeLowersTheHigherCapture) {
    {
        EditFixture flat("0&0a", "", 0.15);
        auto run = test::run_amhv("edit " + flat.quoted() + " --no-frames --out '" + (flat.dir.path() / "e").string() + "'");
        EXPECT_EQ(run.exit_code, 1) << run.output;
        EXPECT_NE(run.output.find("has no solution"), std::string::npos) << run.output;
    }
    EditFixture fixture("0&0a", "z_range = [-0.2, -0.05]\ncontact_tolerance = 0.02", 0.15);
    const fs::path out = fixture.dir.path() / "edit";
    auto run = test::run_amhv("edit " + fixture.quoted() + " --out '" + out.string() + "' --no-timings --csv");
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const auto result = read_json(out / "result.json");
    const auto& seg = result.at("segments").at(0);
    EXPECT_EQ(seg.at("range").at("z_m"), nlohmann::json({-0.18, -0.06}));
    const double z = seg.at("chosen").at("z").get<double>();
    EXPECT_LE(z, -0.06 + 1e-9);
    EXPECT_GE(z, -0.18 - 1e-9);
    EXPECT_NEAR(z / 0.03, std::round(z / 0.03), 1e-9);
    const std::string csv = read_text(out / "segment_1/solutions.csv");
    EXPECT_EQ(csv.rfind("x,y,z,theta_deg,L,thetaA_deg,thetaB_deg\n", 0), 0u);
    EXPECT_NE(csv.find(fmt::format("\n{:.6f},{:.6f},{:.6f},", seg.at("chosen").at("x").get<double>(), seg.at("chosen").at("y").get<double>(), z)),
              std::string::npos);
    const auto transforms = read_json(out / "transforms.json");
    for (int k = 0; k < 40; ++k) {
        const auto& frame = transforms.at("output").at(std::size_t(k));
        EXPECT_EQ(frame.at("A").at("z").get<double>(), 0.0) << k;
        EXPECT_NEAR(frame.at("B").at("z").get<double>(), z, 1e-12) << k;  // one key segment: held before and after
        EXPECT_NEAR(frame.at("B").at("matrix")[2][3].get<double>(), z, 1e-12) << k;
    }
    // Frame 20's PLY: B's first vertex is its source vertex lowered by z.
    EXPECT_NEAR(first_vertex_of_b(out / "frames/0020.ply").z(), first_obj_vertex(fixture.dir.path() / "b/0025.obj").z() + z, 1e-5);
}

// `near` (docs/method.md section 5): the hands pass within 9 cm at some frame and never overlap.
// It is 0&0 (b) on A's hand grown by within_m with the whole bodies as fidelity: the same group,
// byte for byte, as that spelled out; none of its members is a 0&0 (b) member (there the hands
// overlap); both backends agree; the chosen pose's hand spheres (6 cm) have a gap in (0, 9 cm]
// up to the voxel (3 cm).
TEST(Edit, NearPassesWithinTheDistanceAndNeverTouches) {
    const std::string fidelity = "fidelity = { A = { parts = [\"body\"] }, B = { parts = [\"body\"] } }";
    auto group = [](EditFixture& f, const std::string& name, const std::string& backend) {
        const fs::path out = f.dir.path() / name;
        auto run = test::run_amhv("edit " + f.quoted() + " --backend " + backend + " --no-frames --no-timings --csv --out '" + out.string() + "'");
        EXPECT_EQ(run.exit_code, 0) << name << ": " << run.output;
        return out;
    };
    EditFixture near("near", "within_m = 0.09");
    test::replace_in_file(near.scene, fidelity, "");
    const fs::path out = group(near, "near", "vulkan"), cpu = group(near, "cpu", "cpu");
    const std::string members = read_text(out / "segment_1/solutions.csv");
    EXPECT_EQ(read_text(cpu / "segment_1/solutions.csv"), members);
    EXPECT_GT(std::count(members.begin(), members.end(), '\n'), 2);
    const auto seg = read_json(out / "result.json").at("segments").at(0);
    EXPECT_EQ(seg.at("type"), "near");

    EditFixture spelled("0&0b", "contact_tolerance = 0.09");
    test::replace_in_file(spelled.scene, fidelity, "fidelity = { A = \"whole\", B = \"whole\" }");
    EXPECT_EQ(read_text(group(spelled, "spelled", "vulkan") / "segment_1/solutions.csv"), members);

    EditFixture touch("0&0b");
    std::set<std::string> touching;
    std::istringstream lines(read_text(group(touch, "touch", "vulkan") / "segment_1/solutions.csv"));
    for (std::string line; std::getline(lines, line);) touching.insert(line);
    std::istringstream near_lines(members);
    std::string line;
    std::getline(near_lines, line);  // the header
    for (int n = 0; std::getline(near_lines, line) && n < 100000; ++n) EXPECT_EQ(touching.count(line), 0u) << line;

    // The chosen pose, frame by frame over the key: the hand spheres' gap never below zero (up to
    // the voxel), and within 9 cm (up to the voxel) at some frame.
    const auto transforms = read_json(out / "transforms.json");
    const auto key = std::find_if(transforms.at("segments").begin(), transforms.at("segments").end(),
                                  [](const nlohmann::json& s) { return s.at("name") == "key 1"; });
    ASSERT_NE(key, transforms.at("segments").end());
    double nearest = 1e9;
    for (int m = key->at("output_frames")[0].get<int>(); m <= key->at("output_frames")[1].get<int>(); ++m) {
        const auto& frame = transforms.at("output").at(std::size_t(m));
        const int fa = frame.at("A").at("source").get<int>(), fb = frame.at("B").at("source").get<int>();
        const Eigen::Vector2d a = apply(frame.at("A"), {walk(fa, 15, 24) + 0.3, 0.0});
        const Eigen::Vector2d b = apply(frame.at("B"), {0.0, walk(fb, 20, 29) + 0.3});
        const double gap = (a - b).norm() - 0.12;
        EXPECT_GT(gap, -0.03) << m;
        nearest = std::min(nearest, gap);
    }
    EXPECT_LE(nearest, 0.09 + 0.06);
}

// Tolerance that still touches (docs/method.md section 7c): with a 9 cm contact_tolerance and an
// intent that asks for the roots 0.81 m apart, the DP chooses hands that hover; the edit then moves
// B the least distance at which the hands meet without the tolerance (6 cm spheres on 3 cm voxels:
// a gap of at most one voxel at every key frame).
TEST(Edit, ContactToleranceStillTouches) {
    EditFixture fixture("0&0a", "contact_tolerance = 0.09\nprefer = { distance_m = 0.81, weight = 100 }");
    const fs::path out = fixture.dir.path() / "e";
    auto run = test::run_amhv("edit " + fixture.quoted() + " --no-frames --no-timings --out '" + out.string() + "'");
    ASSERT_EQ(run.exit_code, 0) << run.output;
    EXPECT_NE(run.output.find("so that the parts touch without contact_tolerance"), std::string::npos) << run.output;
    const auto touch = read_json(out / "result.json").at("segments").at(0).at("touch_up");
    EXPECT_TRUE(touch.at("touches").get<bool>());
    EXPECT_GE(touch.at("moved_m").get<double>(), 0.03 - 1e-9);
    EXPECT_LE(touch.at("moved_m").get<double>(), 0.09 + 1e-9);
    const auto transforms = read_json(out / "transforms.json");
    const auto key = std::find_if(transforms.at("segments").begin(), transforms.at("segments").end(),
                                  [](const nlohmann::json& s) { return s.at("name") == "key 1"; });
    ASSERT_NE(key, transforms.at("segments").end());
    for (int m = key->at("output_frames")[0].get<int>(); m <= key->at("output_frames")[1].get<int>(); ++m) {
        const auto& frame = transforms.at("output").at(std::size_t(m));
        const int fa = frame.at("A").at("source").get<int>(), fb = frame.at("B").at("source").get<int>();
        const Eigen::Vector2d a = apply(frame.at("A"), {walk(fa, 15, 24) + 0.3, 0.0});
        const Eigen::Vector2d b = apply(frame.at("B"), {0.0, walk(fb, 20, 29) + 0.3});
        EXPECT_LE((a - b).norm() - 0.12, 0.03) << m;
    }
}

TEST(Edit, ReusesASweepAndGivesTheSameBytesOnBothBackendsAndOnReruns) {
    EditFixture fixture;
    const fs::path root = fixture.dir.path();
    ASSERT_EQ(test::run_amhv("sweep " + fixture.quoted() + " --no-maps --no-timings --out '" + (root / "sweep").string() + "'").exit_code, 0);
    for (const std::string name : {"direct", "again", "cpu", "reused"}) {
        std::string args = "edit " + fixture.quoted() + " --no-timings --no-frames --out '" + (root / name).string() + "'";
        if (name == "cpu") args += " --backend cpu";
        if (name == "reused") args += " --from-sweep '" + (root / "sweep").string() + "'";
        auto run = test::run_amhv(args);
        ASSERT_EQ(run.exit_code, 0) << name << ": " << run.output;
    }
    const std::string transforms = read_text(root / "direct/transforms.json");
    for (const char* name : {"again", "cpu", "reused"}) EXPECT_EQ(read_text(root / name / "transforms.json"), transforms) << name;
    EXPECT_EQ(read_text(root / "again/result.json"), read_text(root / "direct/result.json"));
    EXPECT_EQ(read_text(root / "again/paths.png"), read_text(root / "direct/paths.png"));
    EXPECT_EQ(read_text(root / "cpu/views/key_1.png"), read_text(root / "direct/views/key_1.png"));
    EXPECT_EQ(read_text(root / "again/paths.svg"), read_text(root / "direct/paths.svg"));
    EXPECT_FALSE(fs::exists(root / "direct/frames"));
    // The group's store is group.vdb; the CSV only on request (--csv).
    EXPECT_TRUE(fs::exists(root / "sweep/segment_1/group.vdb"));
    EXPECT_FALSE(fs::exists(root / "sweep/segment_1/solutions.csv"));
    EXPECT_FALSE(fs::exists(root / "direct/segment_1/solutions.csv"));
    EXPECT_TRUE(read_json(root / "direct/result.json").at("segments").at(0).at("files").at("solutions").is_null());
}

TEST(Edit, FromSweepOfAnotherSceneIsRefused) {
    EditFixture fixture;
    EditFixture other("0&0a", "tolerance = 2");
    const fs::path root = fixture.dir.path();
    ASSERT_EQ(test::run_amhv("sweep " + other.quoted() + " --no-maps --out '" + (root / "sweep").string() + "'").exit_code, 0);
    auto run = test::run_amhv("edit " + fixture.quoted() + " --from-sweep '" + (root / "sweep").string() + "' --out '" + (root / "e").string() + "'");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.output.find("result.json: key segment 1 was swept with other"), std::string::npos) << run.output;
    EXPECT_FALSE(fs::exists(root / "e"));
    run = test::run_amhv("edit " + fixture.quoted() + " --from-sweep '" + (root / "nothing").string() + "' --out '" + (root / "e").string() + "'");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.output.find("nothing/result.json: cannot open"), std::string::npos) << run.output;
}

TEST(Edit, AnEmptyGroupStopsTheEditUnlessAllowed) {
    // An interest box where A has no voxel is an error of the scene, not an empty group.
    EditFixture fixture("0&0a");
    test::replace_in_file(fixture.scene, "A = { parts = [\"hand\"] }", "A = { box = { min = [-5.0, -5.0, 3.0], max = [5.0, 5.0, 3.2] } }");
    const fs::path root = fixture.dir.path();
    auto run = test::run_amhv("edit " + fixture.quoted() + " --out '" + (root / "e").string() + "'");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.output.find("volume of interest is empty"), std::string::npos) << run.output;

    // An impossible pair: the bodies must touch at every frame (interest) and never share a voxel
    // (fidelity), so every pose in contact fails fidelity and the group is empty.
    EditFixture clash("0&0a");
    test::replace_in_file(clash.scene, "interest = { A = { parts = [\"hand\"] }, B = { parts = [\"hand\"] } }",
                          "interest = { A = { parts = [\"body\"] }, B = { parts = [\"body\"] } }");
    const fs::path croot = clash.dir.path();
    run = test::run_amhv("edit " + clash.quoted() + " --out '" + (croot / "e").string() + "'");
    EXPECT_NE(run.exit_code, 0);
    EXPECT_NE(run.output.find("key segment 1 (0&0a) has no solution"), std::string::npos) << run.output;
    EXPECT_NE(run.output.find("--allow-empty"), std::string::npos);
    EXPECT_FALSE(fs::exists(croot / "e"));

    run = test::run_amhv("edit " + clash.quoted() + " --allow-empty --no-frames --out '" + (croot / "e").string() + "'");
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const auto result = read_json(croot / "e/result.json");
    EXPECT_TRUE(result.at("segments").at(0).at("chosen").at("captured_placement").get<bool>());
    // B keeps its captured placement (x 5, y 1, yaw 0), up to the lattice rounding of the pose.
    const auto transforms = read_json(croot / "e/transforms.json");
    const auto& b = transforms.at("output").at(20).at("B");
    EXPECT_NEAR(b.at("x").get<double>(), 5.0, 0.03);
    EXPECT_NEAR(b.at("y").get<double>(), 1.0, 0.03);
    EXPECT_NEAR(b.at("yaw_deg").get<double>(), 0.0, 1e-9);
}

}  // namespace
}  // namespace amhv

namespace amhv {
namespace {

// Rewrites an OBJ of the fixture as a textured capture would be: a material library one folder
// up, a texture coordinate and a normal per vertex, and a material on the faces.
void texture_obj(const fs::path& file) {
    std::istringstream in(read_text(file));
    std::string v_lines, vt_lines, vn_lines, f_lines;
    int n = 0;
    for (std::string line; std::getline(in, line);) {
        std::istringstream words(line);
        std::string tag;
        words >> tag;
        if (tag == "v") {
            double x, y, z;
            words >> x >> y >> z;
            v_lines += line + "\n";
            vt_lines += fmt::format("vt {} {}\n", (n % 17) / 16.0, (n % 13) / 12.0);
            const Vec3 normal = Vec3(std::cos(n * 0.3), std::sin(n * 0.3), 0.5).normalized();
            vn_lines += fmt::format("vn {:.6f} {:.6f} {:.6f}\n", normal.x(), normal.y(), normal.z());
            ++n;
        } else if (tag == "f") {
            int a, b, c;
            words >> a >> b >> c;
            f_lines += fmt::format("f {0}/{0}/{0} {1}/{1}/{1} {2}/{2}/{2}\n", a, b, c);
        }
    }
    std::ofstream(file) << "# a textured capture\nmtllib ../materials/skin.mtl\no performer\n" << v_lines << vt_lines << vn_lines
                        << "usemtl skin\ns 1\n" << f_lines;
}

std::vector<std::string> lines_of(const std::string& text) {
    std::vector<std::string> lines;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
    return lines;
}

// OBJ input with UVs, normals and a textured material keeps them: frames/B_NNNN.obj holds the
// source frame's lines unchanged but for positions and normals (moved exactly as transforms.json
// says, in the file's units) and the library's name (a copy, with its texture, in the same
// layout); scene.glb carries the UVs (v flipped), the material and the embedded PNG.
TEST(Edit, TexturedObjFramesKeepTheirAppearance) {
    EditFixture fixture;
    const fs::path root = fixture.dir.path();
    for (int f = 0; f < 45; ++f) texture_obj(root / "b" / fmt::format("{:04d}.obj", f));
    fs::create_directories(root / "materials/tex");
    std::ofstream(root / "materials/skin.mtl") << "newmtl skin\nKd 0.8 0.6 0.5\nmap_Kd tex/skin.png\n";
    cairo_surface_t* texture = cairo_image_surface_create(CAIRO_FORMAT_RGB24, 4, 4);
    ASSERT_EQ(cairo_surface_write_to_png(texture, (root / "materials/tex/skin.png").c_str()), CAIRO_STATUS_SUCCESS);
    cairo_surface_destroy(texture);

    const fs::path out = root / "edit";
    // The frames name a library in a folder beside theirs: refused until the scene allows that
    // folder (files_root), so that no file outside what the user gave is read or copied.
    auto outside = test::run_amhv("edit " + fixture.quoted() + " --out '" + out.string() + "' --no-timings");
    EXPECT_EQ(outside.exit_code, 1) << outside.output;
    EXPECT_NE(outside.output.find(".obj:2: material library '../materials/skin.mtl' lies outside"), std::string::npos) << outside.output;
    std::string scene = read_text(fixture.scene);
    const std::string b_meshes = "meshes = \"b/%04d.obj\"";
    scene.replace(scene.find(b_meshes), b_meshes.size(), b_meshes + "\nfiles_root = \".\"");
    std::ofstream(fixture.scene) << scene;
    auto run = test::run_amhv("edit " + fixture.quoted() + " --out '" + out.string() + "' --no-timings");
    ASSERT_EQ(run.exit_code, 0) << run.output;
    EXPECT_EQ(read_json(out / "result.json").at("output").at("obj_files").get<int>(), 40);
    EXPECT_FALSE(fs::exists(out / "frames/A_0000.obj"));  // A's frames have no appearance to keep
    const auto transforms = read_json(out / "transforms.json");
    for (int k : {0, 20, 39}) {
        const auto& move = transforms.at("output").at(std::size_t(k)).at("B");
        const fs::path source = root / "b" / fmt::format("{:04d}.obj", move.at("source").get<int>());
        const auto before = lines_of(read_text(source));
        const auto after = lines_of(read_text(out / "frames" / fmt::format("B_{:04d}.obj", k)));
        ASSERT_EQ(before.size(), after.size());
        const double yaw = move.at("yaw_deg").get<double>() * std::numbers::pi / 180;
        for (std::size_t i = 0; i < before.size(); ++i) {
            std::istringstream was(before[i]), is(after[i]);
            std::string tag, tag_after;
            was >> tag;
            is >> tag_after;
            ASSERT_EQ(tag, tag_after) << i;
            if (tag == "v" || tag == "vn") {
                Vec3 p, q;
                was >> p.x() >> p.y() >> p.z();
                is >> q.x() >> q.y() >> q.z();
                const Eigen::Vector2d xy = tag == "v" ? apply(move, {p.x(), p.y()}) : Eigen::Vector2d(Eigen::Rotation2Dd(yaw) * Eigen::Vector2d(p.x(), p.y()));
                const double z = tag == "v" ? p.z() + move.at("z").get<double>() : p.z();
                EXPECT_NEAR((q - Vec3(xy.x(), xy.y(), z)).norm(), 0, 1e-6) << before[i];
            } else if (tag == "mtllib") {
                std::string library;
                is >> library;
                EXPECT_EQ(library, "B_materials/materials/skin.mtl");
                EXPECT_EQ(read_text(out / "frames" / library), read_text(root / "materials/skin.mtl"));
            } else {
                EXPECT_EQ(before[i], after[i]);  // UVs, faces, material names, groups: the same bytes
            }
        }
    }
    EXPECT_EQ(read_text(out / "frames/B_materials/materials/tex/skin.png"), read_text(root / "materials/tex/skin.png"));

    const auto valid = test::validate_gltf(out / "scene.glb");
    EXPECT_EQ(valid.exit_code, 0) << valid.output;
    EXPECT_NE(valid.output.find(": 0 errors"), std::string::npos) << valid.output;
    tinygltf::Model model;
    tinygltf::TinyGLTF loader;
    std::string error, warning;
    ASSERT_TRUE(loader.LoadBinaryFromFile(&model, &error, &warning, (out / "scene.glb").string())) << error;
    ASSERT_EQ(model.images.size(), 1u);
    EXPECT_EQ(model.images[0].mimeType, "image/png");
    const tinygltf::Primitive& b20 = model.meshes[std::size_t(model.nodes[41].mesh)].primitives.at(0);
    ASSERT_TRUE(b20.attributes.count("TEXCOORD_0"));
    const tinygltf::Material& material = model.materials.at(std::size_t(b20.material));
    EXPECT_EQ(material.name, "B skin");
    EXPECT_GE(material.pbrMetallicRoughness.baseColorTexture.index, 0);
    EXPECT_NEAR(material.pbrMetallicRoughness.baseColorFactor[1], 0.6, 1e-9);
    // The first corner of the first face is the source's vertex 1: its UV with v flipped.
    const tinygltf::Accessor& uv = model.accessors[std::size_t(b20.attributes.at("TEXCOORD_0"))];
    const auto* t = reinterpret_cast<const float*>(model.buffers[0].data.data() + model.bufferViews[std::size_t(uv.bufferView)].byteOffset);
    const auto source = lines_of(read_text(root / "b" / fmt::format("{:04d}.obj", transforms.at("output").at(20).at("B").at("source").get<int>())));
    int first_corner = 0;
    for (const std::string& line : source)
        if (line.rfind("f ", 0) == 0) {
            first_corner = std::stoi(line.substr(2));
            break;
        }
    EXPECT_FLOAT_EQ(t[0], float(((first_corner - 1) % 17) / 16.0));
    EXPECT_FLOAT_EQ(t[1], float(1.0 - ((first_corner - 1) % 13) / 12.0));
}

}  // namespace
}  // namespace amhv

namespace amhv {
namespace {

// Adds a labelled part to a frame of the fixture (its OBJ and its labels file).
void add_part(const fs::path& obj, const fs::path& labels, const std::string& name, const TriangleMesh& part) {
    std::size_t vertices = 0;
    std::istringstream in(read_text(obj));
    for (std::string line; std::getline(in, line);) vertices += line.rfind("v ", 0) == 0;
    std::ofstream out(obj, std::ios::app), names(labels, std::ios::app);
    out.precision(9);
    for (const Vec3& v : part.vertices) out << "v " << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
    for (const auto& t : part.triangles) out << "f " << t[0] + 1 + vertices << ' ' << t[1] + 1 + vertices << ' ' << t[2] + 1 + vertices << '\n';
    for (std::size_t v = 0; v < part.vertices.size(); ++v) names << name << '\n';
}

// The handshake, after which B steps back holding a pole (8 m, 2 cm thick, at knee height) out in
// front of it: facing A, as the editor's intent prefers, the pole runs through A for the whole
// transition, and pushing the two apart makes no progress (six rounds in a row free no frame and
// lower no overlap: the pole still runs through A). The DP chooses again without
// that key pose (and its cell: the same angles, within 15 cm) until B stands turned enough that
// the pole passes A: every transitional frame free, checked from transforms.json alone; both
// backends give the same files. With limits that keep only poses facing A (one cell), no choice is
// left: the edit names the transition and its frames.
struct PoleFixture {
    FixtureWalks walks;
    std::unique_ptr<EditFixture> fixture;
    explicit PoleFixture(const std::string& extra = "") {
        walks.a = [](int f) { return Eigen::Vector2d(walk(f, 15, 24), 0); };
        walks.b = [](int f) { return Eigen::Vector2d(0, f <= 29 ? walk(f, 20, 29) : 0.4 - 0.02 * (f - 29)); };
        fixture = std::make_unique<EditFixture>("0&0a", "prefer = { distance_m = 0.6, thetaA_deg = 0.0, thetaB_deg = 0.0 }\n" + extra, 0, walks);
        const fs::path root = fixture->dir.path();
        for (int f = 30; f < 45; ++f) {
            const Eigen::Vector2d at = walks.b(f);
            const TriangleMesh pole = shapes::capsule({at.x(), at.y() + 0.25, 0.5}, {at.x(), at.y() + 8, 0.5}, 0.02, 2, 8);
            add_part(root / "b" / fmt::format("{:04d}.obj", f), root / "b_labels" / fmt::format("{:04d}.txt", f), "pole", pole);
        }
    }
};

TEST(Edit, AKeyPoseNoTransitionCanLeaveIsChosenAgain) {
    PoleFixture pole;
    const fs::path root = pole.fixture->dir.path();
    const std::string scene = pole.fixture->quoted();
    auto kept = test::run_amhv(fmt::format("edit {} --allow-transition-overlap --no-frames --no-glb --no-timings --out '{}'", scene, (root / "kept").string()));
    ASSERT_EQ(kept.exit_code, 0) << kept.output;
    const auto paper = read_json(root / "kept/result.json");
    EXPECT_EQ(paper.at("dp").at("choices_tried").get<int>(), 1);
    EXPECT_EQ(paper.at("transitions")[1].at("frames_overlapping").get<int>(), 15);  // the pole through A at every frame

    for (const char* backend : {"vulkan", "cpu"}) {
        auto run = test::run_amhv(fmt::format("edit {} --backend {} --no-frames --no-glb --no-timings --out '{}'", scene, backend, (root / backend).string()));
        ASSERT_EQ(run.exit_code, 0) << run.output;
    }
    EXPECT_EQ(read_text(root / "cpu/frames.csv"), read_text(root / "vulkan/frames.csv"));
    EXPECT_EQ(read_text(root / "cpu/transforms.json"), read_text(root / "vulkan/transforms.json"));
    const auto result = read_json(root / "vulkan/result.json");
    EXPECT_GT(result.at("dp").at("choices_tried").get<int>(), 1);
    EXPECT_LE(result.at("dp").at("choices_tried").get<int>(), kMaxKeyChoices);
    EXPECT_GT(result.at("dp").at("cost").get<double>(), paper.at("dp").at("cost").get<double>());
    const double turned = std::abs(result.at("segments")[0].at("chosen").at("thetaB_deg").get<double>());
    EXPECT_GT(turned, 10.0);  // B no longer faces A
    for (const auto& t : result.at("transitions")) EXPECT_EQ(t.at("frames_overlapping").get<int>(), 0) << t.dump();
    // The choice that stands reports every output frame once, in order, and every transition once,
    // whether its segments were checked afresh or kept from an earlier choice.
    std::istringstream rows(read_text(root / "vulkan/frames.csv"));
    std::string row;
    std::getline(rows, row);
    int frame = 0;
    for (; std::getline(rows, row); ++frame) EXPECT_EQ(row.substr(0, row.find(',')), std::to_string(frame));
    EXPECT_EQ(frame, result.at("output").at("frames").get<int>());
    EXPECT_EQ(result.at("transitions").size(), paper.at("transitions").size());

    EXPECT_EQ(test::overlapping_transitional_frames(pole.fixture->scene, root / "vulkan/transforms.json", 0.03), std::vector<int>{});
}

TEST(Edit, ATransitionNoChoiceCanFreeIsNamed) {
    PoleFixture facing("limits = { thetaA_deg = [-5.0, 5.0], thetaB_deg = [-5.0, 5.0] }");
    const fs::path out = facing.fixture->dir.path() / "out";
    auto run = test::run_amhv(fmt::format("edit {} --no-frames --no-glb --out '{}'", facing.fixture->quoted(), out.string()));
    EXPECT_EQ(run.exit_code, 1) << run.output;
    EXPECT_EQ(test::one_line_error(run), 1) << run.output;
    EXPECT_NE(run.output.find("transition 1 (output frames 25-39) keeps the performers inside each other at frames 25-39"), std::string::npos)
        << run.output;
    EXPECT_NE(run.output.find("no other choice of the key poses around it is left (1 tried)"), std::string::npos) << run.output;
    EXPECT_FALSE(fs::exists(out));
}

// Random scenes where the chosen key pose sends B's walk after the handshake across A (a random
// heading and speed, A walking on or standing): the edit frees every transitional frame (checked
// from transforms.json alone, re-voxelised by the CPU reference) or names the transition it cannot
// free; Vulkan and the CPU reference check every frame alike (frames.csv and transforms.json).
TEST(Edit, RandomCrossingsAreFreedOrNamedAlikeOnBothBackends) {
    std::mt19937 random(34);
    std::uniform_real_distribution<double> u(0, 1);
    int crossed = 0;  // scenes whose paper paths put one performer inside the other
    for (int scene_number = 0; scene_number < 4; ++scene_number) {
        // B faces A at the handshake (the intent) and walks on within 40 degrees of straight ahead:
        // towards A and past it.
        const double heading = (90 + 80 * (u(random) - 0.5)) * std::numbers::pi / 180, speed = 0.02 + 0.03 * u(random);
        const bool a_walks_on = scene_number % 2 == 0;
        FixtureWalks walks;
        walks.a = [a_walks_on](int f) { return Eigen::Vector2d(a_walks_on ? walk(f, 15, 24) : walk(std::min(f, 24), 15, 24), 0); };
        walks.b = [heading, speed](int f) {
            const Eigen::Vector2d stop(0, walk(29, 20, 29));
            return f <= 29 ? Eigen::Vector2d(0, walk(f, 20, 29)) : Eigen::Vector2d(stop + speed * (f - 29) * Eigen::Vector2d(std::cos(heading), std::sin(heading)));
        };
        EditFixture fixture("0&0a", "prefer = { distance_m = 0.6, thetaA_deg = 0.0, thetaB_deg = 0.0 }", 0, walks);
        const fs::path root = fixture.dir.path();
        std::array<test::CommandResult, 2> runs;
        for (int b = 0; b < 2; ++b)
            runs[std::size_t(b)] = test::run_amhv(fmt::format("edit {} --backend {} --no-frames --no-glb --no-timings --out '{}'", fixture.quoted(),
                                                              b ? "cpu" : "vulkan", (root / (b ? "cpu" : "vulkan")).string()));
        SCOPED_TRACE(fmt::format("scene {}: heading {:.0f} deg, {:.3f} m a frame", scene_number, heading * 180 / std::numbers::pi, speed));
        ASSERT_EQ(runs[0].exit_code, runs[1].exit_code) << runs[0].output << runs[1].output;
        if (runs[0].exit_code != 0) {
            EXPECT_EQ(test::one_line_error(runs[0]), 1) << runs[0].output;
            EXPECT_NE(runs[0].output.find("(output frames"), std::string::npos) << runs[0].output;
            continue;
        }
        EXPECT_EQ(read_text(root / "cpu/frames.csv"), read_text(root / "vulkan/frames.csv"));
        EXPECT_EQ(read_text(root / "cpu/transforms.json"), read_text(root / "vulkan/transforms.json"));
        const auto result = read_json(root / "vulkan/result.json");
        for (const auto& t : result.at("transitions")) {
            EXPECT_EQ(t.at("frames_overlapping").get<int>(), 0) << t.dump();
            crossed += t.at("before_separation").at("frames_overlapping").get<int>() > 0;
        }
        EXPECT_EQ(test::overlapping_transitional_frames(fixture.scene, root / "vulkan/transforms.json", 0.03), std::vector<int>{});
    }
    EXPECT_GE(crossed, 2);
}

}  // namespace
}  // namespace amhv

namespace amhv {
namespace {

// Headless Chromium on a page, as a person's browser opens it (software WebGL, no network).
test::CommandResult chromium(const std::string& arguments, const fs::path& profile) {
    return test::run_shell(fmt::format(
        "timeout 300 chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run --disable-background-networking "
        "--disable-component-update --disable-sync --enable-unsafe-swiftshader --use-angle=swiftshader --enable-logging=stderr --v=0 "
        "--window-size=1200,800 --virtual-time-budget=10000 --user-data-dir='{}' {}",
        profile.string(), arguments));
}

// The page (index.html, view/): its data are the folder's own outputs; headless Chromium opens it
// from file://, loads the scene with no script error, steps to a key-segment frame (#frame=N) and
// draws both performers; `amhv view --serve` serves the same files on 127.0.0.1; `amhv view`
// refuses a folder amhv did not write and an output without scene.glb.
TEST(Edit, ThePagePlaysTheSceneAndPlotsTheGroupInABrowser) {
    EditFixture fixture;
    const fs::path root = fixture.dir.path(), out = root / "edit";
    auto run = test::run_amhv("edit " + fixture.quoted() + " --no-frames --no-timings --out '" + out.string() + "'");
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const auto result = read_json(out / "result.json");
    EXPECT_EQ(result.at("output").at("scene_fps").get<double>(), 25.0);
    std::string data = read_text(out / "view/data.js");
    ASSERT_EQ(data.rfind("window.AMHV_DATA = ", 0), 0u);
    const auto page = nlohmann::json::parse(data.substr(19, data.size() - 21));
    EXPECT_EQ(page.at("result"), result);  // the page's data are result.json's, as written
    const auto& group = page.at("groups").at(0);
    EXPECT_EQ(group.at("members").get<int>(), result.at("segments").at(0).at("solutions").get<int>());
    EXPECT_EQ(group.at("rows").size(), group.at("members").get<std::size_t>());  // small: every member
    EXPECT_EQ(page.at("roots").size(), 40u);
    for (const char* file : {"three.min.js", "GLTFLoader.js", "OrbitControls.js", "view.js", "scene.js"}) EXPECT_TRUE(fs::exists(out / "view" / file)) << file;

    const std::string url = fmt::format("'file://{}/index.html#frame=20'", out.string());
    auto dom = chromium("--dump-dom " + url, root / "profile1");
    EXPECT_NE(dom.output.find("<div id=\"status\">ready: frame 20 of 40, key 1</div>"), std::string::npos) << dom.output.substr(0, 3000);
    EXPECT_EQ(dom.output.find("Uncaught"), std::string::npos) << dom.output.substr(0, 3000);
    EXPECT_NE(dom.output.find("Key segment 1 (0&amp;0a)"), std::string::npos);
    // A pick (as a click does): the lines that choose that member, with its descriptors.
    const auto& member = group.at("rows").at(3);
    auto picked = chromium(fmt::format("--dump-dom 'file://{}/index.html#pick=1,3'", out.string()), root / "profile3");
    EXPECT_NE(picked.output.find(fmt::format("prefer = {{ distance_m = {}, thetaA_deg = {}, thetaB_deg = {} }}",
                                             std::round(member[4].get<double>() * 1e4) / 1e4, std::round(member[5].get<double>() * 1e4) / 1e4,
                                             std::round(member[6].get<double>() * 1e4) / 1e4)),
              std::string::npos)
        << picked.output.substr(picked.output.find("<pre>"), 800);
    auto shot = chromium(fmt::format("--screenshot='{}' {}", (root / "page.png").string(), url), root / "profile2");
    cairo_surface_t* png = cairo_image_surface_create_from_png((root / "page.png").c_str());
    ASSERT_EQ(cairo_surface_status(png), CAIRO_STATUS_SUCCESS) << shot.output.substr(0, 2000);
    const auto [orange, blue] = orange_and_blue(png, 0.6, 80);  // the player's side
    cairo_surface_destroy(png);
    EXPECT_GT(orange, 500);
    EXPECT_GT(blue, 500);

    // --serve: the same bytes over HTTP, on this machine only.
    const int port = 20000 + int(::getpid() % 20000);
    auto served = test::run_shell(fmt::format(
        "{} view '{}' --serve {} > '{}/serve.log' 2>&1 & pid=$!; "
        "python3 -c \"import sys,time,urllib.request\nfor i in range(100):\n    try:\n        sys.stdout.buffer.write(urllib.request.urlopen('http://127.0.0.1:{}/view/data.js').read()); break\n    except Exception: time.sleep(0.1)\"; "
        "kill $pid",
        test::amhv_command(), out.string(), port, root.string(), port));
    EXPECT_EQ(served.output, read_text(out / "view/data.js"));

    fs::create_directories(root / "mine");
    auto refused = test::run_amhv(fmt::format("view '{}'", (root / "mine").string()));
    EXPECT_EQ(refused.exit_code, 1);
    EXPECT_NE(refused.output.find("is not an output folder of amhv"), std::string::npos) << refused.output;
    EXPECT_FALSE(fs::exists(root / "mine/index.html"));
    auto bare = test::run_amhv("edit " + fixture.quoted() + " --no-glb --no-frames --out '" + (root / "bare").string() + "'");
    ASSERT_EQ(bare.exit_code, 0) << bare.output;
    EXPECT_FALSE(fs::exists(root / "bare/index.html"));
    auto no_scene = test::run_amhv(fmt::format("view '{}'", (root / "bare").string()));
    EXPECT_EQ(no_scene.exit_code, 1);
    EXPECT_NE(no_scene.output.find("scene.glb"), std::string::npos) << no_scene.output;
}

}  // namespace
}  // namespace amhv


namespace amhv {
namespace {

// A frame's root is the mean of its voxels' centres on the grid covering that frame alone: the
// same bits whatever frames it is computed with (the roots go 32 frames at a time, stacked), on
// both backends, and within rounding of the centres summed one by one. 43 frames of the demo's A:
// two words.
TEST(Edit, AFrameRootIsTheFramesOwn) {
    const Scene scene = load_scene(test::source_dir() / "data/scenes/demo.toml");
    ObjectSource a(scene.a);
    ReferenceVoxeliser reference;
    gpu::VulkanVoxeliser vulkan(test::context());
    const double voxel = scene.sampling.voxel;
    std::vector<int> numbers;
    for (int f = 1; f <= 301; f += 7) numbers.push_back(f);
    const std::vector<Eigen::Vector2d> roots = frame_roots(a, numbers, voxel, reference);
    const std::vector<Eigen::Vector2d> on_vulkan = frame_roots(a, numbers, voxel, vulkan);
    test::expect_no_validation_messages();
    for (std::size_t i = 0; i < numbers.size(); ++i) EXPECT_EQ(on_vulkan[i], roots[i]) << "frame " << numbers[i];
    for (std::size_t i : {std::size_t(3), std::size_t(33)}) {
        EXPECT_EQ(frame_roots(a, {numbers[i]}, voxel, reference).at(0), roots[i]) << "frame " << numbers[i];
        MeshFrame frame;
        for (const BodyPart& part : a.frame_parts(numbers[i])) frame.mesh.append(part.mesh);
        const Amhv alone = voxelise(prepare_voxelisation({&frame}, grid_covering(frame.mesh.bounds(), voxel, "frame")), reference);
        const Vec3 summed = occupied_root(alone);
        EXPECT_NEAR(summed.x(), roots[i].x(), 1e-12) << "frame " << numbers[i];
        EXPECT_NEAR(summed.y(), roots[i].y(), 1e-12) << "frame " << numbers[i];
    }
}

// The gap's nearest pair of voxel centres (a k-d tree on the smaller side, built on the points that
// can beat a first answer, asked nearest-box first with early stops) against brute force: bodies
// apart, interleaved and packed into touching cells, either side the larger.
TEST(FrameCheck, NearestVoxelsIsTheBruteForceMinimum) {
    VoxelGrid grid;
    grid.voxel = 0.01;
    grid.origin = Vec3::Zero();
    grid.dims = {50, 50, 50};
    std::mt19937 random(28);
    for (int round = 0; round < 90; ++round) {
        std::set<std::array<int, 3>> taken;  // the bodies share no voxel
        const auto body = [&](std::size_t count, int lo, int size, Box3& box) {
            std::vector<std::array<double, 3>> points;
            while (points.size() < count) {
                const std::array<int, 3> c{lo + int(random() % unsigned(size)), lo + int(random() % unsigned(size)), lo + int(random() % unsigned(size))};
                if (!taken.insert(c).second) continue;
                points.push_back({double(c[0]), double(c[1]), double(c[2])});
                box.extend(grid.centre(c[0], c[1], c[2]));
            }
            return points;
        };
        const int shape = round % 3;  // apart, interleaved, packed
        Box3 box_a, box_b;
        const auto a = body(1 + random() % 300, shape == 0 ? 0 : shape == 1 ? 10 : 20, shape == 2 ? 9 : 20, box_a);
        const auto b = body(1 + random() % 300, shape == 0 ? 28 : shape == 1 ? 10 : 20, shape == 2 ? 9 : 20, box_b);
        double squared = std::numeric_limits<double>::infinity();
        for (const auto& p : a)
            for (const auto& q : b) squared = std::min(squared, (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]));
        EXPECT_EQ(detail::nearest_voxels(grid, a, b, box_a, box_b), std::sqrt(squared)) << "round " << round;
        EXPECT_EQ(detail::nearest_voxels(grid, b, a, box_b, box_a), std::sqrt(squared)) << "round " << round;
    }
}

// The brute-force answer of the frame check for one output frame: both bodies voxelised on one
// grid by the CPU reference, their shared voxels counted, and with none, the nearest pair of their
// surface voxels (an occupied voxel with an empty 6-neighbour) by trying every pair.
struct CheckedFrame {
    std::size_t overlap = 0;
    std::string gap_mm;  // as frames.csv writes it; empty beyond kGapReach
};
CheckedFrame check_by_brute_force(const MeshFrame& a, const MeshFrame& b, double h) {
    Box3 both = a.mesh.bounds();
    both.extend(b.mesh.bounds());
    ReferenceVoxeliser reference;
    const Amhv volume = voxelise(prepare_voxelisation({&a, &b}, grid_covering(both, h, "brute force")), reference);
    const VoxelGrid& g = volume.grid();
    const auto bits = [&](int x, int y, int z) {
        return x >= 0 && y >= 0 && z >= 0 && x < g.dims[0] && y < g.dims[1] && z < g.dims[2] ? volume.word(0, g.index(x, y, z)) : 0u;
    };
    CheckedFrame checked;
    std::array<std::vector<std::array<int, 3>>, 2> surface;
    for (int z = 0; z < g.dims[2]; ++z)
        for (int y = 0; y < g.dims[1]; ++y)
            for (int x = 0; x < g.dims[0]; ++x) {
                const std::uint32_t w = bits(x, y, z);
                if ((w & 3u) == 3u) ++checked.overlap;
                const std::uint32_t inner = bits(x - 1, y, z) & bits(x + 1, y, z) & bits(x, y - 1, z) & bits(x, y + 1, z) & bits(x, y, z - 1) & bits(x, y, z + 1);
                for (std::size_t body = 0; body < 2; ++body)
                    if ((w >> body) & ~(inner >> body) & 1u) surface[body].push_back({x, y, z});
            }
    if (checked.overlap > 0) {
        checked.gap_mm = "0.0";
        return checked;
    }
    long best = std::numeric_limits<long>::max();
    for (const auto& p : surface[0])
        for (const auto& q : surface[1]) {
            const long dx = p[0] - q[0], dy = p[1] - q[1], dz = p[2] - q[2];
            best = std::min(best, dx * dx + dy * dy + dz * dz);
        }
    const double centres = std::sqrt(double(best)) * h;
    if (centres - h <= kGapReach) checked.gap_mm = fmt::format("{:.1f}", std::max(0.0, centres - h) * 1000);
    return checked;
}

// frames.csv's rows (frame, ..., overlap, ..., gap) against the brute force on the edit's own
// transforms; returns how many frames overlap, have a gap, and lie beyond the reach.
std::array<int, 3> expect_frames_match_brute_force(const fs::path& scene_file, const fs::path& out, const std::string& what) {
    const Scene scene = load_scene(scene_file);
    ObjectSource a(scene.a), b(scene.b);
    const auto transforms = read_json(out / "transforms.json").at("output");
    std::istringstream rows(read_text(out / "frames.csv"));
    std::string row;
    std::getline(rows, row);
    std::array<int, 3> cases{};
    int checked = 0;
    const auto whole = [](const std::string&) { return true; };
    while (std::getline(rows, row)) {
        std::vector<std::string> cells;
        std::stringstream cut(row);
        for (std::string cell; std::getline(cut, cell, ',');) cells.push_back(cell);
        if (cells.size() == 4) cells.emplace_back();  // no gap: the line ends in a comma
        EXPECT_EQ(cells.size(), 5u) << row;
        if (cells.size() != 5) continue;
        const auto& frame = transforms.at(std::size_t(std::stoi(cells[0])));
        const CheckedFrame truth = check_by_brute_force(test::moved_parts(a, frame.at("A"), whole), test::moved_parts(b, frame.at("B"), whole),
                                                        scene.sampling.voxel);
        EXPECT_EQ(cells[2], std::to_string(truth.overlap)) << what << ": " << row;
        EXPECT_EQ(cells[4], truth.gap_mm) << what << ": " << row;
        ++checked;
        cases[0] += truth.overlap > 0;
        cases[1] += truth.overlap == 0 && !truth.gap_mm.empty();
        cases[2] += truth.gap_mm.empty();
    }
    EXPECT_EQ(checked, 40) << what << ": one row per output frame";
    return cases;
}

// Every output frame of edits whose B walks through A and away at four speeds (kept, with
// --allow-transition-overlap) against the brute force: the check voxelises batches of frames on
// one grid and scans only where the two bodies' reaches meet, and must give the same overlaps and
// gaps, from touching to beyond the reach (at 10 cm a frame, one frame's boxes lie just beyond the
// reach while its gap is within it).
TEST(FrameCheck, EveryFrameMatchesTheBruteForce) {
    std::array<int, 3> cases{};
    for (const double speed : {0.08, 0.1, 0.12, 0.15}) {
        FixtureWalks walks;
        walks.a = [](int) { return Eigen::Vector2d(0, 0); };
        walks.b = [speed](int f) { return Eigen::Vector2d(0, f < 30 ? 0.0 : speed * (f - 29)); };
        EditFixture fixture("0&0a", "prefer = { distance_m = 0.6, thetaA_deg = 0.0, thetaB_deg = 0.0 }", 0, walks);
        const fs::path out = fixture.dir.path() / "out";
        auto run = test::run_amhv(fmt::format("edit {} --allow-transition-overlap --no-frames --no-glb --no-page --no-timings --out '{}'",
                                              fixture.quoted(), out.string()));
        ASSERT_EQ(run.exit_code, 0) << run.output;
        const std::array<int, 3> these = expect_frames_match_brute_force(fixture.scene, out, fmt::format("{} m a frame", speed));
        for (std::size_t c = 0; c < 3; ++c) cases[c] += these[c];
    }
    // The walks give every case: frames inside each other, near, and out of reach.
    EXPECT_GE(cases[0], 20);
    EXPECT_GE(cases[1], 6);
    EXPECT_GE(cases[2], 10);
}

// The same walk separated: the rounds' checks that find the bodies inside each other leave their
// other frames' gaps unmeasured (Gaps::UntilAnOverlap), and the check reported, the last round's,
// must still give every frame's gap.
TEST(FrameCheck, SeparatedFramesKeepTheirGaps) {
    FixtureWalks walks;
    walks.a = [](int) { return Eigen::Vector2d(0, 0); };
    walks.b = [](int f) { return Eigen::Vector2d(0, f < 30 ? 0.0 : 0.1 * (f - 29)); };
    EditFixture fixture("0&0a", "prefer = { distance_m = 0.6, thetaA_deg = 0.0, thetaB_deg = 0.0 }", 0, walks);
    const fs::path out = fixture.dir.path() / "out";
    auto run = test::run_amhv(fmt::format("edit {} --no-frames --no-glb --no-page --no-timings --out '{}'", fixture.quoted(), out.string()));
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const auto transitions = read_json(out / "result.json").at("transitions");
    int rounds = 0;
    for (const auto& t : transitions) {
        rounds += t.at("separation_rounds").get<int>();
        EXPECT_EQ(t.at("frames_overlapping").get<int>(), 0) << transitions.dump();
    }
    EXPECT_GE(rounds, 1) << "the walk must need separating: " << transitions.dump();
    // The key segment's hands share voxels; every other frame has its gap.
    const std::array<int, 3> cases = expect_frames_match_brute_force(fixture.scene, out, "separated");
    EXPECT_GE(cases[1], 6) << "frames near each other, with a gap";
}

}  // namespace
}  // namespace amhv
