// Scene files and the sweep command: validation with file, line and key; the resolved scene; the
// sweep's outputs (identical for both backends, byte-identical reruns, readable feasibility maps).
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfInputFile.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "src/body/shapes.hpp"
#include "src/core/error.hpp"
#include "src/results/group_vdb.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"
#include "support.hpp"

namespace amhv {
namespace {

namespace fs = std::filesystem;

using test::read_text;
using test::write_obj;

// Two small performers on disk: A (a body and a separate fist mesh that moves forward, a view
// track) and B (a body with a hand, labelled per vertex), 10 frames each.
struct SceneFixture {
    test::TempDir dir;
    fs::path scene;

    explicit SceneFixture(const std::string& type = "0&0b", bool b_hand_moves = true) {
        const fs::path root = dir.path();
        for (const char* sub : {"a", "fist", "b", "b_labels"}) fs::create_directories(root / sub);
        std::ofstream track(root / "a_track.csv");
        track << "frame,eye_x,eye_y,eye_z,gaze_x,gaze_y,gaze_z\n";
        for (int f = 0; f < 10; ++f) {
            const double s = f / 9.0;
            write_obj(root / "a" / fmt::format("{:04d}.obj", f), shapes::capsule({0, 0, 0.4}, {0, 0, 1.4}, 0.2, 3, 10));
            write_obj(root / "fist" / fmt::format("{:04d}.obj", f), shapes::sphere({0.25 + 0.3 * s, 0, 1.2}, 0.06, 6, 10));
            track << fmt::format("{},0.05,0,1.6,1,0,-0.1\n", f);
            const double hx = b_hand_moves ? 0.55 - 0.3 * s : 0.4;
            test::write_labelled_obj(root / "b" / fmt::format("{:04d}.obj", f), root / "b_labels" / fmt::format("{:04d}.txt", f),
                                     {{"body", shapes::capsule({0, 0, 0.4}, {0, 0, 1.4}, 0.2, 3, 10)},
                                      {"hand", shapes::sphere({hx, 0.02, 1.2}, 0.06, 6, 10)}});
        }
        scene = root / "scene.toml";
        std::ofstream(scene) << fmt::format(R"([sampling]
voxel = 0.03
angle_step_deg = 30

[objects.A]
meshes = "a/%04d.obj"
track = "a_track.csv"

[objects.B]
meshes = "b/%04d.obj"
labels = "b_labels/%04d.txt"
facing_deg = 180

[[segments]]
a = [0, 9]
b = [0, 9]
type = "{}"
interest = {{ A = {{ meshes = "fist/%04d.obj" }}, B = {{ parts = ["hand"] }} }}
fidelity = {{ A = "whole_minus_interest", B = {{ parts_except = ["hand"] }} }}
visibility = {{ enabled = true, half_angle_deg = 40 }}
)",
                                            type);
    }
};

TEST(Scene, CheckPrintsTheResolvedScene) {
    SceneFixture fixture;
    auto result = test::run_amhv("check '" + fixture.scene.string() + "'");
    EXPECT_EQ(result.exit_code, 0) << result.output;
    for (const char* expected : {"normalised_frames = 10", "type = '0&0b'", "half_angle_deg = 40", "parts_except = [ 'hand' ]", "angles = 12"})
        EXPECT_NE(result.output.find(expected), std::string::npos) << expected << "\n" << result.output;
}

// Signed volume of a closed mesh (divergence theorem): positive when the faces wind outward.
double signed_volume(const TriangleMesh& mesh) {
    double v = 0;
    for (const auto& t : mesh.triangles) v += mesh.vertices[t[0]].dot(mesh.vertices[t[1]].cross(mesh.vertices[t[2]])) / 6;
    return v;
}

// A capture in a left-handed, y-up frame (x right, y up, z away) and 0.3 m above its floor:
// `axes = "x,z,y"` (a reflection) brings it into the scene with outward faces, and floor = "auto"
// or floor = 0.3 puts its lowest points at z = 0. `amhv check` says what auto found.
TEST(Scene, AxesAndFloorBringACaptureIntoTheScene) {
    test::TempDir dir;
    const fs::path root = dir.path();
    fs::create_directories(root / "m");
    // In scene terms: a box from (0.1, 0.2, 0.3) to (0.5, 0.4, 1.3), and a tilted capsule; written
    // in the file's frame (file x = x, file y = z, file z = y).
    TriangleMesh scene_mesh = shapes::box(Vec3(0.1, 0.2, 0.3), Vec3(0.5, 0.4, 1.3));
    scene_mesh.append(shapes::capsule(Vec3(0.3, 0.3, 1.4), Vec3(0.6, 0.5, 1.7), 0.05, 3, 8));
    TriangleMesh file_mesh = scene_mesh;
    for (Vec3& v : file_mesh.vertices) v = Vec3(v.x(), v.z(), v.y());
    for (auto& t : file_mesh.triangles) std::swap(t[1], t[2]);  // the mirrored file's own outward winding
    for (int f = 0; f < 4; ++f) write_obj(root / "m" / fmt::format("{:04d}.obj", f), file_mesh);

    UnitsAndAxes units;
    units.axes = parse_axes("x,z,y", "test");
    EXPECT_TRUE(units.axes->reflects());
    EXPECT_FALSE(parse_axes("x,-z,y", "test").reflects());
    EXPECT_EQ(units.axes->describe(), "x,z,y");
    EXPECT_THROW(parse_axes("x,x,y", "test"), Error);
    EXPECT_THROW(parse_axes("x,y", "test"), Error);
    const TriangleMesh read = read_mesh(root / "m/0000.obj", units);
    EXPECT_GT(signed_volume(read), 0.07);
    EXPECT_NEAR(signed_volume(read), signed_volume(scene_mesh), 1e-6);  // OBJ text keeps about 6 digits
    for (std::size_t i = 0; i < read.vertices.size(); ++i) EXPECT_NEAR((read.vertices[i] - scene_mesh.vertices[i]).norm(), 0, 1e-6);

    for (const char* floor : {"\"auto\"", "0.3"}) {
        std::ofstream(root / "scene.toml") << fmt::format(R"([sampling]
voxel = 0.05
angle_step_deg = 90
[objects.A]
meshes = "m/%04d.obj"
axes = "x,z,y"
floor = {0}
[objects.B]
meshes = "m/%04d.obj"
axes = "x,z,y"
floor = {0}
[[segments]]
a = [0, 3]
b = [0, 3]
type = "0&0b"
)",
                                                          floor);
        const Scene scene = load_scene(root / "scene.toml");
        ObjectSource a(scene.a);
        double low = 1e9;
        for (const BodyPart& part : a.frame_parts(2))
            for (const Vec3& v : part.mesh.vertices) low = std::min(low, v.z());
        EXPECT_NEAR(low, 0.0, 1e-6) << floor;
        auto check = test::run_amhv(fmt::format("check '{}'", (root / "scene.toml").string()));
        EXPECT_EQ(check.exit_code, 0) << check.output;
        EXPECT_NE(check.output.find("axes = 'x,z,y'"), std::string::npos) << check.output;
        if (std::string(floor) == "0.3") continue;
        EXPECT_NE(check.output.find("# object A: floor = \"auto\" found 0.3000 m (5th percentile of the lowest points of 4 frames"), std::string::npos)
            << check.output;
    }
}

