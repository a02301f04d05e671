// The skinned body (src/body/skinned_body.hpp): the shipped CC0 human, closed, fitted to both CMU
// skeletons (arms out in 18/19's rest pose, arms down in 20/21's), follows the takes' joints, has
// the capsule body's part names, every part closed, and voxelises as a solid on both backends
// bit for bit; scenes and the CLI take it.
#include <cmath>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "host/reference/voxelise_reference.hpp"
#include "src/body/skeleton_body.hpp"
#include "src/body/skeleton_roles.hpp"
#include "src/body/skinned_body.hpp"
#include "src/core/error.hpp"
#include "src/scene/scene.hpp"
#include "src/scene/segment.hpp"
#include "src/voxelise/voxelise.hpp"
#include "src/voxelise/voxelise_vulkan.hpp"
#include "support.hpp"

namespace amhv {
namespace {

namespace fs = std::filesystem;

const SkinModel& model() {
    static const SkinModel m = load_skin_model(test::source_dir() / "data/bodies/human-male.glb");
    return m;
}

// The shipped model has holes (27 boundary edges once welded): each is capped, and the result is
// a closed surface; every weight names a joint and sums to 1.
TEST(SkinnedBody, TheModelIsClosedByCappingItsHoles) {
    const SkinModel& m = model();
    EXPECT_EQ(m.welded_vertices(), 7011u);
    EXPECT_GT(m.capped_holes, 0);
    EXPECT_EQ(m.vertices.size(), m.welded_vertices() + std::size_t(m.capped_holes));
    EXPECT_TRUE((TriangleMesh{m.vertices, m.triangles}.is_closed()));
    EXPECT_EQ(m.joint_names.size(), 66u);
    for (std::size_t v = 0; v < m.welded_vertices(); ++v) {
        float sum = 0;
        for (std::size_t c = 0; c < 4; ++c) sum += m.weights[v][c];
        ASSERT_NEAR(sum, 1.0f, 1e-5f) << v;
    }
    // Its bind pose stands on the floor, 1.83 m tall, z up.
    Box3 box;
    for (const Vec3& v : m.vertices) box.extend(v);
    EXPECT_NEAR(box.min.z(), 0.0, 0.01);
    EXPECT_NEAR(box.max.z(), 1.83, 0.01);
}

struct Take {
    const char* file;
    int frame;
};

class SkinnedTake : public ::testing::TestWithParam<Take> {};

// At a captured frame the body's parts sit on the take's joints: each hand part around its wrist
// (within a hand's length), the head around the head joint, the feet on the ankles; the parts are
// the capsule body's names and each part is closed.
TEST_P(SkinnedTake, PartsFollowTheTakesJointsAndAreClosed) {
    const BvhMotion motion = load_bvh(test::source_dir() / "data/cmu" / GetParam().file, {});
    SkeletonBodyOptions options;
    options.skinned = fit_skin_model(model(), motion, options.units);
    const SkinnedFitSummary summary = summarise(*options.skinned);
    EXPECT_GT(summary.scale, 0.8);
    EXPECT_LT(summary.scale, 1.2);
    EXPECT_GT(summary.part_caps, 10);  // every cut between two parts is capped
    const int f = GetParam().frame;
    const std::vector<BodyPart> parts = skeleton_body_parts(motion, f, options);
    std::vector<std::string> names;
    for (const BodyPart& p : parts) names.push_back(p.name);
    EXPECT_EQ(names, body_part_names(motion, true));
    const auto roles = role_names(motion);
    const auto global = motion.global_transforms(f);
    auto joint = [&](const char* role) {
        const auto at = std::find(roles.begin(), roles.end(), role);
        return to_scene_point(global[std::size_t(at - roles.begin())].translation(), options.units);
    };
    auto centre = [&](const std::string& name) {
        for (const BodyPart& p : parts)
            if (p.name == name) {
                EXPECT_TRUE(p.mesh.is_closed()) << name;
                Vec3 sum = Vec3::Zero();
                for (const Vec3& v : p.mesh.vertices) sum += v;
                return Vec3(sum / double(p.mesh.vertices.size()));
            }
        ADD_FAILURE() << "no part " << name;
        return Vec3(Vec3::Zero());
    };
    for (const BodyPart& p : parts) EXPECT_TRUE(p.mesh.is_closed()) << p.name;
    EXPECT_LT((centre("right_hand") - joint("RightHand")).norm(), 0.15);
    EXPECT_LT((centre("left_hand") - joint("LeftHand")).norm(), 0.15);
    EXPECT_LT((centre("head") - joint("Head")).norm(), 0.15);
    EXPECT_LT((centre("right_foot") - joint("RightFoot")).norm(), 0.15);
    EXPECT_LT((centre("left_shin") - 0.5 * (joint("LeftLeg") + joint("LeftFoot"))).norm(), 0.08);
    EXPECT_LT((centre("right_forearm") - 0.5 * (joint("RightForeArm") + joint("RightHand"))).norm(), 0.08);
}

// The whole skinned body over 40 frames voxelises as a solid (no frame falls back to the surface
// rule), the same on Vulkan and the CPU reference, to a person's volume.
TEST_P(SkinnedTake, VoxelisesAsASolidOnBothBackends) {
    const BvhMotion motion = load_bvh(test::source_dir() / "data/cmu" / GetParam().file, {});
    SkeletonBodyOptions options;
    options.skinned = fit_skin_model(model(), motion, options.units);
    const int first = std::max(motion.first_frame, GetParam().frame - 20);
    const MeshSequence sequence = skeleton_body_sequence(motion, {first, first + 39}, options);
    const VoxelisationInput input = prepare_voxelisation(sequence, 0.01);
    ReferenceVoxeliser reference;
    gpu::VulkanVoxeliser vulkan(test::context());
    VoxeliseReport report;
    const Amhv gpu = voxelise(input, vulkan, &report);
    test::expect_no_validation_messages();
    EXPECT_TRUE(report.open_frames.empty());
    const Amhv cpu = voxelise(input, reference);
    ASSERT_EQ(gpu.mask().size(), cpu.mask().size());
    EXPECT_TRUE(std::equal(gpu.mask().begin(), gpu.mask().end(), cpu.mask().begin()));
    const AmhvSummary summary = summarise(gpu);
    for (std::size_t f = 0; f < summary.occupied_per_frame.size(); ++f) {
        const double litres = double(summary.occupied_per_frame[f]) * 1e-3;  // 1 cm voxels
        EXPECT_GT(litres, 40) << f;
        EXPECT_LT(litres, 95) << f;
    }
}

INSTANTIATE_TEST_SUITE_P(Cmu, SkinnedTake, ::testing::Values(Take{"19_01.bvh", 130}, Take{"20_11.bvh", 33}),
                         [](const auto& test_info) { return std::string(test_info.param.file).substr(0, 5); });

// body = "skinned" in a scene gives the object the skinned parts (the fit of ObjectSource equals
// one made by hand); a mesh sequence cannot take it, and an unknown body is named.
TEST(SkinnedBody, ScenesAndTheCliTakeIt) {
    test::TempDir tmp;
    const fs::path bvh = test::source_dir() / "data/cmu/19_01.bvh";
    const auto scene_text = [&](const std::string& b_body) {
        return fmt::format("[sampling]\nvoxel = 0.04\nangle_step_deg = 30\n\n[objects.A]\nbvh = '{0}'\nbody = \"skinned\"\n\n"
                           "[objects.B]\nbvh = '{0}'\n{1}\n\n[[segments]]\na = [100, 110]\nb = [100, 110]\ntype = \"0&0a\"\n"
                           "interest = {{ A = {{ parts = [\"right_hand\"] }}, B = {{ parts = [\"right_hand\"] }} }}\n",
                           bvh.string(), b_body);
    };
    std::ofstream(tmp.path() / "scene.toml") << scene_text("");
    const Scene scene = load_scene(tmp.path() / "scene.toml");
    EXPECT_EQ(scene.a.body, BodyKind::Skinned);
    EXPECT_EQ(scene.b.body, BodyKind::Capsules);
    ObjectSource a(scene.a);
    const BvhMotion motion = load_bvh(bvh, {});
    SkeletonBodyOptions options;
    options.skinned = fit_skin_model(model(), motion, options.units);
    const auto expected = skeleton_body_parts(motion, 105, options);
    const auto& got = a.frame_parts(105);
    ASSERT_EQ(got.size(), expected.size());
    for (std::size_t p = 0; p < got.size(); ++p) EXPECT_EQ(got[p].mesh.vertices, expected[p].mesh.vertices) << got[p].name;

    std::ofstream(tmp.path() / "bad.toml") << scene_text("body = \"robot\"");
    try {
        load_scene(tmp.path() / "bad.toml");
        ADD_FAILURE() << "an unknown body was accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("'robot' is not a body"), std::string::npos) << e.what();
    }

    // import-bvh --body skinned writes the skinned frames and their part labels; a mesh library
    // (OpenMesh) reads them back as written (every part a closed manifold) and closed.
    const fs::path out = tmp.path() / "imported";
    auto run = test::run_amhv(fmt::format("import-bvh '{}' --frames 100:102 --body skinned --out '{}'", bvh.string(), out.string()));
    ASSERT_EQ(run.exit_code, 0) << run.output;
    const TriangleMesh read = read_mesh(out / "meshes/frame_0101.ply", UnitsAndAxes{1.0, UpAxis::Z});
    std::size_t vertices = 0;
    for (const BodyPart& part : skeleton_body_parts(motion, 101, options)) vertices += part.mesh.vertices.size();
    EXPECT_EQ(read.vertices.size(), vertices);
    EXPECT_TRUE(read.is_closed());
    auto refused = test::run_amhv(fmt::format("import-bvh '{}' --body robot --out '{}'", bvh.string(), (tmp.path() / "x").string()));
    EXPECT_EQ(refused.exit_code, 1);
    EXPECT_EQ(test::one_line_error(refused), 1) << refused.output;
    EXPECT_FALSE(fs::exists(tmp.path() / "x"));
}

// A skinned model file that is not glTF, or has no skin, is refused naming it.
TEST(SkinnedBody, AModelThatIsNoSkinnedGlbIsRefused) {
    test::TempDir tmp;
    std::ofstream(tmp.path() / "text.glb") << "not a glb";
    EXPECT_THROW(load_skin_model(tmp.path() / "text.glb"), Error);
    EXPECT_THROW(load_skin_model(tmp.path() / "missing.glb"), Error);
    try {
        load_skin_model(test::source_dir() / "data/pictures/demo_key_1.png");
        ADD_FAILURE();
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("demo_key_1.png"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace amhv
