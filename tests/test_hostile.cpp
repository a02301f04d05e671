// A corpus of hostile inputs across every reader (BVH, OBJ, PLY, OFF, STL, scene TOML, tracks,
// labels, a sweep folder for --from-sweep, command-line numbers): each generated here, each must
// end in its own exact refusal: a non-zero exit, one "amhv: error:" line naming the file (and line)
// and what is wrong, no crash, no hang, no output folder. docs/scenes.md, "What amhv refuses".
#include <bit>
#include <cstdio>
#include <limits>
#include <cstdlib>
#include <map>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <regex>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "src/results/group_vdb.hpp"
#include "src/sweep/problem.hpp"
#include "src/sweep/solution_group.hpp"

#include "support.hpp"

namespace amhv {
namespace {

namespace fs = std::filesystem;

struct Hostile {
    std::string name;
    // Files to write into the case's folder (relative path -> content); "@cmu" copies the captures,
    // "@sweep" copies a good sweep of scene.toml into sweep/.
    std::vector<std::pair<std::string, std::string>> files;
    std::string arguments;  // {d} is the case's folder
    std::string expected;   // a part of the error line
};

const std::string kTetra = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n";

// A small BVH take: one root joint and a child, `frames` rows of `row`.
std::string bvh(const std::string& frames, const std::string& frame_time, const std::string& row, int rows) {
    std::string text = "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n"
                       " JOINT Chest\n {\n  OFFSET 0 10 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 10 0\n  }\n }\n}\n"
                       "MOTION\nFrames: " + frames + "\nFrame Time: " + frame_time + "\n";
    for (int r = 0; r < rows; ++r) text += row + "\n";
    return text;
}
const std::string kRow = "0 30 0 0 0 0 0 0 0";

// The scene every scene case edits: the handshake at 4 cm / 30 deg (fast), on the copied captures.
const std::string kScene = R"([sampling]
voxel = 0.04
angle_step_deg = 30.0

[objects.A]
bvh = "cmu/18_01.bvh"

[objects.B]
bvh = "cmu/19_01.bvh"

[[segments]]
a = [108, 147]
b = [108, 147]
type = "0&0a"
interest = { A = { parts = ["right_hand"] }, B = { parts = ["right_hand"] } }
fidelity = { A = { parts_except = ["right_upper_arm", "right_forearm", "right_hand"] }, B = { parts_except = ["right_upper_arm", "right_forearm", "right_hand"] } }
)";

std::string scene_with(const std::string& from, const std::string& to) {
    std::string s = kScene;
    const auto at = s.find(from);
    if (at == std::string::npos) ADD_FAILURE() << "scene has no " << from;
    else s.replace(at, from.size(), to);
    return s;
}

// Mesh-sequence scene: A and B are the tetrahedron frames of folder m/ with a track.
const std::string kMeshScene = R"([sampling]
voxel = 0.05
angle_step_deg = 90.0

[objects.A]
meshes = "m/f_%04d.obj"
track = "track.csv"

[objects.B]
meshes = "m/f_%04d.obj"

[[segments]]
a = [0, 1]
b = [0, 1]
type = "0&0b"
)";
const std::string kTrack = "frame,eye_x,eye_y,eye_z,gaze_x,gaze_y,gaze_z\n0,0,0,1.6,1,0,0\n1,0,0,1.6,1,0,0\n";

// kMeshScene with B's parts labelled by l/f_NNNN.txt.
std::string with_labels(std::string scene) {
    const std::string b = "[objects.B]\nmeshes = \"m/f_%04d.obj\"\n";
    return scene.replace(scene.find(b), b.size(), b + "labels = \"l/f_%04d.txt\"\n");
}

std::string mhv(const std::string& input, const std::string& voxel = "0.05") {
    return "mhv --meshes '{d}/" + input + "' --voxel " + voxel + " --backend cpu --out '{d}/out'";
}
const std::string kEditFromSweep = "edit '{d}/scene.toml' --from-sweep '{d}/sweep' --backend cpu --no-frames --out '{d}/out'";

// The good sweep's segment_1/group.vdb, tampered with as `kind` says: the bytes of the file.
std::string tampered_group(const fs::path& good, const std::string& kind) {
    results::GroupLattice lattice = results::read_group_lattice(good);
    const SolutionGroup group = results::read_group_vdb(good, lattice);
    if (kind == "truncated") return test::read_text(good).substr(0, 200);
    SolutionGroup changed;
    const std::size_t keep = kind == "short" ? group.runs().size() - 1 : group.runs().size();
    for (std::size_t r = 0; r < keep; ++r) changed.add_run(group.runs()[r]);
    if (kind == "outside") changed.add_run({0, lattice.angles - 1, 10000, 10000, 10000});
    if (kind == "angle") changed.add_run({0, lattice.angles, 0, 0, 0});
    if (kind == "other-scene") lattice.scene_hash = "0123456789abcdef";
    if (kind == "other-lattice") lattice.voxel = 0.05;
    if (kind == "other-segment") lattice.segment = 2;
    if (kind == "heights") lattice.z_last = 1;  // grids solutions_z0 and solutions_z1, no grid "solutions"
    test::TempDir tmp;
    results::write_group_vdb(tmp.path() / "group.vdb", changed, lattice);
    return test::read_text(tmp.path() / "group.vdb");
}

class HostileInput : public ::testing::TestWithParam<Hostile> {
public:
    static void SetUpTestSuite() {
        folder_ = new test::TempDir();
        fs::copy(test::source_dir() / "data" / "cmu", folder_->path() / "cmu");
        std::ofstream(folder_->path() / "scene.toml") << kScene;
        auto result = test::run_amhv(fmt::format("sweep '{0}/scene.toml' --no-maps --backend cpu --out '{0}/sweep'", folder_->path().string()));
        ASSERT_EQ(result.exit_code, 0) << result.output;
        ASSERT_GT(results::read_group_vdb(good_group(), results::read_group_lattice(good_group())).size(), 3u);
    }
    static fs::path good_group() { return folder_->path() / "sweep" / "segment_1" / "group.vdb"; }
    static void TearDownTestSuite() {
        delete folder_;
        folder_ = nullptr;
    }

protected:
    static test::TempDir* folder_;
};
test::TempDir* HostileInput::folder_ = nullptr;

TEST_P(HostileInput, IsRefusedInOneLine) {
    const Hostile& c = GetParam();
    test::TempDir tmp;
    const fs::path d = tmp.path();
    for (const auto& [path, content] : c.files) {
        if (path == "@cmu") {
            fs::copy(test::source_dir() / "data" / "cmu", d / "cmu");
            continue;
        }
        if (path == "@sweep") {
            fs::copy(folder_->path() / "sweep", d / "sweep", fs::copy_options::recursive);
            continue;
        }
        fs::create_directories((d / path).parent_path());
        if (content == "@remove") {
            fs::remove(d / path);
            continue;
        }
        const std::string text = content.rfind("@group:", 0) == 0 ? tampered_group(good_group(), content.substr(7)) : content;
        std::ofstream(d / path, std::ios::binary) << text;
    }
    const std::string arguments = std::regex_replace(c.arguments, std::regex("\\{d\\}"), d.string());
    const auto result = test::run_shell("timeout 60 " + test::amhv_command() + " " + arguments);
    // 1 for amhv's own refusals; CLI11's parse errors have codes of their own (100..120).
    EXPECT_TRUE(result.exit_code == 1 || (result.exit_code >= 100 && result.exit_code <= 120)) << "exit " << result.exit_code << ": " << result.output;
    EXPECT_EQ(result.output.find("Sanitizer"), std::string::npos) << result.output;
    EXPECT_EQ(result.output.find("runtime error:"), std::string::npos) << result.output;
    EXPECT_EQ(test::one_line_error(result), 1) << result.output;
    EXPECT_NE(result.output.find(c.expected), std::string::npos) << "expected '" << c.expected << "' in:\n" << result.output;
    EXPECT_FALSE(fs::exists(d / "out")) << result.output;
}