TEST(Scene, ShippedExampleIsValid) {
    Scene scene = load_scene(test::source_dir() / "data/scenes/handshake.toml");
    ASSERT_EQ(scene.segments.size(), 1u);
    EXPECT_EQ(scene.segments[0].type.name(), "0&0a");
    EXPECT_EQ(scene.a.frame_last, 303);
}

TEST(Scene, SweepBackendsAgreeAndRerunsAreByteIdentical) {
    SceneFixture fixture;
    const fs::path out = fixture.dir.path();
    const std::string scene = fmt::format("'{}'", fixture.scene.string());
    auto vulkan = test::run_amhv("sweep " + scene + " --no-timings --csv --out '" + (out / "vk").string() + "'");
    ASSERT_EQ(vulkan.exit_code, 0) << vulkan.output;
    auto cpu = test::run_amhv("sweep " + scene + " --no-timings --csv --backend cpu --out '" + (out / "cpu").string() + "'");
    ASSERT_EQ(cpu.exit_code, 0) << cpu.output;
    auto again = test::run_amhv("sweep " + scene + " --no-timings --csv --out '" + (out / "vk2").string() + "'");
    ASSERT_EQ(again.exit_code, 0) << again.output;

    const std::string csv = read_text(out / "vk/segment_1/solutions.csv");
    EXPECT_EQ(csv, read_text(out / "cpu/segment_1/solutions.csv"));
    auto json = nlohmann::json::parse(read_text(out / "vk/result.json"));
    auto json_cpu = nlohmann::json::parse(read_text(out / "cpu/result.json"));
    EXPECT_EQ(json["segments"], json_cpu["segments"]);
    const auto& segment = json["segments"][0];
    const std::uint64_t solutions = segment["solutions"];
    EXPECT_GT(solutions, 0u);
    EXPECT_EQ(std::uint64_t(std::count(csv.begin(), csv.end(), '\n')), solutions + 1);
    std::uint64_t accounted = solutions;
    for (const char* constraint : {"contact", "dictionary", "fidelity", "visibility"}) accounted += segment["rejected"][constraint].get<std::uint64_t>();
    EXPECT_EQ(accounted, segment["poses_tested"].get<std::uint64_t>());

    // Byte-identical rerun, feasibility maps and the group's volume included (amhv replaces the
    // random UUID OpenVDB stamps on a file with a hash of its content); the group as the CPU
    // backend found it, read back, is the same set.
    for (const auto& entry : fs::recursive_directory_iterator(out / "vk")) {
        if (!entry.is_regular_file()) continue;
        fs::path twin = out / "vk2" / fs::relative(entry.path(), out / "vk");
        EXPECT_EQ(read_text(entry.path()), read_text(twin)) << entry.path();
    }
    const results::GroupLattice lattice = results::group_lattice(load_scene(fixture.scene), 1, PoseRange{});
    EXPECT_EQ(results::read_group_vdb(out / "vk" / "segment_1" / "group.vdb", lattice),
              results::read_group_vdb(out / "cpu" / "segment_1" / "group.vdb", lattice));

    // The maps: one EXR per angle whose `passed` = 4 pixels are exactly the solutions.
    std::uint64_t solution_pixels = 0;
    for (int k = 0; k < 12; ++k) {
        Imf::InputFile file((out / fmt::format("vk/segment_1/feasibility/angle_{:03d}.exr", k)).c_str());
        ASSERT_NE(file.header().channels().findChannel("passed"), nullptr);
        auto window = file.header().dataWindow();
        const int width = window.max.x - window.min.x + 1, height = window.max.y - window.min.y + 1;
        std::vector<float> passed(std::size_t(width) * height);
        Imf::FrameBuffer buffer;
        buffer.insert("passed", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(passed.data()), sizeof(float), sizeof(float) * width));
        file.setFrameBuffer(buffer);
        file.readPixels(window.min.y, window.max.y);
        solution_pixels += std::uint64_t(std::count(passed.begin(), passed.end(), 4.0f));
    }
    EXPECT_EQ(solution_pixels, solutions);
    EXPECT_TRUE(fs::exists(out / "vk/segment_1/feasibility/montage.png"));
}

