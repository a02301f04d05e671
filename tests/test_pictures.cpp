// The pictures a reader looks at first (docs/scenes.md, "Outputs of amhv edit"): the key views
// look at the meeting from where nothing hides it; the paths picture names what it draws.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "src/body/shapes.hpp"
#include "src/results/key_views.hpp"
#include "src/results/paths_picture.hpp"
#include "support.hpp"

namespace amhv {
namespace {

namespace fs = std::filesystem;

// Two balls touching at (0.1, 0, 1), their line along x, and `blockers` more balls.
struct Meeting2 {
    TriangleMesh scene;
    std::vector<bool> part;
    Meeting meeting;
    explicit Meeting2(const std::vector<Vec3>& blockers) {
        const TriangleMesh a = shapes::sphere(Vec3(0, 0, 1), 0.1, 12, 16), b = shapes::sphere(Vec3(0.2, 0, 1), 0.1, 12, 16);
        scene.append(a);
        scene.append(b);
        part.assign(scene.triangles.size(), true);
        for (const Vec3& c : blockers) scene.append(shapes::sphere(c, 0.25, 12, 16));
        part.resize(scene.triangles.size(), false);
        meeting = find_meeting(a, b, Eigen::Vector2d::UnitX());
    }
};

TEST(KeyViews, TheMeetingIsFoundBetweenThePartsAndSeenAcrossTheirLine) {
    const Meeting2 m({});
    EXPECT_NEAR(m.meeting.centre().x(), 0.1, 0.02);
    EXPECT_NEAR(m.meeting.direction.x(), 1.0, 1e-9);
    const KeyCamera c = choose_key_camera(m.scene, m.part, m.meeting);
    EXPECT_EQ(c.blocked, 0);
    EXPECT_EQ(c.turn_deg, 0);
    EXPECT_EQ(c.raise_deg, 0);
    EXPECT_NEAR(std::abs(c.forward.y()), 1.0, 1e-9);  // across the line between the parts
}

TEST(KeyViews, ABodyInFrontOfTheMeetingTurnsOrRaisesTheCamera) {
    // A third body on the +y side, where the camera would first stand (looking towards -y): it looks
    // from the other side instead, not turned.
    const Meeting2 side({Vec3(0.1, 0.6, 1)});
    const KeyCamera one = choose_key_camera(side.scene, side.part, side.meeting);
    EXPECT_EQ(one.blocked, 0);
    EXPECT_EQ(one.turn_deg, 0);
    EXPECT_GT(one.forward.y(), 0.9);  // from -y, looking towards +y (the third body behind the parts)
    // Bodies on both sides, across the line: the camera turns until it sees past them.
    const Meeting2 both({Vec3(0.1, -0.6, 1), Vec3(0.1, 0.6, 1)});
    const KeyCamera turned = choose_key_camera(both.scene, both.part, both.meeting);
    EXPECT_EQ(turned.blocked, 0);
    EXPECT_TRUE(turned.turn_deg != 0 || turned.raise_deg != 0);
    // Walls of bodies all around at the parts' height: it rises over them.
    std::vector<Vec3> ring;
    for (int k = 0; k < 24; ++k) ring.push_back(Vec3(0.1 + 0.6 * std::cos(k * std::numbers::pi / 12), 0.6 * std::sin(k * std::numbers::pi / 12), 1));
    const Meeting2 walled(ring);
    const KeyCamera raised = choose_key_camera(walled.scene, walled.part, walled.meeting);
    EXPECT_EQ(raised.blocked, 0);
    EXPECT_GT(raised.raise_deg, 0);
}

TEST(PathsPicture, ItsLegendNamesEveryPerformerAndWhatTheLinesMean) {
    test::TempDir tmp;
    std::vector<ObjectFrameEdit> a(30), b(30);
    for (int k = 0; k < 30; ++k) {
        a[std::size_t(k)].edited_root = a[std::size_t(k)].original_root = Eigen::Vector2d(0.05 * k, 0);
        b[std::size_t(k)].original_root = Eigen::Vector2d(3, 0.05 * k);
        b[std::size_t(k)].edited_root = Eigen::Vector2d(2 - 0.05 * k, 0.6);
    }
    write_paths_picture(tmp.path() / "paths.svg", tmp.path() / "paths.png", {{"A", &a, {{1, 10, 5}}}, {"Bob", &b, {{1, 10, 5}}}});
    const std::string svg = test::read_text(tmp.path() / "paths.svg");
    for (const char* text : {">A (orange)<", ">Bob (blue)<", ">edited path<", ">captured path (at the editor's initial placement)<",
                             ">key segment N, labelled at its first frame<", ">facing, every 10 output frames<", ">x (m)<", ">y (m)<", ">1 m<",
                             ">A: key 1<", ">Bob: key 1<"})
        EXPECT_NE(svg.find(text), std::string::npos) << text;
    EXPECT_NE(svg.find("stroke-dasharray"), std::string::npos);  // the captured paths dashed
    // The PNG carries the same text (drawn from the font file): far more dark pixels than the
    // lines alone would give, and the same bytes on every run.
    const std::string png = test::read_text(tmp.path() / "paths.png");
    write_paths_picture(tmp.path() / "again.svg", tmp.path() / "again.png", {{"A", &a, {{1, 10, 5}}}, {"Bob", &b, {{1, 10, 5}}}});
    EXPECT_EQ(png, test::read_text(tmp.path() / "again.png"));
}

}  // namespace
}  // namespace amhv