std::vector<Hostile> bvh_cases() {
    const std::string imp = "import-bvh '{d}/t.bvh' --out '{d}/out'";
    return {
        {"BvhFrameTimeHuge", {{"t.bvh", bvh("2", "1e308", kRow, 2)}}, imp + " --fps 30", "t.bvh:18: frame time 1e+308 s is not between"},
        {"BvhFrameTimeZero", {{"t.bvh", bvh("2", "0", kRow, 2)}}, imp, "t.bvh:18: frame time 0 s"},
        {"BvhFrameTimeNaN", {{"t.bvh", bvh("2", "nan", kRow, 2)}}, imp, "t.bvh:18: frame time 'nan' is not a finite number"},
        {"BvhFramesHuge", {{"t.bvh", bvh("4294967296", "0.01", kRow, 2)}}, imp, "t.bvh:17: frame count 4294967296 is not a whole number in 0..10000000"},
        {"BvhFramesFraction", {{"t.bvh", bvh("0.5", "0.01", kRow, 2)}}, imp, "t.bvh:17: frame count 0.5 is not a whole number"},
        {"BvhNotABvh", {{"t.bvh", "root:x:0:0:root:/root:/bin/bash\nsecret line\n"}}, imp, "t.bvh:1: is not a BVH file"},
        {"BvhBinary", {{"t.bvh", std::string("\x7f" "ELF\x02\x01\x01\0\0\0\x1b[31m", 14)}}, imp, "t.bvh:1: is not a BVH file"},
        {"BvhTruncated", {{"t.bvh", bvh("3", "0.01", kRow, 2)}}, imp, "motion block is truncated: 2 of 3 frames"},
        {"BvhValueNaN", {{"t.bvh", bvh("1", "0.01", "0 30 0 0 nan 0 0 0 0", 1)}}, imp, "is not a finite number"},
        {"BvhValueOverflow", {{"t.bvh", bvh("1", "0.01", "0 30 0 0 1e400 0 0 0 0", 1)}}, imp, "is not a finite number"},
        {"BvhRowTooShort", {{"t.bvh", bvh("1", "0.01", "0 30 0 0 0 0 0 0", 1)}}, imp, "t.bvh:19: motion block is truncated: frame 0 of 1 has 8 of 9 values"},
        {"BvhEmpty", {{"t.bvh", ""}}, imp, "t.bvh:1: file ends where HIERARCHY was expected"},
        {"BvhFpsHuge", {{"t.bvh", bvh("2", "0.01", kRow, 2)}}, imp + " --fps 1e308", "--fps: 1e+308 is not a frame rate"},
        {"BvhMissing", {}, imp, "t.bvh: cannot open BVH file"},
    };
}

// A binary little-endian PLY: float x y z per vertex, then faces as a list of `count_type` counts
// and int indices; `faces` rows are written as given (count first), `tail` appended raw.
std::string binary_ply(const std::vector<float>& xyz, const std::vector<std::vector<std::int64_t>>& faces, const std::string& count_type,
                       const std::string& extra_header = "") {
    std::string out = fmt::format("ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\n"
                                  "property float z\nelement face {}\nproperty list {} int vertex_indices\n{}end_header\n",
                                  xyz.size() / 3, faces.size(), count_type, extra_header);
    auto put = [&](std::uint64_t v, int bytes) {
        for (int k = 0; k < bytes; ++k) out.push_back(char((v >> (8 * k)) & 0xff));
    };
    for (float f : xyz) put(std::bit_cast<std::uint32_t>(f), 4);
    for (const auto& row : faces) {
        put(std::uint64_t(row[0]), count_type == "uchar" ? 1 : 4);
        for (std::size_t k = 1; k < row.size(); ++k) put(std::uint64_t(row[k]), 4);
    }
    return out;
}

const std::vector<float> kTetraXyz{0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};