// 0&0 (c) needs B to leave every contact voxel before A arrives; B's hand never moves, so no pose
// qualifies: an answer (exit 0), unless --require-solutions.
TEST(Scene, EmptySolutionGroupIsAnAnswer) {
    SceneFixture fixture("0&0c", false);
    const std::string scene = fmt::format("'{}'", fixture.scene.string());
    auto result = test::run_amhv("sweep " + scene + " --out '" + (fixture.dir.path() / "out").string() + "'");
    EXPECT_EQ(result.exit_code, 0) << result.output;
    EXPECT_NE(result.output.find("no solution among"), std::string::npos) << result.output;
    EXPECT_NE(result.output.find("dictionary"), std::string::npos);
    auto required = test::run_amhv("sweep " + scene + " --require-solutions --out '" + (fixture.dir.path() / "out2").string() + "'");
    EXPECT_NE(required.exit_code, 0);
    EXPECT_NE(required.output.find("--require-solutions"), std::string::npos) << required.output;
}

struct BadScene {
    const char* name;
    const char* from;  // text of the fixture's scene to replace
    const char* to;
    const char* expected;  // in the one-line error
};

class SceneBadInput : public ::testing::TestWithParam<BadScene> {};

TEST_P(SceneBadInput, OneLineErrorWithLineAndKey) {
    SceneFixture fixture;
    const BadScene& bad = GetParam();
    test::replace_in_file(fixture.scene, bad.from, bad.to);
    const fs::path out = fixture.dir.path() / "out";
    for (const char* command : {"check", "sweep"}) {
        auto result = test::run_amhv(std::string(command) + " '" + fixture.scene.string() + "'" +
                                     (std::string(command) == "sweep" ? " --out '" + out.string() + "'" : ""));
        EXPECT_NE(result.exit_code, 0) << result.output;
        EXPECT_EQ(std::count(result.output.begin(), result.output.end(), '\n'), 1) << result.output;
        EXPECT_EQ(result.output.rfind("amhv: error: ", 0), 0u) << result.output;
        EXPECT_NE(result.output.find("scene.toml"), std::string::npos) << result.output;
        EXPECT_NE(result.output.find(bad.expected), std::string::npos) << result.output;
        EXPECT_FALSE(fs::exists(out));
    }
}

