// Skinning (src/body/skinning.hpp, shaders/skin.comp): the Vulkan kernel equals the CPU reference
// bit for bit, on the shipped character and on a constructed one with a known answer.
#include <cmath>
#include <cstring>
#include <numbers>

#include <gtest/gtest.h>

#include "src/body/character_body.hpp"
#include "src/body/skin_vulkan.hpp"
#include "src/body/skinning.hpp"
#include "support.hpp"

namespace amhv {
namespace {

// Two nodes: "Arm" at the origin and "Hand" 1 m along x below it, whose local turn about z is
// 0 at frame 0 and 90 degrees at frame 1. Vertex 0 at (2, 0, 0) is skinned to Hand alone,
// vertex 1 at (1, 0, 0) half to each, vertex 2 at (1.5, 0, 0) rides Hand as an unskinned mesh.
CharacterFile two_bones() {
    CharacterFile c;
    c.source = "constructed";
    c.nodes = {{"Arm", -1, Eigen::Affine3d::Identity(), false}, {"Hand", 0, Eigen::Affine3d(Eigen::Translation3d(1, 0, 0)), true}};
    c.bones = {{0, Eigen::Affine3d::Identity()}, {1, Eigen::Affine3d(Eigen::Translation3d(-1, 0, 0))}};
    c.vertices = {Vec3(2, 0, 0), Vec3(1, 0, 0), Vec3(0.5, 0, 0)};
    c.vertex_bones = {{1, -1, -1, -1}, {0, 1, -1, -1}, {-1, -1, -1, -1}};
    c.vertex_weights = {{1, 0, 0, 0}, {0.5, 0.5, 0, 0}, {0, 0, 0, 0}};
    c.rigid_node = {-1, -1, 1};
    c.triangles = {{0, 1, 2}};
    for (double degrees : {0.0, 90.0}) {
        Eigen::Affine3d hand = Eigen::Translation3d(1, 0, 0) * Eigen::AngleAxisd(degrees * std::numbers::pi / 180, Vec3::UnitZ());
        c.frames.push_back({Eigen::Affine3d::Identity(), hand});
    }
    return c;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

TEST(Skinning, ABentHandPutsItsVerticesWhereTheAngleSays) {
    const CharacterFile c = two_bones();
    const SkinVertices vertices = skin_vertices(c);
    EXPECT_EQ(vertices.palette_size, 3u);  // two bones and the node the unskinned vertex rides on
    const UnitsAndAxes units{0.5, UpAxis::Z, std::nullopt, 0.25};  // half a metre per unit, lifted by 0.25 m
    std::vector<SkinFrame> frames{skin_frame(c, 0, units), skin_frame(c, 1, units)};
    CpuSkinner cpu;
    std::vector<float> out;
    cpu.skin(vertices, frames, out);
    const std::vector<Vec3> rest = skinned_points(out, 3, 0, frames[0]), bent = skinned_points(out, 3, 1, frames[1]);
    const double tolerance = 1e-6;  // metres: floats about a body-sized anchor
    EXPECT_LT((rest[0] - Vec3(1.0, 0, 0.25)).norm(), tolerance);
    EXPECT_LT((bent[0] - Vec3(0.5, 0.5, 0.25)).norm(), tolerance);   // the hand's tip turned up
    EXPECT_LT((bent[1] - Vec3(0.5, 0, 0.25)).norm(), tolerance);     // the wrist: both bones agree
    EXPECT_LT((bent[2] - Vec3(0.5, 0.25, 0.25)).norm(), tolerance);  // the unskinned mesh turns with Hand
    gpu::VulkanSkinner gpu_skinner(test::context());
    std::vector<float> got;
    gpu_skinner.skin(vertices, frames, got);
    EXPECT_TRUE(same_bits(got, out));
    test::expect_no_validation_messages();
}

// 40 frames of the shipped character (CMU 18_01 on the CC0 human, 16k vertices) in the demo's
// units, skinned on the device in one batch, in batches of 3 frames, in chunks of 1,000 vertices
// and through staged transfers: every float equal to the reference's, bit for bit.
TEST(Skinning, VulkanEqualsTheReferenceBitForBitOnFortyFramesOfTheFixture) {
    const CharacterFile c = read_character(test::source_dir() / "data" / "characters" / "cmu_18_01.glb", std::nullopt, std::nullopt);
    const SkinVertices vertices = skin_vertices(c);
    const UnitsAndAxes units{1.0, UpAxis::Y, std::nullopt, 0.013};
    std::vector<SkinFrame> frames;
    for (int f = 100; f < 140; ++f) frames.push_back(skin_frame(c, f, units));
    CpuSkinner cpu;
    std::vector<float> reference;
    cpu.skin(vertices, frames, reference);
    // The reference against skinning in double (the file's Eigen transforms): within a micrometre.
    for (int f : {0, 39}) {
        const std::vector<Vec3> points = skinned_points(reference, vertices.count(), std::size_t(f), frames[std::size_t(f)]);
        const std::vector<Vec3> exact = skin_character_vertices(c, 100 + f);
        double worst = 0;
        for (std::size_t v = 0; v < exact.size(); ++v) worst = std::max(worst, (points[v] - to_scene_point(exact[v], units)).norm());
        EXPECT_LT(worst, 1e-6) << "frame " << 100 + f;
    }
    struct Case {
        gpu::Context* context;
        gpu::SkinnerOptions options;
        int chunks, batches;
    };
    const std::size_t frame_bytes = 12 * vertices.count();
    const std::uint32_t chunk = 1000;
    const int chunks = int((vertices.count() + chunk - 1) / chunk);
    for (const Case& k : {Case{&test::context(), {}, 1, 1}, Case{&test::context(), {3 * frame_bytes, 0}, 1, 14},
                          Case{&test::context(), {std::uint64_t(1) << 20, chunk}, chunks, chunks}, Case{&test::staged_context(), {}, 1, 1}}) {
        gpu::VulkanSkinner skinner(*k.context, k.options);
        std::vector<float> got;
        skinner.skin(vertices, frames, got);
        EXPECT_TRUE(same_bits(got, reference)) << k.chunks << " chunks, " << k.batches << " batches";
        EXPECT_EQ(skinner.last_plan().chunks, k.chunks);
        EXPECT_EQ(skinner.last_plan().batches, k.batches);
    }
    test::expect_no_validation_messages();
}

}  // namespace
}  // namespace amhv