std::vector<Hostile> mesh_cases() {
    const std::string obj = mhv("m/f_%04d.obj");
    return {
        {"ObjNaN", {{"m/f_0000.obj", "v 0 0 0\nv 1 0 0\nv 0 nan 0\nv 0 0 1\nf 1 3 2\n"}}, obj, "f_0000.obj:3: vertex 2 has a non-finite coordinate 'nan'"},
        {"ObjInfinite", {{"m/f_0000.obj", "v 0 0 0\nv inf 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\n"}}, obj, "f_0000.obj:2: vertex 1 has a non-finite coordinate 'inf'"},
        {"ObjOverflow", {{"m/f_0000.obj", "v 0 0 0\nv 1e400 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\n"}}, obj, "f_0000.obj:2: vertex 1 has a non-finite coordinate"},
        {"ObjFar", {{"m/f_0000.obj", "v 1e12 0 0\nv 1000000000001 0 0\nv 1e12 1 0\nv 1e12 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n"}}, obj,
         "lies 1e+12 m from the origin"},
        {"ObjFarInCentimetres", {{"m/f_0000.obj", "v 2e6 0 0\nv 2000001 0 0\nv 2e6 1 0\nv 2e6 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n"}},
         obj + " --unit cm", "m from the origin; amhv takes scenes within 10 km"},
        {"ObjIndexPastEnd", {{"m/f_0000.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 9\nf 1 2 4\n"}}, obj, "f_0000.obj:5: face index 9 is past the last of the file's 4 vertices"},
        {"ObjIndexZero", {{"m/f_0000.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"}}, obj, "f_0000.obj:4: face index '0' is not a vertex number"},
        {"ObjIndexBeforeFirst", {{"m/f_0000.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -7\n"}}, obj, "f_0000.obj:4: face index -7 reaches before the first vertex"},
        {"ObjIndexText", {{"m/f_0000.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n"}}, obj, "f_0000.obj:4: face index 'x' is not a vertex number"},
        {"ObjIndexHuge", {{"m/f_0000.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999\n"}}, obj, "f_0000.obj:4: face index '99999999999999999999' is not a vertex number"},
        {"ObjNoFaces", {{"m/f_0000.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"}}, obj, "f_0000.obj: empty frame: the mesh has no faces"},
        {"ObjEmpty", {{"m/f_0000.obj", ""}}, obj, "f_0000.obj"},
        {"PlyBinaryShort", {{"m/f_0000.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 1000000\nproperty float x\nproperty float y\n"
                                             "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\x01\x02"}},
         mhv("m/f_%04d.ply"), "malformed PLY: 1000000 vertices and 1 faces need at least"},
        {"PlyAsciiShort", {{"m/f_0000.ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                                            "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n"}},
         mhv("m/f_%04d.ply"), "malformed PLY: 4 vertices and 1 faces declared but only 2 lines follow"},
        {"PlyNoEndHeader", {{"m/f_0000.ply", "ply\nformat ascii 1.0\nelement vertex 4\n"}}, mhv("m/f_%04d.ply"), "malformed PLY: no end_header"},
        {"PlyIndexPastEnd", {{"m/f_0000.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                                              "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"}},
         mhv("m/f_%04d.ply"), "f_0000.ply:13: face 0 names vertex 7, not one of the 3 vertices"},
        {"PlyAsciiNaN", {{"m/f_0000.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                                          "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n"}},
         mhv("m/f_%04d.ply"), "f_0000.ply:11: vertex 1 has a non-finite or unreadable value 'nan'"},
        {"StlAsciiGarbage", {{"m/f_0000.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex nan 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid x\n"}},
         mhv("m/f_%04d.stl"), "f_0000.stl: empty frame: the mesh has no faces"},
        {"OffHeaderHuge", {{"m/f_0000.off", "OFF\n1000000 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"}}, mhv("m/f_%04d.off"),
         "malformed OFF: 1000000 vertices and 1 faces do not fit in a file of"},
        {"OffIndexPastEnd", {{"m/f_0000.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n"}}, mhv("m/f_%04d.off"), "f_0000.off:6: face 0 names vertex 5"},
        {"OffNaN", {{"m/f_0000.off", "OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n"}}, mhv("m/f_%04d.off"), "f_0000.off:4: vertex 1 does not have three finite coordinates"},
        {"OffNoCounts", {{"m/f_0000.off", "OFF\n\n"}}, mhv("m/f_%04d.off"), "malformed OFF"},
        {"OffNotOff", {{"m/f_0000.off", "PLY\n3 1 0\n"}}, mhv("m/f_%04d.off"), "f_0000.off:1: malformed OFF: it does not start with OFF"},
        {"OffBinary", {{"m/f_0000.off", std::string("OFF BINARY\n\x7f\xff\xff\xff\x7f\xff\xff\xff\0\0\0\0", 23)}}, mhv("m/f_%04d.off"),
         "f_0000.off:1: binary OFF is not read"},
        {"OffFourD", {{"m/f_0000.off", "4OFF\n3 1 0\n0 0 0 1\n1 0 0 1\n0 1 0 1\n3 0 1 2\n"}}, mhv("m/f_%04d.off"),
         "f_0000.off:1: 4OFF declares vertices of more than three dimensions"},
        {"OffColourHuge", {{"m/f_0000.off", "COFF\n100000000 1 0\n0 0 0 1 1 1 1\n"}}, mhv("m/f_%04d.off"),
         "malformed OFF: 100000000 vertices and 1 faces do not fit in a file of"},
        {"OffMagicGarbage", {{"m/f_0000.off", "xyzOFF\n3 1 0\n"}}, mhv("m/f_%04d.off"), "f_0000.off:1: malformed OFF: it does not start with OFF"},
        {"OffCountsOnFirstLine", {{"m/f_0000.off", "OFF\r4 4 0\n11151111111111111111111110 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n"}}, mhv("m/f_%04d.off"),
         "f_0000.off:1: malformed OFF: the vertex and face counts belong on the line after OFF"},
        {"OffFaceTrailingWords", {{"m/f_0000.off", "OFF\n4 2 4\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 3 44488888888888888881 0 2 1r\n3 0 3 2\n2\n"}},
         mhv("m/f_%04d.off"), "f_0000.off:7: face 0 has words after its corners that are not a colour (3 or 4 numbers from 0 to 255)"},
        {"OffVertexExtraWord", {{"m/f_0000.off", "OFF\n4 4 0\n0 0 0 99999999999\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n"}},
         mhv("m/f_%04d.off"), "f_0000.off:3: vertex 0 has 1 values after its coordinates where the OFF form holds 0"},
        {"OffCountsWithoutEdges", {{"m/f_0000.off", "OFF\n3 1  \n0 0 0\n1 0 0\n0 1 0\n3 0 2 1\n 3555555555555555555555555555555\n01\n"}},
         mhv("m/f_%04d.off"), "f_0000.off:2: malformed OFF: expected the vertex, face and edge counts (three numbers) on this line"},
        {"OffComment", {{"m/f_0000.off", "OFF\n# 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n"}}, mhv("m/f_%04d.off"),
         "f_0000.off:2: malformed OFF: a comment (#), which the reader does not take"},
        {"OffFaceNegativeCount", {{"m/f_0000.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n-3 1 2 3\n"}}, mhv("m/f_%04d.off"),
         "f_0000.off:7: face 0 does not start with its number of corners (3 or more)"},
        {"PlyListCountFloat", {{"m/f_0000.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                                                "element face 1\nproperty list float int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"}},
         mhv("m/f_%04d.ply"), "f_0000.ply:8: malformed PLY header: the count of list vertex_indices is of type float; a count is an integer"},
        {"PlyBinaryListHuge", {{"m/f_0000.ply", binary_ply(kTetraXyz, {{0xffffffff, 0, 1, 2}, {3, 0, 1, 3}, {3, 1, 2, 3}, {3, 0, 3, 2}}, "uint")}},
         mhv("m/f_%04d.ply"), "malformed PLY: row 0 of element face has a list of 4294967295 values, past the end of the file"},
        {"PlyBinaryIndexPastEnd", {{"m/f_0000.ply", binary_ply(kTetraXyz, {{3, 0, 2, 1}, {3, 0, 1, 9}, {3, 1, 2, 3}, {3, 0, 3, 2}}, "uchar")}},
         mhv("m/f_%04d.ply"), "f_0000.ply: face 1 names vertex 9, not one of the 4 vertices"},
        {"PlyBinaryIndexNegative", {{"m/f_0000.ply", binary_ply(kTetraXyz, {{3, 0, 2, 1}, {3, 0, 1, -1}, {3, 1, 2, 3}, {3, 0, 3, 2}}, "uchar")}},
         mhv("m/f_%04d.ply"), "f_0000.ply: face 1 names vertex -1, not one of the 4 vertices"},
        {"PlyBinaryNaN", {{"m/f_0000.ply", binary_ply({0, 0, 0, 1, 0, 0, 0, std::numeric_limits<float>::quiet_NaN(), 0, 0, 0, 1},
                                                      {{3, 0, 2, 1}, {3, 0, 1, 3}, {3, 1, 2, 3}, {3, 0, 3, 2}}, "uchar")}},
         mhv("m/f_%04d.ply"), "f_0000.ply: vertex 2 has a non-finite coordinate y"},
        {"PlyElementWithoutProperties", {{"m/f_0000.ply", binary_ply(kTetraXyz, {{3, 0, 2, 1}, {3, 0, 1, 3}, {3, 1, 2, 3}, {3, 0, 3, 2}}, "uchar",
                                                                     "element junk 4000000000\n")}},
         mhv("m/f_%04d.ply"), "malformed PLY: element junk has 4000000000 rows but no properties"},
        {"StlCountMismatch", {{"m/f_0000.stl", std::string(80, 'x') + std::string("\x10\0\0\0", 4) + std::string(50, '\0')}}, mhv("m/f_%04d.stl"),
         "malformed binary STL: 16 triangles need 884 bytes but the file has 134"},
        {"StlShort", {{"m/f_0000.stl", "abc"}}, mhv("m/f_%04d.stl"), "malformed binary STL: shorter than its 84-byte header"},
        {"FrameNumberHuge", {{"m/f_99999999999.obj", kTetra}}, mhv("m/f_%d.obj"), "frame number 99999999999 is beyond"},
        {"FolderWithoutMeshes", {{"m/readme.txt", "x"}}, "mhv --meshes '{d}/m' --out '{d}/out'", "folder holds no OBJ, PLY, OFF or STL files"},
    };
}

std::vector<Hostile> scene_cases() {
    const std::string check = "check '{d}/scene.toml'", sweep = "sweep '{d}/scene.toml' --backend cpu --out '{d}/out'";
    auto with = [](const std::string& from, const std::string& to) {
        return std::vector<std::pair<std::string, std::string>>{{"@cmu", ""}, {"scene.toml", scene_with(from, to)}};
    };
    return {
        {"SceneXRangeHuge", with("angle_step_deg = 30.0", "angle_step_deg = 30.0\nx_range = [-1e9, 1e9]"), check, "scene.toml:4: sampling.x_range: must lie within 1 km"},
        {"SceneAngleStepTiny", with("angle_step_deg = 30.0", "angle_step_deg = 9.5367431640625e-07"), check, "scene.toml:3: sampling.angle_step_deg"},
        {"SceneVoxelZero", with("voxel = 0.04", "voxel = 0.0"), check, "scene.toml:2: sampling.voxel"},
        {"SceneVoxelNaN", with("voxel = 0.04", "voxel = nan"), check, "scene.toml:2: sampling.voxel"},
        {"SceneVoxelHuge", with("voxel = 0.04", "voxel = 1e300"), check, "scene.toml:2: sampling.voxel"},
        {"ScenePartUnknown", with("interest = { A = { parts = [\"right_hand\"] }", "interest = { A = { parts = [\"rigth_hand\"] }"), check,
         "scene.toml:11: segments[1]: object A has no part 'rigth_hand'; its parts are head, torso, left_upper_arm"},
        {"SceneRotationNaN", with("[objects.A]", "[weights]\na_rotations_deg = [nan]\n\n[objects.A]"), check,
         "weights.a_rotations_deg: must hold angles in degrees within [-180, 180]"},
        {"SceneFilesRootMissing", with("[objects.A]", "[objects.C]\nmeshes = \"m/f_%04d.obj\"\nfiles_root = \"nowhere\"\n\n[objects.A]"), check,
         "files_root"},
        {"SceneFramesWrap", with("a = [108, 147]", "a = [108, 4294967296]"), check, "scene.toml:12: segments[1].a: frame numbers must lie in 0..10000000"},
        {"SceneFramesBeyondTake", with("a = [108, 147]", "a = [108, 9000]"), check, "scene.toml"},
        {"SceneUnknownKey", with("type = \"0&0a\"", "type = \"0&0a\"\nvisibilty = true"), check, "visibilty"},
        {"SceneWrongType", with("voxel = 0.04", "voxel = \"fine\""), check, "scene.toml:2: sampling.voxel: must be a number"},
        {"SceneUnknownInteraction", with("type = \"0&0a\"", "type = \"hug\""), check, "scene.toml:14: segments[1].type: unknown interaction type 'hug'"},
        {"SceneNegativeTolerance", with("type = \"0&0a\"", "type = \"0&0a\"\ntolerance = -3"), check, "tolerance"},
        {"SceneSyntax", with("[[segments]]", "[[segments]"), check, "scene.toml:11: Error while parsing table header"},
        {"ScenePreferNegativeWeight", with("type = \"0&0a\"", "type = \"0&0a\"\nprefer = { distance_m = 0.7, weight = -1 }"), check, "prefer.weight"},
        {"ScenePreferUnknownKey", with("type = \"0&0a\"", "type = \"0&0a\"\nprefer = { distance = 0.7 }"), check, "prefer.distance"},
        {"SceneLimitsReversed", with("type = \"0&0a\"", "type = \"0&0a\"\nlimits = { distance_m = [1.2, 0.4] }"), check,
         "limits.distance_m: must be [low, high] within [0, 100]"},
        {"SceneLimitsAngleRange", with("type = \"0&0a\"", "type = \"0&0a\"\nlimits = { thetaA_deg = [-400, 45] }"), check,
         "limits.thetaA_deg: must be [low, high] within [-180, 180]"},
        {"SceneContactToleranceNegative", with("type = \"0&0a\"", "type = \"0&0a\"\ncontact_tolerance = -0.01"), check,
         "scene.toml:15: segments[1].contact_tolerance: -0.01 is out of range [0, 0.5]"},
        {"SceneContactFramesZero", with("type = \"0&0a\"", "type = \"0&0a\"\ncontact_frames = 0"), check, "segments[1].contact_frames: 0 is out of range (0, 1]"},
        {"SceneContactFramesOtherType", with("type = \"0&0a\"", "type = \"0&0b\"\ncontact_frames = 0.9"), check,
         "segments[1].contact_frames: applies to type 0&0a only (this key segment is 0&0b)"},
        {"SceneNearWithoutDistance", with("type = \"0&0a\"", "type = \"near\""), check, "segments[1].within_m: type near needs within_m"},
        {"SceneNearWithContactTolerance", with("type = \"0&0a\"", "type = \"near\"\nwithin_m = 0.1\ncontact_tolerance = 0.1"), check,
         "segments[1].contact_tolerance: does not apply to type near"},
        {"SceneNearWithFidelity", with("type = \"0&0a\"", "type = \"near\"\nwithin_m = 0.1"), check,
         "segments[1].fidelity: a near key keeps the whole bodies apart"},
        {"SceneWithinOtherType", with("type = \"0&0a\"", "type = \"0&0a\"\nwithin_m = 0.1"), check,
         "segments[1].within_m: applies to type near only (this key segment is 0&0a)"},
        {"SceneZRangeReversed", with("type = \"0&0a\"", "type = \"0&0a\"\nz_range = [0.05, -0.05]"), check,
         "segments[1].z_range: must be [low, high] in metres within [-1, 1]"},
        {"SceneZRangeNaN", with("type = \"0&0a\"", "type = \"0&0a\"\nz_range = [nan, 0.05]"), check, "segments[1].z_range"},
        {"SceneZRangeNoVoxel", with("type = \"0&0a\"", "type = \"0&0a\"\nz_range = [0.01, 0.02]"), sweep, "z_range [0.01, 0.02] holds no whole voxel of 0.04 m"},
        {"SceneVisibilityFramesAlone", with("type = \"0&0a\"", "type = \"0&0a\"\nvisibility = { enabled = true, frames = 0.8 }"), check,
         "visibility.frames: applies to per-frame visibility only; add per_frame = true"},
        {"SceneVisibilityPerFrameOff", with("type = \"0&0a\"", "type = \"0&0a\"\nvisibility = { per_frame = true }"), check,
         "visibility.per_frame: needs enabled = true"},
        {"SceneAxesRepeated", with("bvh = \"cmu/19_01.bvh\"", "bvh = \"cmu/19_01.bvh\"\naxes = \"x,x,y\""), check,
         "scene.toml:10: objects.B.axes: 'x,x,y' is not three signed file axes"},
        {"SceneAxesAndUp", with("bvh = \"cmu/19_01.bvh\"", "bvh = \"cmu/19_01.bvh\"\nup = \"y\"\naxes = \"x,-z,y\""), check,
         "objects.B.axes: give one of 'up' and 'axes'"},
        {"SceneFloorWord", with("bvh = \"cmu/19_01.bvh\"", "bvh = \"cmu/19_01.bvh\"\nfloor = \"ground\""), check,
         "objects.B.floor: must be \"auto\" or a height in metres"},
        {"SceneFloorHuge", with("bvh = \"cmu/19_01.bvh\"", "bvh = \"cmu/19_01.bvh\"\nfloor = 1e9"), check, "objects.B.floor: 1000000000 is out of range [-100, 100]"},
        {"SceneBvhMissing", {{"scene.toml", kScene}}, check, "18_01.bvh"},
        {"SceneBvhNameTooLong", with("bvh = \"cmu/19_01.bvh\"", "bvh = \"cmu/" + std::string(300, 'x') + ".bvh\""), check,
         "xxxxxxxx.bvh' is not a file"},
        {"SceneMemory", with("voxel = 0.04", "voxel = 0.002"), sweep + " --max-memory 0.5", "more than the 0.5 GB --max-memory allows; use a voxel of at least"},
        {"TrackFrameHuge", {{"m/f_0000.obj", kTetra}, {"m/f_0001.obj", kTetra}, {"scene.toml", kMeshScene}, {"track.csv", kTrack + "1e20,0,0,1.6,1,0,0\n"}},
         check, "track.csv:4: frame 1e+20 is not a whole frame number"},
        {"TrackFrameFraction", {{"m/f_0000.obj", kTetra}, {"m/f_0001.obj", kTetra}, {"scene.toml", kMeshScene}, {"track.csv", kTrack + "0.5,0,0,1.6,1,0,0\n"}},
         check, "track.csv:4: frame 0.5 is not a whole frame number"},
        {"LabelOfAGroupMember", {{"m/f_0000.obj", kTetra}, {"m/f_0001.obj", kTetra}, {"l/f_0000.txt", "body body @A body\n"}, {"l/f_0001.txt", "body body body body\n"},
                                 {"scene.toml", with_labels(kMeshScene)}, {"track.csv", kTrack}},
         sweep, "f_0000.txt: label '@A' of vertex 2 starts with '@', which amhv keeps for the members of a placed group"},
        {"TrackNaN", {{"m/f_0000.obj", kTetra}, {"m/f_0001.obj", kTetra}, {"scene.toml", kMeshScene}, {"track.csv", kTrack + "1,nan,0,1.6,1,0,0\n"}},
         check, "track.csv:4"},
        {"ObjMaterialLibraryMissing", {{"m/f_0000.obj", "mtllib none.mtl\n" + kTetra}, {"m/f_0001.obj", kTetra}, {"scene.toml", kMeshScene}, {"track.csv", kTrack}},
         sweep, "f_0000.obj:1: material library 'none.mtl' does not exist"},
        {"ObjTexcoordText", {{"m/f_0000.obj", kTetra + "vt x 0\n"}, {"m/f_0001.obj", kTetra}, {"scene.toml", kMeshScene}, {"track.csv", kTrack}}, sweep,
         "f_0000.obj:9: 'x' is not a finite number"},
        {"ObjTexcoordIndexPastEnd", {{"m/f_0000.obj", "vt 0 0\n" + kTetra + "f 1/1 3/1 2/9\n"}, {"m/f_0001.obj", kTetra}, {"scene.toml", kMeshScene}, {"track.csv", kTrack}},
         sweep, "f_0000.obj:10: texture coordinate index 9 is out of range"},
        {"ObjMaterialUndefined", {{"m/f_0000.obj", "mtllib a.mtl\nusemtl nosuch\n" + kTetra}, {"m/a.mtl", "newmtl skin\nKd 1 1 1\n"}, {"m/f_0001.obj", kTetra},
                                  {"scene.toml", kMeshScene}, {"track.csv", kTrack}},
         sweep, "f_0000.obj: material 'nosuch' is used but no material library defines it"},
        {"MtlTextureMissing", {{"m/f_0000.obj", "mtllib a.mtl\nusemtl skin\n" + kTetra}, {"m/a.mtl", "newmtl skin\nmap_Kd gone.png\n"},
                               {"m/f_0001.obj", kTetra}, {"scene.toml", kMeshScene}, {"track.csv", kTrack}},
         sweep, "a.mtl:2: texture '"},
        {"TrackZeroGaze", {{"m/f_0000.obj", kTetra}, {"m/f_0001.obj", kTetra}, {"scene.toml", kMeshScene}, {"track.csv", kTrack + "1,0,0,1.6,0,0,0\n"}},
         check, "track.csv:4: the gaze direction is zero"},
    };
}

std::vector<Hostile> sweep_folder_cases() {
    auto tampered = [](const std::string& kind) {
        return std::vector<std::pair<std::string, std::string>>{{"@cmu", ""}, {"scene.toml", kScene}, {"@sweep", ""}, {"sweep/segment_1/group.vdb", "@group:" + kind}};
    };
    const std::string at = "segment_1/group.vdb: ";
    return {
        {"GroupOtherScene", tampered("other-scene"), kEditFromSweep, at + "grid solutions is the group of another scene (scene_hash differs)"},
        {"GroupOtherLattice", tampered("other-lattice"), kEditFromSweep, at + "grid solutions was swept on another lattice or for another key segment"},
        {"GroupOtherSegment", tampered("other-segment"), kEditFromSweep, at + "grid solutions was swept on another lattice or for another key segment"},
        {"GroupMissingGrid", tampered("heights"), kEditFromSweep, at + "has no grid solutions: not the group of this key segment's sweep"},
        {"GroupOutsideRange", tampered("outside"), kEditFromSweep, at + "holds poses at x 400..400 m, y 400 m (theta index 11), outside the range"},
        {"GroupAngleOffLattice", tampered("angle"), kEditFromSweep, at + "grid solutions has poses at angle index 12, outside 0..11"},
        {"GroupPoseMissing", tampered("short"), kEditFromSweep, at + "holds"},
        {"GroupTruncated", tampered("truncated"), kEditFromSweep, at + "is not a readable OpenVDB file"},
        {"GroupNotVdb", {{"@cmu", ""}, {"scene.toml", kScene}, {"@sweep", ""}, {"sweep/segment_1/group.vdb", "x,y,z\n1,2,3\n"}}, kEditFromSweep,
         at + "is not a readable OpenVDB file"},
        {"GroupMissing", {{"@cmu", ""}, {"scene.toml", kScene}, {"@sweep", ""}, {"sweep/segment_1/group.vdb", "@remove"}}, kEditFromSweep,
         at + "cannot open the solution group"},
        {"ResultNotJson", {{"@cmu", ""}, {"scene.toml", kScene}, {"@sweep", ""}, {"sweep/result.json", "{ not json"}}, kEditFromSweep, "result.json: is not valid JSON"},
        {"ResultOtherSampling", {{"@cmu", ""}, {"scene.toml", scene_with("voxel = 0.04", "voxel = 0.05")}, {"@sweep", ""}}, kEditFromSweep,
         "result.json: was swept at 0.04 m / 30 deg but the scene asks for 0.05 m / 30 deg"},
        {"ResultMissing", {{"@cmu", ""}, {"scene.toml", kScene}, {"sweep/notes.txt", "x"}}, kEditFromSweep, "result.json: cannot open"},
    };
}

std::vector<Hostile> command_line_cases() {
    auto tetra_at = [](const std::string& voxel) { return mhv("m/f_%04d.obj", voxel); };
    const std::string tetra = mhv("m/f_%04d.obj");
    const std::vector<std::pair<std::string, std::string>> m{{"m/f_0000.obj", kTetra}, {"m/f_0001.obj", kTetra}};
    return {
        {"VoxelZero", m, tetra_at("0"), "voxel size must be a positive number"},
        {"VoxelNaN", m, tetra_at("nan"), "voxel size must be a positive number"},
        {"VoxelTiny", m, tetra_at("1e-9"), "voxels along"},
        {"ResampleHuge", m, tetra + " --resample 2000000000", "--resample: 2000000000 frames is more than"},
        {"ResampleNegative", m, tetra + " --resample -3", "--resample: the frame count must be positive"},
        {"FramesBackwards", m, tetra + " --frames 1:0", "frame range '1:0' is empty or negative"},
        {"FramesMissing", m, tetra + " --frames 0:7", "frame 2 of --frames 0:7 is missing"},
        {"FramesText", m, tetra + " --frames a:b", "frame range 'a:b' is not FIRST:LAST"},
        {"UnitNegative", m, tetra + " --unit -1", "unit '-1' is not m, cm, mm, in, ft or a positive number"},
        {"UpAxisBad", m, tetra + " --up w", "up axis 'w' is not x, y or z"},
        {"AxisBad", m, tetra + " --axis q", "--axis: 'q' is not x, y or z"},
        {"MaxMemoryNegative", m, tetra + " --max-memory -1", "max-memory"},
        {"SegmentOutOfRange", {{"@cmu", ""}, {"scene.toml", kScene}}, "sweep '{d}/scene.toml' --segment 9 --out '{d}/out'", "--segment: 9 is not a key segment"},
        {"ControlCharactersInName", {{"m/f_0000.obj", kTetra}}, "mhv --meshes '{d}/m/\x1b[31mred_%04d.obj' --out '{d}/out'", "\\x1b[31mred"},
    };
}

// A small glTF (JSON, its buffer inline as base64): a triangle skinned to a chain of `joints`
// joints J1, J2, ... (node 0 holds the mesh), each vertex of weight `weight` on J1, and, when
// `animated`, an animation turning J1. `buffer_uri` replaces the inline buffer (a path).
std::string gltf_text(int joints, float weight, bool animated, const std::string& buffer_uri = "") {
    std::string bytes;
    auto put = [&](const void* p, std::size_t n) { bytes.append(static_cast<const char*>(p), n); };
    const float positions[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    put(positions, sizeof(positions));                                   // 0: 36
    const std::uint16_t joint_ids[12] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    put(joint_ids, sizeof(joint_ids));                                   // 36: 24
    const float weights[12] = {weight, 0, 0, 0, weight, 0, 0, 0, weight, 0, 0, 0};
    put(weights, sizeof(weights));                                       // 60: 48
    const std::uint16_t indices[4] = {0, 1, 2, 0};
    put(indices, sizeof(indices));                                       // 108: 8
    const float times[2] = {0, 1}, rotations[8] = {0, 0, 0, 1, 0, 0, 0.7071068f, 0.7071068f};
    put(times, sizeof(times));                                           // 116: 8
    put(rotations, sizeof(rotations));                                   // 124: 32
    const float identity[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    for (int j = 0; j < joints; ++j) put(identity, sizeof(identity));   // 156: 64 per joint
    static const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string b64;
    for (std::size_t i = 0; i < bytes.size(); i += 3) {
        const std::uint32_t n = (std::uint32_t(std::uint8_t(bytes[i])) << 16) | (i + 1 < bytes.size() ? std::uint32_t(std::uint8_t(bytes[i + 1])) << 8 : 0u) |
                                (i + 2 < bytes.size() ? std::uint32_t(std::uint8_t(bytes[i + 2])) : 0u);
        for (int k = 0; k < 4; ++k) b64 += i * 4 / 3 + std::size_t(k) < (bytes.size() * 4 + 2) / 3 ? alphabet[(n >> (18 - 6 * k)) & 63] : '=';
    }
    nlohmann::json nodes = nlohmann::json::array({{{"name", "body"}, {"mesh", 0}, {"skin", 0}}});
    nlohmann::json skin_joints = nlohmann::json::array();
    for (int j = 1; j <= joints; ++j) {
        nlohmann::json node = {{"name", fmt::format("J{}", j)}};
        if (j < joints) node["children"] = {j + 1};
        nodes.push_back(node);
        skin_joints.push_back(j);
    }
    auto view = [](int offset, int length) { return nlohmann::json{{"buffer", 0}, {"byteOffset", offset}, {"byteLength", length}}; };
    nlohmann::json g = {
        {"asset", {{"version", "2.0"}}},
        {"scene", 0},
        {"scenes", {{{"nodes", {0, 1}}}}},
        {"nodes", nodes},
        {"meshes", {{{"primitives", {{{"attributes", {{"POSITION", 0}, {"JOINTS_0", 1}, {"WEIGHTS_0", 2}}}, {"indices", 3}}}}}}},
        {"skins", {{{"joints", skin_joints}, {"inverseBindMatrices", 6}}}},
        {"buffers", {{{"byteLength", bytes.size()}, {"uri", buffer_uri.empty() ? "data:application/octet-stream;base64," + b64 : buffer_uri}}}},
        {"bufferViews", {view(0, 36), view(36, 24), view(60, 48), view(108, 6), view(116, 8), view(124, 32), view(156, 64 * joints)}},
        {"accessors",
         {{{"bufferView", 0}, {"componentType", 5126}, {"count", 3}, {"type", "VEC3"}, {"min", {0, 0, 0}}, {"max", {1, 1, 0}}},
          {{"bufferView", 1}, {"componentType", 5123}, {"count", 3}, {"type", "VEC4"}},
          {{"bufferView", 2}, {"componentType", 5126}, {"count", 3}, {"type", "VEC4"}},
          {{"bufferView", 3}, {"componentType", 5123}, {"count", 3}, {"type", "SCALAR"}},
          {{"bufferView", 4}, {"componentType", 5126}, {"count", 2}, {"type", "SCALAR"}, {"min", {0}}, {"max", {1}}},
          {{"bufferView", 5}, {"componentType", 5126}, {"count", 2}, {"type", "VEC4"}},
          {{"bufferView", 6}, {"componentType", 5126}, {"count", joints}, {"type", "MAT4"}}}}};
    if (animated) {
        nlohmann::json sampler = {{"input", 4}, {"output", 5}, {"interpolation", "LINEAR"}};
        nlohmann::json channel = {{"sampler", 0}, {"target", {{"node", 1}, {"path", "rotation"}}}};
        nlohmann::json animation = {{"name", "turn"}, {"samplers", nlohmann::json::array({sampler})}, {"channels", nlohmann::json::array({channel})}};
        g["animations"] = nlohmann::json::array({animation});
    }
    return g.dump();
}

std::vector<Hostile> character_cases() {
    std::string scene = kScene;
    scene.replace(scene.find("bvh = \"cmu/18_01.bvh\""), std::string("bvh = \"cmu/18_01.bvh\"").size(), "character = \"c.gltf\"");
    const std::string check = "check '{d}/scene.toml'";
    const auto with = [&](const std::string& gltf, const std::string& extra = "") {
        std::string text = scene;
        text.replace(text.find("character = \"c.gltf\""), std::string("character = \"c.gltf\"").size(), "character = \"c.gltf\"" + extra);
        return std::vector<std::pair<std::string, std::string>>{{"@cmu", ""}, {"scene.toml", text}, {"c.gltf", gltf}};
    };
    // A skin without its inverse bind matrices (the fuzz target's find): assimp 5.2 dereferences
    // the missing accessor and crashes; its reader runs in a child, so amhv names the crash.
    std::string no_binds = gltf_text(3, 1, true);
    no_binds.replace(no_binds.find("inverseBindMatrices"), std::string("inverseBindMatrices").size(), "inverseBindMatric_s");
    return {
        {"CharacterCrashesAssimp", with(no_binds), check, "c.gltf: cannot be read: the reader (assimp) crashed on it with a segmentation fault (SIGSEGV)"},
        {"CharacterNotReadable", with("{\"asset\": 1"), check, "cannot be read as a character"},
        {"CharacterNoAnimation", with(gltf_text(3, 1, false)), check, "holds no animation"},
        {"CharacterTooManyJoints", with(gltf_text(1100, 1, true)), check, "more than 1024 nodes"},
        {"CharacterNaNWeights", with(gltf_text(3, std::nanf(""), true)), check, "has no weight"},
        {"CharacterZeroWeights", with(gltf_text(3, 0, true)), check, "weights sum to 0"},
        {"CharacterUnknownAnimation", with(gltf_text(3, 1, true), "\nanimation = \"walk\""), check, "has no animation named walk (it has: turn)"},
        {"CharacterBufferOutsideItsFolder", with(gltf_text(3, 1, true, "../../../../../../etc/passwd")), check, "cannot be read as a character"},
        {"CharacterUnknownRig", with(gltf_text(3, 1, true), "\nfps = 200"), check, "no joint plays the role of the head (a joint named like Head)"},
        {"CharacterAndBvh", with(gltf_text(3, 1, true), "\nbvh = \"cmu/18_01.bvh\""), check, "give exactly one of 'meshes'"},
        {"CharacterWithLabels", with(gltf_text(3, 1, true), "\nlabels = \"l_%04d.txt\""), check, "a character's body already has part labels"},
        {"CharacterJointRoleUnknown", with(gltf_text(3, 1, true), "\njoints = { J1 = \"Elbow\" }"), check, "joints.J1: 'Elbow' is not a role (roles: Hips,"},
        {"JointsOnABvhObject", {{"@cmu", ""}, {"scene.toml", scene_with("bvh = \"cmu/19_01.bvh\"", "bvh = \"cmu/19_01.bvh\"\njoints = { Head = \"Head\" }")}},
         check, "objects.B.joints: only a character's joints are given roles by name"},
        {"CharacterJointNameUnknown", with(gltf_text(3, 1, true), "\njoints = { Bip01 = \"Head\" }"), check, "joints.Bip01: names no joint of"},
    };
}

std::vector<Hostile> compose_cases() {
    const std::string compose = "compose '{d}/lib.toml' --out '{d}/out'";
    const std::string take = "[[takes]]\nname = \"a\"\nbvh = \"cmu/18_01.bvh\"\n";
    const std::string walk = "[[examples]]\ntake = \"a\"\nframes = [1, 96]\naction = \"walk\"\n";
    const auto lib = [](const std::string& text) { return std::vector<std::pair<std::string, std::string>>{{"@cmu", ""}, {"lib.toml", text}}; };
    return {
        {"LibraryNotToml", lib("[[takes]\n"), compose, "lib.toml:1:"},
        {"LibraryNoTakes", lib(walk), compose, "takes: give at least one [[takes]] table"},
        {"LibraryTakeMissing", lib("[[takes]]\nname = \"a\"\nbvh = \"cmu/none.bvh\"\n" + walk), compose, "lib.toml:3: takes[1].bvh: "},
        {"LibraryTakeIsAFolder", lib("[[takes]]\nname = \"a\"\nbvh = \"cmu\"\n" + walk), compose, "is not a file"},
        {"LibraryMixedSkeletons", lib(take + "[[takes]]\nname = \"b\"\nbvh = \"cmu/20_11.bvh\"\n" + walk), compose, "take 'b' does not map joint by joint onto take 'a'"},
        {"LibraryTakeTooShort", {{"t.bvh", bvh("2", "0.01", kRow, 2)}, {"lib.toml", "[[takes]]\nname = \"a\"\nbvh = \"t.bvh\"\n"}}, compose, "fewer than 0.50 s"},
        {"LibraryTakeNaN", {{"t.bvh", bvh("1", "0.01", "0 30 0 0 nan 0 0 0 0", 1)}, {"lib.toml", "[[takes]]\nname = \"a\"\nbvh = \"t.bvh\"\n"}}, compose, "is not a finite number"},
        {"LibraryExampleOutside", lib(take + "[[examples]]\ntake = \"a\"\nframes = [250, 400]\naction = \"walk\"\n"), compose, "lib.toml:6: examples[1].frames"},
        {"LibraryExampleTooShort", lib(take + "[[examples]]\ntake = \"a\"\nframes = [1, 5]\naction = \"walk\"\n"), compose, "an example needs at least 0.25 s"},
        {"LibraryExampleUnknownTake", lib(take + "[[examples]]\ntake = \"z\"\nframes = [1, 96]\naction = \"walk\"\n"), compose, "'z' is not a take of the library"},
        {"LibraryActionWithColon", lib(take + "[[examples]]\ntake = \"a\"\nframes = [1, 96]\naction = \"w:1\"\n"), compose, "no commas, colons or quotes"},
        {"LibraryUnknownKey", lib(take + walk + "colour = 1\n"), compose, "unknown key"},
        {"ComposeActionWithoutExample", lib(take + walk), compose + " --actions 'walk, wave'", "'wave' has no example in the library"},
        {"ComposeDurationBad", lib(take + walk), compose + " --actions 'walk:3-1'", "a duration is MIN-MAX in seconds"},
        {"ComposeNoPath", lib(take + walk), compose + " --actions 'walk:10-20'", "no path through the motion graph"},
    };
}

std::vector<Hostile> corpus() {
    std::vector<Hostile> all;
    for (auto part : {bvh_cases(), mesh_cases(), scene_cases(), sweep_folder_cases(), command_line_cases(), compose_cases(), character_cases()}) all.insert(all.end(), part.begin(), part.end());
    return all;
}

INSTANTIATE_TEST_SUITE_P(Corpus, HostileInput, ::testing::ValuesIn(corpus()), [](const auto& param_info) { return param_info.param.name; });

TEST(HostileCorpus, HasAtLeastSixtyCases) { EXPECT_GE(corpus().size(), 60u); }

// The fuzz targets' seed corpora (tests/fuzz/corpus/TARGET/, committed): every file of this corpus
// by its reader, a good input of each reader, and the page server's requests. Run by hand when the
// corpus grows: AMHV_FUZZ_SEEDS=tests/fuzz/corpus build/tests/amhv_tests
// --gtest_also_run_disabled_tests --gtest_filter=HostileCorpus.DISABLED_WritesFuzzSeeds
TEST(HostileCorpus, DISABLED_WritesFuzzSeeds) {
    const char* root = std::getenv("AMHV_FUZZ_SEEDS");
    ASSERT_NE(root, nullptr) << "set AMHV_FUZZ_SEEDS to the corpus folder";
    const std::map<std::string, std::string> by_extension{{".bvh", "bvh"}, {".obj", "mesh_obj"}, {".ply", "mesh_ply"}, {".off", "mesh_off"},
                                                          {".stl", "mesh_stl"}, {".mtl", "mtl"}, {".toml", "scene"}, {".vdb", "group_vdb"},
                                                          {".json", "shard"}, {".gltf", "character"}};
    auto seed = [&](const std::string& target, const std::string& name, const std::string& bytes) {
        fs::create_directories(fs::path(root) / target);
        std::ofstream(fs::path(root) / target / name, std::ios::binary) << bytes;
    };
    test::TempDir tmp;
    fs::copy(test::source_dir() / "data" / "cmu", tmp.path() / "cmu");
    std::ofstream(tmp.path() / "scene.toml") << kScene;
    ASSERT_EQ(test::run_amhv(fmt::format("sweep '{0}/scene.toml' --no-maps --backend cpu --out '{0}/sweep'", tmp.path().string())).exit_code, 0);
    ASSERT_EQ(test::run_amhv(fmt::format("sweep '{0}/scene.toml' --shard 1/2 --backend cpu --out '{0}/shard'", tmp.path().string())).exit_code, 0);
    const fs::path good = tmp.path() / "sweep" / "segment_1" / "group.vdb";
    for (const Hostile& c : corpus())
        for (const auto& [path, content] : c.files) {
            const auto target = by_extension.find(fs::path(path).extension().string());
            if (path.front() == '@' || target == by_extension.end() || content == "@remove") continue;
            const std::string bytes = content.rfind("@group:", 0) == 0 ? tampered_group(good, content.substr(7)) : content;
            seed(target->second, c.name + "-" + fs::path(path).filename().string(), bytes);
        }
    seed("bvh", "good-take.bvh", bvh("3", "0.04", kRow, 3));
    seed("mesh_obj", "good-tetra.obj", kTetra);
    seed("mesh_off", "good-tetra.off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n");
    seed("mesh_ply", "good-tetra.ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                                       "element face 4\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n"
                                       "3 0 2 1\n3 0 1 3\n3 1 2 3\n3 0 3 2\n");
    seed("mesh_stl", "good-tetra.stl", "solid t\nfacet normal 0 0 -1\nouter loop\nvertex 0 0 0\nvertex 0 1 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid t\n");
    seed("mtl", "good.mtl", "newmtl skin\nKd 0.8 0.6 0.5\nd 1\nmap_Kd textures/skin.png\n");
    seed("scene", "good-meshes.toml", "[sampling]\nvoxel = 0.05\nangle_step_deg = 90.0\n\n[objects.A]\nmeshes = \"m/%04d.obj\"\n\n"
                                      "[objects.B]\nbvh = \"take.bvh\"\n\n[[segments]]\na = [0, 1]\nb = [1, 2]\ntype = \"0&0b\"\n");
    seed("group_vdb", "good-group.vdb", test::read_text(good));
    seed("shard", "good-shard.json", test::read_text(tmp.path() / "shard" / "shard.json"));
    const std::vector<std::pair<std::string, std::string>> requests{
        {"get-index", "GET / HTTP/1.1\r\nHost: 127.0.0.1:8080\r\n\r\n"},
        {"get-data-keepalive", "GET /view/data.js HTTP/1.1\r\nHost: localhost\r\n\r\nHEAD /index.html HTTP/1.1\r\nHost: localhost\r\n\r\n"},
        {"absolute", "GET //etc/passwd HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"},
        {"query-only", "GET ?a HTTP/1.1\r\n\r\n"},
        {"dotdot-encoded", "GET /%2e%2e/secret HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"},
        {"link", "GET /link HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n"},
        {"rebinding", "GET / HTTP/1.1\r\nHost: evil.example\r\n\r\n"},
        {"post-body", "POST / HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 5\r\n\r\nhello"},
        {"chunked", "POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n5\r\nhello\r\n0\r\n\r\n"},
        {"range", "GET /index.html HTTP/1.1\r\nRange: bytes=0-3,5-\r\n\r\n"}};
    for (const auto& [name, request] : requests) seed("server", name, request);
}

// A folder with the captures and the scene files `scenes` (name -> text), each swept into a folder
// of its name.
void sweep_scenes(const fs::path& d, const std::vector<std::pair<std::string, std::string>>& scenes) {
    fs::copy(test::source_dir() / "data" / "cmu", d / "cmu");
    for (const auto& [name, text] : scenes) {
        std::ofstream(d / (name + ".toml")) << text;
        auto sweep = test::run_amhv(fmt::format("sweep '{0}/{1}.toml' --no-maps --csv --backend cpu --out '{0}/{1}'", d.string(), name));
        ASSERT_EQ(sweep.exit_code, 0) << sweep.output;
    }
}


// A group that is consistent (this scene's lattice and hash, in range, its count) but holds a pose
// that is not a solution: the edit sweeps the pose it chose again and refuses it.
TEST(HostileSweepFolder, AChosenPoseThatIsNoSolutionIsRefused) {
    test::TempDir tmp;
    const fs::path d = tmp.path();
    sweep_scenes(d, {{"scene", kScene}});
    fs::rename(d / "scene", d / "sweep");
    auto json = nlohmann::json::parse(test::read_text(d / "sweep" / "result.json"));
    auto& segment = json["segments"][0];
    // The range's first corner: far from A, no contact.
    const int i = int(std::lround(segment["range"]["x_m"][0].get<double>() / 0.04)), j = int(std::lround(segment["range"]["y_m"][0].get<double>() / 0.04));
    const fs::path file = d / "sweep" / "segment_1" / "group.vdb";
    SolutionGroup group;
    group.add({i, j, 0, 0});
    results::write_group_vdb(file, group, results::read_group_lattice(file));
    segment["solutions"] = 1;
    std::ofstream(d / "sweep" / "result.json") << json.dump(2);
    auto edit = test::run_amhv(fmt::format("edit '{0}/scene.toml' --from-sweep '{0}/sweep' --backend cpu --no-frames --out '{0}/out'", d.string()));
    EXPECT_EQ(edit.exit_code, 1) << edit.output;
    EXPECT_EQ(test::one_line_error(edit), 1) << edit.output;
    EXPECT_NE(edit.output.find("is not a solution of key segment 1: it fails contact"), std::string::npos) << edit.output;
    EXPECT_FALSE(fs::exists(d / "out"));
}


// limits: solutions outside are counted in rejected.limits and left out of the group; the rows
// kept all lie within the limits.
TEST(Intent, LimitsRejectAndCount) {
    test::TempDir tmp;
    const fs::path d = tmp.path();
    sweep_scenes(d, {{"plain", kScene}, {"limited", scene_with("type = \"0&0a\"", "type = \"0&0a\"\nlimits = { distance_m = [0.0, 0.6] }")}});
    const auto plain = nlohmann::json::parse(test::read_text(d / "plain" / "result.json"))["segments"][0];
    const auto limited = nlohmann::json::parse(test::read_text(d / "limited" / "result.json"))["segments"][0];
    const std::uint64_t all = plain["solutions"], kept = limited["solutions"], rejected = limited["rejected"]["limits"];
    EXPECT_EQ(kept + rejected, all);
    EXPECT_GT(rejected, 0u);
    EXPECT_GT(kept, 0u);
    EXPECT_EQ(plain["rejected"]["limits"], 0);
    std::istringstream rows(test::read_text(d / "limited" / "segment_1" / "solutions.csv"));
    std::string line;
    std::getline(rows, line);
    std::uint64_t count = 0;
    while (std::getline(rows, line)) {
        ++count;
        double x, y, z, theta, distance;
        ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%lf", &x, &y, &z, &theta, &distance), 5);
        EXPECT_LE(distance, 0.6);
    }
    EXPECT_EQ(count, kept);
}

// `amhv probe` decides as the sweep: on random poses of the range and on rows of the group, its
// verdict is membership in solutions.csv. An empty group has near misses in result.json.
TEST(Probe, VerdictIsMembershipInTheGroup) {
    test::TempDir tmp;
    const fs::path d = tmp.path();
    const std::string empty_scene = scene_with("type = \"0&0a\"", "type = \"0&0a\"\nlimits = { distance_m = [0.0, 0.01] }\nvisibility = { enabled = true, half_angle_deg = 1.0 }");
    sweep_scenes(d, {{"scene", kScene}, {"narrow", empty_scene}});
    const auto segment = nlohmann::json::parse(test::read_text(d / "scene" / "result.json"))["segments"][0];
    std::set<std::string> group;
    std::istringstream rows(test::read_text(d / "scene" / "segment_1" / "solutions.csv"));
    std::string line;
    std::getline(rows, line);
    std::vector<std::string> poses;
    while (std::getline(rows, line)) {
        std::istringstream fields(line);
        std::string x, y, z, theta;
        std::getline(fields, x, ',');
        std::getline(fields, y, ',');
        std::getline(fields, z, ',');
        std::getline(fields, theta, ',');
        group.insert(fmt::format("{},{},{},{}", std::stod(x), std::stod(y), std::stod(theta), std::stod(z)));
        if (poses.size() < 4) poses.push_back(*group.rbegin());
    }
    ASSERT_GT(group.size(), 3u);
    // Poses on the 0.04 m / 30 deg lattice as whole steps (i, j, k, l).
    auto steps = [](double x, double y, double theta, double z) {
        return std::array<long, 4>{std::lround(x / 0.04), std::lround(y / 0.04), (std::lround(theta / 30.0) % 12 + 12) % 12, std::lround(z / 0.04)};
    };
    std::set<std::array<long, 4>> lattice_group;
    for (const std::string& member : group) {
        double x = 0, y = 0, theta = 0, z = 0;
        std::sscanf(member.c_str(), "%lf,%lf,%lf,%lf", &x, &y, &theta, &z);
        lattice_group.insert(steps(x, y, theta, z));
    }
    // One voxel beside members: when not members themselves, members are among their neighbours.
    for (std::size_t n = 0, given = poses.size(); n < given; ++n) {
        double x = 0, y = 0, theta = 0, z = 0;
        std::sscanf(poses[n].c_str(), "%lf,%lf,%lf,%lf", &x, &y, &theta, &z);
        poses.push_back(fmt::format("{},{},{},{}", x + 0.04, y, theta, z));
    }
    int beside = 0;
    std::mt19937 random(5);
    const auto x_m = segment["range"]["x_m"], y_m = segment["range"]["y_m"];
    for (int n = 0; n < 8; ++n) {
        const int i = std::uniform_int_distribution<int>(int(std::lround(x_m[0].get<double>() / 0.04)), int(std::lround(x_m[1].get<double>() / 0.04)))(random);
        const int j = std::uniform_int_distribution<int>(int(std::lround(y_m[0].get<double>() / 0.04)), int(std::lround(y_m[1].get<double>() / 0.04)))(random);
        poses.push_back(fmt::format("{},{},{},{}", i * 0.04, j * 0.04, 30.0 * (n % 12), 0.0));
    }
    int solutions = 0;
    for (const std::string& pose : poses) {
        auto probe = test::run_amhv(fmt::format("probe '{}/scene.toml' --segment 1 --pose {} --json --backend cpu", d.string(), pose));
        ASSERT_EQ(probe.exit_code, 0) << probe.output;
        const auto answer = nlohmann::json::parse(probe.output);
        const auto& p = answer["pose"];
        const std::string key = fmt::format("{},{},{},{}", p["x"].get<double>(), p["y"].get<double>(), p["theta_deg"].get<double>(), p["z"].get<double>());
        const bool solution = answer["verdict"] == "solution";
        solutions += solution;
        EXPECT_EQ(solution, group.count(key) == 1) << pose << " -> " << key << " " << answer["verdict"];
        EXPECT_EQ(answer["gap_mm"].size(), 40u);
        // A pose that fails lists its neighbours in the group: exactly the members one step away.
        std::set<std::array<long, 4>> expected, listed;
        if (!solution) {
            const auto at = steps(p["x"].get<double>(), p["y"].get<double>(), p["theta_deg"].get<double>(), p["z"].get<double>());
            for (int dk = -1; dk <= 1; ++dk)
                for (int dj = -1; dj <= 1; ++dj)
                    for (int di = -1; di <= 1; ++di) {
                        const std::array<long, 4> n{at[0] + di, at[1] + dj, ((at[2] + dk) % 12 + 12) % 12, at[3]};
                        if ((di || dj || dk) && lattice_group.count(n)) expected.insert(n);
                    }
        }
        for (const auto& n : answer["neighbours_in_group"])
            listed.insert(steps(n["x"].get<double>(), n["y"].get<double>(), n["theta_deg"].get<double>(), n["z"].get<double>()));
        EXPECT_EQ(listed, expected) << pose;
        beside += !listed.empty();
    }
    EXPECT_GE(solutions, 4);
    EXPECT_GE(beside, 1);
    auto table = test::run_amhv(fmt::format("probe '{}/scene.toml' --pose {} --backend cpu", d.string(), poses.front()));
    EXPECT_NE(table.output.find("verdict: a solution"), std::string::npos) << table.output;
    auto bad = test::run_amhv(fmt::format("probe '{}/scene.toml' --pose 1,2", d.string()));
    EXPECT_EQ(bad.exit_code, 1);
    EXPECT_NE(bad.output.find("--pose: '1,2' is not X,Y,THETA or X,Y,THETA,Z"), std::string::npos) << bad.output;
    const auto narrow = nlohmann::json::parse(test::read_text(d / "narrow" / "result.json"))["segments"][0];
    ASSERT_EQ(narrow["solutions"], 0);
    ASSERT_TRUE(narrow.contains("near_misses"));
    ASSERT_GT(narrow["near_misses"].size(), 0u);
    EXPECT_LE(narrow["near_misses"].size(), 10u);
    EXPECT_EQ(narrow["near_misses"][0]["fails"], "visibility");
    EXPECT_EQ(narrow["near_misses"][0]["frames"], 40);
}

// segment_N/group.vdb opens in OpenVDB's own Python module (Debian's python3-openvdb) and holds
// exactly the rows of solutions.csv, height by height; its summary counts them per angle.
TEST(Group, PythonOpenVdbReadsTheCsvRows) {
    test::TempDir tmp;
    const fs::path d = tmp.path();
    sweep_scenes(d, {{"scene", scene_with("type = \"0&0a\"", "type = \"0&0a\"\nz_range = [-0.04, 0.04]")}});
    const fs::path script = d / "compare.py";
    std::ofstream(script) << R"(import sys, pyopenvdb as vdb
folder = sys.argv[1]
rows = set()
with open(folder + "/segment_1/solutions.csv") as f:
    next(f)
    for line in f:
        x, y, z, theta = (float(v) for v in line.split(",")[:4])
        rows.add((round(x / 0.04), round(y / 0.04), round(theta / 30) % 12, round(z / 0.04)))
poses = set()
for grid in vdb.readAll(folder + "/segment_1/group.vdb")[0]:
    level = grid.metadata["z_voxels"]
    assert grid.metadata["voxel_m"] == 0.04 and grid.metadata["angles"] == 12, grid.metadata
    for item in grid.citerOnValues():  # a voxel, or a tile of a solid block
        (i0, j0, k0), (i1, j1, k1) = item.min, item.max
        poses.update((i, j, k, level) for i in range(i0, i1 + 1) for j in range(j0, j1 + 1) for k in range(k0, k1 + 1))
print(len(rows), len(poses), rows == poses)
)";
    const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
    const auto run = test::run_shell(fmt::format("{} '{}' '{}/scene' 2>&1", python, script.string(), d.string()));
    const auto summary = nlohmann::json::parse(test::read_text(d / "scene" / "segment_1" / "group_summary.json"));
    const std::uint64_t count = summary["solutions"];
    EXPECT_GT(count, 0u);
    EXPECT_EQ(run.output, fmt::format("{} {} True\n", count, count)) << run.output;
    std::uint64_t per_angle = 0;
    for (const auto& a : summary["per_angle"]) per_angle += a["count"].get<std::uint64_t>();
    EXPECT_EQ(per_angle, count);
    const auto result = nlohmann::json::parse(test::read_text(d / "scene" / "result.json"));
    EXPECT_EQ(result["segments"][0]["files"]["group_bytes"].get<std::uint64_t>(), fs::file_size(d / "scene" / "segment_1" / "group.vdb"));

    // `amhv solutions`: the summary, and the CSV export byte for byte the sweep's, never over a file.
    auto report = test::run_amhv(fmt::format("solutions '{}/scene' --segment 1", d.string()));
    ASSERT_EQ(report.exit_code, 0) << report.output;
    EXPECT_NE(report.output.find(fmt::format("key segment 1: {} solutions on the 0.04 m / 30 deg lattice", count)), std::string::npos) << report.output;
    auto exported = test::run_amhv(fmt::format("solutions '{0}/scene' --csv '{0}/export.csv'", d.string()));
    ASSERT_EQ(exported.exit_code, 0) << exported.output;
    EXPECT_EQ(test::read_text(d / "export.csv"), test::read_text(d / "scene" / "segment_1" / "solutions.csv"));
    auto again = test::run_amhv(fmt::format("solutions '{0}/scene' --csv '{0}/export.csv'", d.string()));
    EXPECT_EQ(again.exit_code, 1);
    EXPECT_NE(again.output.find("export.csv: exists: amhv does not overwrite a file it did not create"), std::string::npos) << again.output;
    auto wrong = test::run_amhv(fmt::format("solutions '{}/scene' --segment 2", d.string()));
    EXPECT_EQ(wrong.exit_code, 1);
    EXPECT_NE(wrong.output.find("segment_2/group.vdb: cannot open the solution group"), std::string::npos) << wrong.output;
}

}  // namespace
}  // namespace amhv