INSTANTIATE_TEST_SUITE_P(
    Scene, SceneBadInput,
    ::testing::Values(
        BadScene{"UnknownKey", "voxel = 0.03", "voxel = 0.03\nvoxle = 2", "scene.toml:3: sampling.voxle: unknown key"},
        BadScene{"WrongType", "voxel = 0.03", "voxel = \"fine\"", "scene.toml:2: sampling.voxel: must be a number"},
        BadScene{"OutOfRange", "voxel = 0.03", "voxel = -1", "sampling.voxel: -1 is out of range"},
        BadScene{"AngleStep", "angle_step_deg = 30", "angle_step_deg = 7", "angle_step_deg: 7 does not divide 360"},
        BadScene{"UnknownType", "type = \"0&0b\"", "type = \"hug\"", "segments[1].type: unknown interaction type 'hug'"},
        BadScene{"BeyondSequence", "a = [0, 9]", "a = [0, 12]", "segments[1].a: frames 0..12 are beyond object A's frames 0..9"},
        BadScene{"Reversed", "b = [0, 9]", "b = [9, 0]", "segments[1].b: first frame 9 is after last frame 0"},
        BadScene{"Overlapping", "visibility = { enabled = true, half_angle_deg = 40 }",
                 "visibility = { enabled = true, half_angle_deg = 40 }\n[[segments]]\na = [5, 9]\nb = [5, 9]\ntype = \"+&-\"",
                 "segments[2].a: overlaps or comes before key segment 1"},
        BadScene{"BothSources", "meshes = \"a/%04d.obj\"", "meshes = \"a/%04d.obj\"\nbvh = \"x.bvh\"",
                 "objects.A.meshes: give exactly one of 'meshes'"},
        BadScene{"TPoseOnMeshes", "meshes = \"a/%04d.obj\"", "meshes = \"a/%04d.obj\"\ntpose = \"skip\"",
                 "objects.A.tpose: only a BVH object has a T-pose frame"},
        BadScene{"PartsWithoutLabels", "A = { meshes = \"fist/%04d.obj\" }", "A = { parts = [\"hand\"] }",
                 "object A has no part labels"},
        BadScene{"MissingType", "type = \"0&0b\"", "", "segments[1].type: is missing"},
        BadScene{"BadHalfAngle", "half_angle_deg = 40", "half_angle_deg = 120", "visibility.half_angle_deg: 120 is out of range"},
        BadScene{"Syntax", "[sampling]", "[sampling", "scene.toml:1"}),
    [](const auto& test_info) { return std::string(test_info.param.name); });

}  // namespace
}  // namespace amhv

namespace amhv {
namespace {

// A box as the volume of interest: A's body voxels inside the box (its upper half, where B's hand
// comes), in the capture frame.
TEST(Scene, BoxInterestSweeps) {
    SceneFixture fixture;
    test::replace_in_file(fixture.scene, "A = { meshes = \"fist/%04d.obj\" }", "A = { box = { min = [-0.3, -0.3, 1.0], max = [0.3, 0.3, 1.5] } }");
    // B's hand points away from its facing in this fixture: leave visibility out of this test.
    test::replace_in_file(fixture.scene, "enabled = true", "enabled = false");
    const std::string scene = fmt::format("'{}'", fixture.scene.string());
    auto result = test::run_amhv("sweep " + scene + " --no-maps --out '" + (fixture.dir.path() / "out").string() + "'");
    ASSERT_EQ(result.exit_code, 0) << result.output;
    auto json = nlohmann::json::parse(read_text(fixture.dir.path() / "out/result.json"));
    EXPECT_GT(json["segments"][0]["solutions"].get<std::uint64_t>(), 0u) << result.output;
    EXPECT_EQ(json["segments"][0]["interest"]["A"], "box [-0.3, -0.3, 1] - [0.3, 0.3, 1.5]");
    auto cpu = test::run_amhv("sweep " + scene + " --no-maps --backend cpu --out '" + (fixture.dir.path() / "cpu").string() + "'");
    ASSERT_EQ(cpu.exit_code, 0) << cpu.output;
    EXPECT_EQ(read_text(fixture.dir.path() / "out/segment_1/group.vdb"), read_text(fixture.dir.path() / "cpu/segment_1/group.vdb"));
}

}  // namespace
}  // namespace amhv

namespace amhv {
namespace {

// A part name that no label file uses is an error naming the object and the part.
TEST(Scene, UnknownPartInLabelFilesIsAnError) {
    SceneFixture fixture;
    test::replace_in_file(fixture.scene, "B = { parts = [\"hand\"] }", "B = { parts = [\"hnad\"] }");
    const fs::path out = fixture.dir.path() / "out";
    auto result = test::run_amhv(fmt::format("sweep '{}' --out '{}'", fixture.scene.string(), out.string()));
    EXPECT_NE(result.exit_code, 0);
    EXPECT_NE(result.output.find("object B has no part 'hnad'"), std::string::npos) << result.output;
    EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace amhv
