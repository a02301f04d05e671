// amhv propose: contact moments from a take's joints, B's shift from the hands' coupled motion,
// and the proposals on the shipped pairs with their key segments removed.
#include <algorithm>
#include <cmath>
#include <functional>
#include <fstream>
#include <numbers>
#include <tuple>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "src/propose/proposals.hpp"
#include "support.hpp"

namespace amhv {
namespace {

namespace fs = std::filesystem;
using namespace amhv::propose;

Vec3 turned(const Vec3& p, double degrees) {
    const double t = degrees * std::numbers::pi / 180, c = std::cos(t), s = std::sin(t);
    return {c * p.x() - s * p.y(), s * p.x() + c * p.y(), p.z()};
}

// The wrist of a labelled mesh is a weighted surface centroid: each triangle counts by its area
// times its weight, so a weight that keeps one triangle gives that triangle's centroid, and
// weights that are all 0 give none.
TEST(Propose, AWeightedSurfaceCentroidCountsEachTriangleByAreaAndWeight) {
    TriangleMesh mesh;
    mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {5, 0, 0}, {7, 0, 0}, {5, 2, 0}};
    mesh.triangles = {{0, 1, 2}, {3, 4, 5}};  // areas 0.5 and 2
    const Vec3 near{1.0 / 3, 1.0 / 3, 0}, far{17.0 / 3, 2.0 / 3, 0};
    const auto only_near = weighted_surface_centroid(mesh, [](const Vec3& c) { return c.x() < 2 ? 1.0 : 0.0; });
    ASSERT_TRUE(only_near);
    EXPECT_LT((*only_near - near).norm(), 1e-12);
    // Equal weights give the plain area-weighted centroid: (0.5 near + 2 far) / 2.5.
    const auto even = weighted_surface_centroid(mesh, [](const Vec3&) { return 3.0; });
    ASSERT_TRUE(even);
    EXPECT_LT((*even - *surface_centroid(mesh)).norm(), 1e-12);
    EXPECT_LT((*even - (0.5 * near + 2 * far) / 2.5).norm(), 1e-12);
    EXPECT_FALSE(weighted_surface_centroid(mesh, [](const Vec3&) { return 0.0; }));
}

// A track at `fps` whose hips move at `walk(f)` m/s along x and whose hands sit at `hand(f)`.
HandTrack track(double fps, int frames, const std::function<double(int)>& walk, const std::function<Vec3(int)>& hand) {
    HandTrack t;
    t.fps = fps;
    double x = 0;
    for (int f = 0; f < frames; ++f) {
        x += walk(f) / fps;
        t.hips.emplace_back(x, 0.0, 0.95);
        t.hand[0].push_back(hand(f) + Vec3(0, 0.4, 0));
        t.hand[1].push_back(hand(f));
    }
    return t;
}

std::vector<ContactEvent> of_variant(const std::vector<ContactEvent>& events, char variant, Hand hand) {
    std::vector<ContactEvent> out;
    for (const ContactEvent& e : events)
        if (e.variant == variant && e.hand == hand) out.push_back(e);
    return out;
}

// A shipped scene (data/scenes/NAME) without its key segments, its paths made absolute, `edit`
// applied to its text, written into `dir` as `file`.
fs::path without_segments(const fs::path& dir, const std::string& name, const std::string& file,
                          const std::function<void(std::string&)>& edit = nullptr) {
    const fs::path scenes = test::source_dir() / "data" / "scenes";
    std::string text = test::read_text(scenes / name);
    text = text.substr(0, text.find("[[segments]]"));
    for (std::size_t at; (at = text.find("\"../")) != std::string::npos;) text.replace(at + 1, 2, (scenes / "..").string());
    if (edit) edit(text);
    std::ofstream(dir / file) << text;
    return dir / file;
}

// A hand pumped up and down and back and forth, as in a handshake (2 Hz, a few centimetres).
Vec3 pumped(int f) {
    const double t = f / 120.0;
    return {0.3 + 0.04 * std::sin(2 * std::numbers::pi * 2 * t), 0.02 * std::cos(2 * std::numbers::pi * 1.3 * t), 1.0 + 0.05 * std::sin(2 * std::numbers::pi * 2.2 * t)};
}

TEST(Propose, CoupledMotionFindsTheShiftAndTurnOfHeldHands) {
    // B's frame f + 7 holds A's hand of frame f, turned by -40 degrees and moved: the held hands.
    const HandTrack a = track(120, 200, [](int) { return 0.0; }, pumped);
    const HandTrack b = track(120, 200, [](int) { return 0.0; }, [](int f) { return Vec3(turned(pumped(f - 7), -40) + Vec3(2, -1, 0.03)); });
    const Coupling at = coupled_motion(a, Hand::Right, b, Hand::Right, 40, 140, 7);
    EXPECT_LT(at.rms_m, 1e-6);  // a micrometre: the closed form subtracts sums of squares
    EXPECT_NEAR(at.theta_rad * 180 / std::numbers::pi, 40.0, 1e-6);
    for (int shift : {4, 10}) EXPECT_GT(coupled_motion(a, Hand::Right, b, Hand::Right, 40, 140, shift).rms_m, 0.005) << shift;
    // As candidates: both stand over frames 20..180 of their takes; the best shift is 7.
    const ContactEvent hold_a{Hand::Right, 'a', 20, 180, 20, 1.3, "a"}, hold_b{Hand::Right, 'a', 20, 180, 20, 1.3, "b"};
    const std::vector<Candidate> found = candidates(a, {hold_a}, b, {hold_b});
    ASSERT_FALSE(found.empty());
    EXPECT_EQ(found[0].shift(), 7);
    EXPECT_EQ(found[0].variant, 'a');
    EXPECT_EQ(found[0].a[0], 20);
    EXPECT_EQ(found[0].b[1], 180);
    EXPECT_LT(found[0].coupling_m, 1e-6);
}

// A handshake's shake, a known answer: at 120 fps, two people stand over frames 0..239 and hold
// hands still, but from frame 80 to 140 the joined hands pump one cycle at 2 Hz (3 cm up, 6 cm down,
// 3 cm up: three strokes peaking at 0.38 m/s) and rest again; B holds A's hand 5 frames later in
// its take; both hands sway 2 cm on the floor throughout. The hold's window is trimmed to the shake, a frame either side for the central
// differences. A hand that sways 1 cm at 0.5 Hz (0.03 m/s) does not shake: the hold keeps every
// frame both stand.
TEST(Propose, AHoldIsTrimmedToTheHandsShake) {
    auto shaken = [](double amplitude, double hz, int from, int to) {
        return [=](int f) {
            const double t = double(std::clamp(f, from, to) - from) / 120.0;
            const double sway = 0.02 * std::sin(2 * std::numbers::pi * 0.37 * f / 120.0);  // on the floor: no stroke
            return Vec3(0.3 + sway, 0.0, 1.0 + amplitude * std::sin(2 * std::numbers::pi * hz * t));
        };
    };
    const auto pump = shaken(0.03, 2.0, 80, 140);
    const HandTrack a = track(120, 240, [](int) { return 0.0; }, pump);
    const HandTrack b = track(120, 240, [](int) { return 0.0; }, [&](int f) { return Vec3(turned(pump(f - 5), 30) + Vec3(1, 0, 0)); });
    const auto shake = joined_shake(a, Hand::Right, b, Hand::Right, 10, 220, 5);
    ASSERT_TRUE(shake.has_value());
    EXPECT_EQ(shake->strokes, 3);
    EXPECT_NEAR(shake->a[0], 80, 1);
    EXPECT_NEAR(shake->a[1], 140, 1);
    EXPECT_NEAR(shake->slowest_mps, 2 * std::numbers::pi * 2.0 * 0.03, 0.03);
    const ContactEvent hold{Hand::Right, 'a', 10, 230, 10, 1.8, "stands"};
    const std::vector<Candidate> found = candidates(a, {hold}, b, {hold});
    ASSERT_FALSE(found.empty());
    EXPECT_EQ(found[0].shift(), 5);
    EXPECT_EQ(found[0].a, shake->a);
    EXPECT_EQ(found[0].b[1], shake->a[1] + 5);
    // Swaying held hands do not shake.
    const auto sway = shaken(0.01, 0.5, 0, 240);
    const HandTrack still = track(120, 240, [](int) { return 0.0; }, sway);
    EXPECT_FALSE(joined_shake(still, Hand::Right, still, Hand::Right, 10, 220, 0).has_value());
    const std::vector<Candidate> held = candidates(still, {hold}, still, {hold});
    ASSERT_FALSE(held.empty());
    EXPECT_EQ(held[0].a[0], 10);
    EXPECT_EQ(held[0].a[1], 230);
}

TEST(Propose, ASlapIsAHandsSuddenStopAndASwingIsNot) {
    // At 30 fps: the right hand arrives at 2.5 m/s and stops at frame 30 (an impact); the left hand
    // swings as a walker's arm (0.3 m at 1 Hz): no slap. The body walks: no hold.
    HandTrack t = track(30, 60, [](int) { return 1.2; }, [](int f) { return Vec3(f < 30 ? 2.5 * f / 30.0 : 2.5 + 0.2 * (f - 30) / 30.0, 0, 1.5); });
    for (int f = 0; f < 60; ++f) t.hand[0][std::size_t(f)] = t.hips[std::size_t(f)] + Vec3(0.15 * std::sin(2 * std::numbers::pi * f / 30.0), 0.2, -0.1);
    t.first = 100;
    const std::vector<ContactEvent> events = contact_events(t);
    const auto slaps = of_variant(events, 'b', Hand::Right);
    ASSERT_EQ(slaps.size(), 1u);
    EXPECT_NEAR(slaps[0].moment, 130, 1);
    EXPECT_EQ(slaps[0].last - slaps[0].first, 2 * int(std::lround(kSlapHalfSeconds * 30)));
    EXPECT_TRUE(of_variant(events, 'b', Hand::Left).empty());
    EXPECT_TRUE(of_variant(events, 'a', Hand::Right).empty());
    // Two such takes: the impacts meet, B's frames shifted by the difference of the moments.
    HandTrack later = t;
    later.first = 200;
    const std::vector<Candidate> found = candidates(t, slaps, later, of_variant(contact_events(later), 'b', Hand::Right));
    ASSERT_EQ(found.size(), 1u);
    EXPECT_EQ(found[0].shift(), 100);
    EXPECT_EQ(found[0].a[0], slaps[0].first);
    EXPECT_EQ(found[0].b[0], slaps[0].first + 100);
}

TEST(Propose, StandingIsAHoldForEitherHand) {
    // Walks at 1.2 m/s, stands from frame 60 to 119 (at 60 fps: one second), walks on.
    const HandTrack t = track(60, 180, [](int f) { return f >= 60 && f < 120 ? 0.0 : 1.2; }, [](int) { return Vec3(0.3, 0, 1.0); });
    const std::vector<ContactEvent> events = contact_events(t);
    for (Hand hand : {Hand::Left, Hand::Right}) {
        const auto holds = of_variant(events, 'a', hand);
        ASSERT_EQ(holds.size(), 1u);
        // The root's speed is a central difference over kStandSeconds: the run's ends move in by
        // up to half of it.
        const int reach = int(std::lround(kStandSeconds / 2 * 60));
        EXPECT_NEAR(holds[0].first, 60, reach);
        EXPECT_NEAR(holds[0].last, 119, reach);
    }
}

// The shipped real pairs with their key segments removed: the true key segment is among the top 3
// proposals with its type and parts, its A and B frames start and end within 5 frames of the
// shipped ranges, and B's shift is the shipped one within 2 frames.
TEST(Propose, TheShippedPairsProposeTheirKeySegments) {
    test::TempDir tmp;
    struct Expected {
        const char* scene;
        const char* type;
        int a0, a1, b0, b1;
    };
    // characters.toml is the demo's handshake as two characters (glTF), whose frame k is the
    // takes' k + 1: their rigs' joints give the moments.
    for (const Expected& e : {Expected{"demo.toml", "0&0a", 108, 147, 108, 147}, Expected{"highfive.toml", "0&0b", 29, 37, 29, 37},
                              Expected{"characters.toml", "0&0a", 107, 146, 107, 146}}) {
        const fs::path file = without_segments(tmp.path(), e.scene, e.scene);
        const fs::path out = tmp.path() / (std::string(e.scene) + ".out");
        const auto run = test::run_amhv(fmt::format("propose '{}' --out '{}'", file.string(), out.string()));
        ASSERT_EQ(run.exit_code, 0) << e.scene << run.output;
        const nlohmann::json proposals = nlohmann::json::parse(test::read_text(out / "proposals.json"))["proposals"];
        bool found = false;
        for (std::size_t n = 0; n < std::min<std::size_t>(3, proposals.size()) && !found; ++n) {
            const auto& p = proposals[n];
            found = p["type"] == e.type && p["parts"]["A"] == "right_hand" && p["parts"]["B"] == "right_hand" &&
                    std::abs(p["a"][0].get<int>() - e.a0) <= 5 && std::abs(p["b"][0].get<int>() - e.b0) <= 5 &&
                    std::abs(p["a"][1].get<int>() - e.a1) <= 5 && std::abs(p["b"][1].get<int>() - e.b1) <= 5 &&
                    std::abs(p["shift_frames"].get<int>() - (e.b0 - e.a0)) <= 2;
        }
        EXPECT_TRUE(found) << e.scene << "\n" << proposals.dump(1);
        // The page lists them and plays the best one, edited.
        EXPECT_NE(test::read_text(out / "index.html").find("best/index.html"), std::string::npos);
        EXPECT_TRUE(fs::is_regular_file(out / "best" / "index.html"));
        EXPECT_TRUE(fs::is_regular_file(out / "best" / "scene.glb"));
        EXPECT_EQ(nlohmann::json::parse(test::read_text(out / "best" / "result.json"))["segments"][0]["frames_a"], proposals[0]["a"]);
        // The blocks paste into the scene: the scene with the best one edits.
        const std::string blocks = test::read_text(out / "proposals.toml");
        std::ofstream(file, std::ios::app) << blocks.substr(0, blocks.find("\n# 2."));
        const auto edit = test::run_amhv(fmt::format("check '{}'", file.string()));
        EXPECT_EQ(edit.exit_code, 0) << e.scene << edit.output;
    }
}

// `amhv propose FILE --out OUT` (with `flags`) and its first proposal, which the tests below expect
// to be the handshake: 0&0a on the right hands. Null when the run fails or proposes nothing (the
// failure is reported).
nlohmann::json first_handshake_proposal(const fs::path& file, const fs::path& out, const std::string& flags = "") {
    const auto run = test::run_amhv(fmt::format("propose '{}' --out '{}'{}", file.string(), out.string(), flags));
    EXPECT_EQ(run.exit_code, 0) << run.output;
    if (run.exit_code != 0) return nullptr;
    const nlohmann::json proposals = nlohmann::json::parse(test::read_text(out / "proposals.json"))["proposals"];
    EXPECT_FALSE(proposals.empty());
    if (proposals.empty()) return nullptr;
    const nlohmann::json& p = proposals[0];
    EXPECT_EQ(p["type"], "0&0a");
    EXPECT_EQ(p["parts"]["A"], "right_hand");
    EXPECT_EQ(p["parts"]["B"], "right_hand");
    return p;
}

// Takes captured apart rarely share a tempo. B's take resampled at 108 and 132 fps (its frame k the
// pose at k / fps s) performs the handshake in 0.9 and 1.1 times A's frames, and A's frame f meets
// B's rate * f. A proposal pairs windows of equal length (the normalisation makes them one), so B's
// window is off by up to a tenth of its length at one end; the handshake is still proposed within
// 5 frames at both ends and edited within 5 cm and 6 degrees of the truth (docs/method.md section 13).
TEST(Propose, BAtAnotherTempoIsStillMetWhereTheHandsWereHeld) {
    test::TempDir tmp;
    for (const auto& tempo : {std::pair{108, 272}, std::pair{132, 330}}) {
        const int fps = tempo.first, last = tempo.second;  // plain names: the lambda below captures them
        const double rate = fps / 120.0;
        const std::string name = fmt::format("tempo{}.toml", fps);
        const fs::path file = without_segments(tmp.path(), "demo.toml", name, [&](std::string& text) {
            const std::string frames = "frames = [21, 303]";
            text.replace(text.find(frames), frames.size(), fmt::format("frames = [{}, {}]\nfps = {}", int(std::lround(21 * rate)), last, fps));
        });
        const fs::path out = tmp.path() / (name + ".out");
        const nlohmann::json p = first_handshake_proposal(file, out);
        ASSERT_FALSE(p.is_null()) << fps;
        for (int end : {0, 1}) {
            EXPECT_LE(std::abs(p["a"][end].get<int>() - (end ? 147 : 113)), 5) << fps << p.dump();
            EXPECT_LE(std::abs(p["b"][end].get<int>() - rate * p["a"][end].get<int>()), 5) << fps << p.dump();
        }
        const auto truth = nlohmann::json::parse(test::read_text(out / "best" / "result.json"))["segments"][0]["truth"];
        EXPECT_TRUE(truth["in_group"].get<bool>()) << fps << truth.dump();
        EXPECT_LE(truth["chosen_error_m"].get<double>(), 0.05) << fps << truth.dump();
        EXPECT_LE(truth["chosen_error_deg"].get<double>(), 6.0) << fps << truth.dump();
    }
}

// Where no pose of B meets A (the sweep's range keeps B 5 m away), there is no proposal: one line
// and no output.
TEST(Propose, NoPoseWithinReachIsNoProposal) {
    test::TempDir tmp;
    const fs::path file = without_segments(tmp.path(), "highfive.toml", "far.toml", [](std::string& text) {
        text.replace(text.find("[sampling]"), 10, "[sampling]\nx_range = [5.0, 6.0]\ny_range = [5.0, 6.0]");
    });
    const auto run = test::run_amhv(fmt::format("propose '{}' --out '{}'", file.string(), (tmp.path() / "out").string()));
    EXPECT_NE(run.exit_code, 0);
    EXPECT_EQ(test::one_line_error(run), 1) << run.output;
    EXPECT_NE(run.output.find("no proposal"), std::string::npos) << run.output;
    EXPECT_FALSE(fs::exists(tmp.path() / "out"));
}

// A labelled mesh sequence gives the moments its take gives: the demo's two takes written as mesh
// sequences with part labels (amhv import-bvh: the capsule bodies, one part name per vertex)
// propose the handshake the takes propose (A and B 113-147, shift 0), from the torsos and the
// hands' wrists (where each hand's surface meets its forearm).
TEST(Propose, ALabelledMeshSequenceProposesWhatItsTakeDoes) {
    test::TempDir tmp;
    const fs::path cmu = test::source_dir() / "data" / "cmu";
    for (const auto& [take, frames, dir] : {std::tuple{"18_01", "1:303", "a"}, std::tuple{"19_01", "21:303", "b"}}) {
        const auto run = test::run_amhv(fmt::format("import-bvh '{}' --frames {} --out '{}'", (cmu / (std::string(take) + ".bvh")).string(), frames,
                                                    (tmp.path() / dir).string()));
        ASSERT_EQ(run.exit_code, 0) << run.output;
    }
    const fs::path file = without_segments(tmp.path(), "demo.toml", "meshes.toml", [](std::string& text) {
        text = text.substr(0, text.find("[objects.A]")) + "[objects.A]\nmeshes = \"a/meshes/frame_%04d.ply\"\nlabels = \"a/labels/frame_%04d.txt\"\n"
               "unit = \"m\"\nup = \"z\"\nfps = 120\nframes = [1, 303]\n\n[objects.B]\nmeshes = \"b/meshes/frame_%04d.ply\"\n"
               "labels = \"b/labels/frame_%04d.txt\"\nunit = \"m\"\nup = \"z\"\nfps = 120\nframes = [21, 303]\n"
               "placement = { x = 4.0, y = -3.0, yaw_deg = 120.0 }\n";
    });
    const nlohmann::json p = first_handshake_proposal(file, tmp.path() / "out", " --no-best");
    ASSERT_FALSE(p.is_null());
    EXPECT_LE(std::abs(p["shift_frames"].get<int>()), 2) << p.dump();
    for (const char* side : {"a", "b"}) {
        EXPECT_LE(std::abs(p[side][0].get<int>() - 113), 5) << p.dump();
        EXPECT_LE(std::abs(p[side][1].get<int>() - 147), 5) << p.dump();
    }
}

// A mesh sequence without part labels has no hands to follow: one line naming the object, no output.
TEST(Propose, AnUnlabelledMeshSequenceIsRefusedInOneLine) {
    test::TempDir tmp;
    fs::create_directories(tmp.path() / "m");
    for (int f = 0; f < 3; ++f)
        std::ofstream(tmp.path() / "m" / fmt::format("{:04d}.obj", f)) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n";
    const fs::path file = without_segments(tmp.path(), "demo.toml", "meshes.toml", [](std::string& text) {
        const std::size_t b = text.find("[objects.B]");
        text = text.substr(0, b) + "[objects.B]\nmeshes = \"m/%04d.obj\"\n";
    });
    const auto run = test::run_amhv(fmt::format("propose '{}' --out '{}'", file.string(), (tmp.path() / "out").string()));
    EXPECT_NE(run.exit_code, 0);
    EXPECT_EQ(test::one_line_error(run), 1) << run.output;
    EXPECT_NE(run.output.find("object B is a mesh sequence without part labels"), std::string::npos) << run.output;
    EXPECT_FALSE(fs::exists(tmp.path() / "out"));
}

// Both backends propose the same, byte for byte (at 4 cm / 8 degrees, where no proposal is swept
// again: the CPU reference's sweep at 1 cm takes minutes), and a rerun too.
TEST(Propose, BothBackendsAndRerunsProposeTheSame) {
    test::TempDir tmp;
    const fs::path file = without_segments(tmp.path(), "highfive.toml", "coarse.toml", [](std::string& text) {
        text.replace(text.find("voxel = 0.01"), 12, "voxel = 0.04");
        text.replace(text.find("angle_step_deg = 2.0"), 20, "angle_step_deg = 8.0");
    });
    std::vector<std::string> tomls;
    for (const char* backend : {"vulkan", "cpu", "vulkan"}) {
        const fs::path out = tmp.path() / fmt::format("out_{}", tomls.size());
        const auto run = test::run_amhv(fmt::format("propose '{}' --out '{}' --backend {} --no-best", file.string(), out.string(), backend));
        ASSERT_EQ(run.exit_code, 0) << backend << run.output;
        tomls.push_back(test::read_text(out / "proposals.toml"));
    }
    EXPECT_NE(tomls[0].find("[[segments]]"), std::string::npos);
    EXPECT_EQ(tomls[0], tomls[1]);
    EXPECT_EQ(tomls[0], tomls[2]);
}

// `amhv edit --propose` on a scene without key segments edits with the best proposal; without
// --propose such a scene is refused, pointing at amhv propose.
TEST(Propose, EditProposeEditsASceneWithoutKeySegments) {
    test::TempDir tmp;
    const fs::path file = without_segments(tmp.path(), "highfive.toml", "open.toml");
    const auto refused = test::run_amhv(fmt::format("edit '{}' --out '{}' --no-frames --no-glb", file.string(), (tmp.path() / "no").string()));
    EXPECT_EQ(test::one_line_error(refused), 1) << refused.output;
    EXPECT_NE(refused.output.find("amhv propose"), std::string::npos) << refused.output;
    const auto run = test::run_amhv(fmt::format("edit '{}' --propose --out '{}' --no-frames --no-glb", file.string(), (tmp.path() / "out").string()));
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const nlohmann::json result = nlohmann::json::parse(test::read_text(tmp.path() / "out" / "result.json"));
    ASSERT_EQ(result["segments"].size(), 1u);
    EXPECT_EQ(result["segments"][0]["type"], "0&0b");
    EXPECT_GT(result["segments"][0]["solutions"].get<int>(), 0);
}

}  // namespace
}  // namespace amhv
