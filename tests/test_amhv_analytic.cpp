// A sphere moving in a straight line: swept volume and per-voxel timing against closed forms, plus
// real body frames from the CMU capture: GPU and CPU reference bit for bit.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "src/body/shapes.hpp"
#include "src/core/error.hpp"
#include "src/body/skeleton_body.hpp"
#include "src/core/normalise.hpp"
#include "src/voxelise/voxelise.hpp"
#include "src/voxelise/voxelise_vulkan.hpp"
#include "src/io/bvh.hpp"
#include "host/reference/voxelise_reference.hpp"
#include "support.hpp"

namespace amhv {
namespace {

TEST(AmhvAnalytic, MovingSphereSweptVolumeAndTiming) {
    const double r = 0.2, h = 0.01, step = 0.01;
    const int frames = 60;
    const Vec3 start(0.0, 0.0, 1.0), velocity(step, 0.0, 0.0);
    MeshSequence sequence;
    for (int t = 0; t < frames; ++t) sequence.frames.push_back({shapes::sphere(start + t * velocity, r, 48, 64), ""});
    auto input = prepare_voxelisation(sequence, h);
    gpu::VulkanVoxeliser vulkan(test::context());
    Amhv volume = voxelise(input, vulkan);
    test::expect_no_validation_messages();

    // Swept volume of the tessellated sphere along the path: a capsule of the same length; the
    // polygon's volume ratio accounts for the tessellation. Tolerance 1.5% (voxel staircase).
    double d = step * (frames - 1);
    double ratio = shapes::signed_volume(sequence.frames[0].mesh) / (4.0 / 3.0 * std::numbers::pi * r * r * r);
    double swept = (4.0 / 3.0 * std::numbers::pi * r * r * r + std::numbers::pi * r * r * d) * ratio;
    auto summary = summarise(volume);
    EXPECT_NEAR(double(summary.occupied_voxels), swept / (h * h * h), 0.015 * swept / (h * h * h));
    EXPECT_EQ(summary.gap_voxels, 0u);  // a convex body moving straight covers each voxel in one interval

    // Voxels on the path axis: the sphere covers centre p at frame t when |p - c(t)| < r. Skip
    // voxels where some frame puts p within the tessellation band [r cos(pi/48)... r].
    const auto& grid = volume.grid();
    const double inner = r * std::cos(std::numbers::pi / 48) * std::cos(std::numbers::pi / 64);
    int checked = 0;
    int y = int((start.y() - grid.origin.y()) / h), z = int((start.z() - grid.origin.z()) / h);
    for (int x = 0; x < grid.dims[0]; ++x) {
        Vec3 p = grid.centre(x, y, z);
        int first = -1, last = -1;
        bool ambiguous = false;
        for (int t = 0; t < frames; ++t) {
            double distance = (p - (start + t * velocity)).norm();
            if (distance > inner - 1e-3 && distance < r + 1e-3) ambiguous = true;
            if (distance < r) {
                if (first < 0) first = t;
                last = t;
            }
        }
        if (ambiguous) continue;
        std::size_t v = grid.index(x, y, z);
        EXPECT_EQ(volume.t_start(v), first) << "x " << x;
        EXPECT_EQ(volume.t_end(v), last) << "x " << x;
        ++checked;
    }
    EXPECT_GT(checked, 40);
}

// A volume freed and the next one of about its size: the memory is kept and handed on, and the new
// volume must still start empty (cleared on all cores instead of by calloc).
TEST(AmhvAnalytic, RecycledVolumesStartEmpty) {
    VoxelGrid grid;
    grid.dims = {100, 120, 130};  // 1.56 M voxels, two words: 12.5 MB
    const std::uint32_t* first_mask = nullptr;
    {
        Amhv volume(grid, 40);
        for (std::size_t voxel = 0; voxel < volume.voxel_count(); voxel += 7) volume.set(voxel, int(voxel % 40));
        first_mask = volume.mask().data();
    }
    Amhv next(grid, 40);
    EXPECT_EQ(next.mask().data(), first_mask) << "the freed volume's memory was not handed on";
    EXPECT_TRUE(std::all_of(next.mask().begin(), next.mask().end(), [](std::uint32_t word) { return word == 0; }));
    release_recycled_volume();
    Amhv after_release(grid, 40);
    EXPECT_TRUE(std::all_of(after_release.mask().begin(), after_release.mask().end(), [](std::uint32_t word) { return word == 0; }));
}

// The parts of the summary computed on their own must be its values to the bit: an empty volume,
// one voxel, and scattered voxels over frames in every word on an off-lattice grid.
TEST(AmhvAnalytic, PartsOfTheSummaryAreItsValues) {
    VoxelGrid grid;
    grid.dims = {37, 23, 41};
    grid.voxel = 0.0073;
    grid.origin = Vec3(-1.234567, 0.987654, 0.0111);
    const auto expect_parts = [](const Amhv& volume, const char* what) {
        const AmhvSummary summary = summarise(volume);
        EXPECT_EQ(any_occupied(volume), summary.occupied_voxels > 0) << what;
        const Box3 bounds = occupied_bounds(volume);
        EXPECT_EQ(bounds.empty(), summary.bounds.empty()) << what;
        if (!summary.bounds.empty()) {
            EXPECT_EQ(bounds.min, summary.bounds.min) << what;
            EXPECT_EQ(bounds.max, summary.bounds.max) << what;
        }
        EXPECT_EQ(occupied_root(volume), summary.root) << what;
        // The occupied voxels per slice are those any() finds, in order (8 at a time and a tail).
        const auto slices = occupied_by_slice(volume);
        ASSERT_EQ(slices.size(), std::size_t(volume.grid().dims[2])) << what;
        const std::size_t per_slice = std::size_t(volume.grid().dims[0]) * std::size_t(volume.grid().dims[1]);
        for (std::size_t z = 0; z < slices.size(); ++z) {
            std::vector<std::uint32_t> expected;
            for (std::size_t v = 0; v < per_slice; ++v)
                if (volume.any(z * per_slice + v)) expected.push_back(std::uint32_t(v));
            EXPECT_EQ(slices[z], expected) << what << " slice " << z;
        }
    };
    Amhv volume(grid, 70);
    expect_parts(volume, "empty");
    volume.set(grid.index(36, 0, 17), 69);
    expect_parts(volume, "one voxel in the last word");
    volume.set(grid.index(36, 22, 40), 3);  // the last voxel of the last slice: in the tail of 851 = 106 * 8 + 3
    expect_parts(volume, "and one in a slice's tail");
    EXPECT_TRUE(any_occupied(volume));
    std::mt19937 random(5);
    for (int k = 0; k < 900; ++k)
        volume.set(grid.index(int(random() % 30) + 3, int(random() % 20), int(random() % 35) + 2), int(random() % 70));
    expect_parts(volume, "scattered");
    EXPECT_NE(occupied_root(volume), Vec3(Vec3::Zero()));
}

TEST(AmhvAnalytic, LabelsFollowTheSurfaces) {
    // Voxels only reached at the last frame are on the ending surface, only at the first frame on
    // the starting surface; a voxel covered from the first to the last frame carries +1.
    VoxelGrid grid{0.1, Vec3::Zero(), {4, 1, 1}};
    Amhv volume(grid, 5);
    volume.set(0, 0);
    volume.set(1, 4);
    volume.set(2, 2);
    for (int t = 0; t < 5; ++t) volume.set(3, t);
    EXPECT_EQ(volume.label(0), -1);
    EXPECT_EQ(volume.label(1), 1);
    EXPECT_EQ(volume.label(2), 0);
    EXPECT_EQ(volume.label(3), 1);
    volume.set(2, 0);
    volume.set(2, 3);
    EXPECT_TRUE(volume.has_gap(2));
    EXPECT_EQ(volume.frame_count(2), 3);
}

// 48 frames of a real capture (CMU subject 18 walking into the handshake) as capsule bodies.
TEST(AmhvAnalytic, RealBodyFramesMatchReferenceAt5mm) {
    BvhMotion motion = read_bvh(test::source_dir() / "data/cmu/18_01.bvh");
    MeshSequence sequence = skeleton_body_sequence(motion, {40, 87}, {});
    for (const auto& frame : sequence.frames) ASSERT_TRUE(frame.mesh.is_closed());
    auto input = prepare_voxelisation(sequence, 0.005);
    ReferenceVoxeliser reference;
    gpu::VulkanVoxeliser vulkan(test::context());
    Amhv expected = voxelise(input, reference);
    Amhv actual = voxelise(input, vulkan);
    test::expect_no_validation_messages();
    EXPECT_EQ(expected.mask(), actual.mask());
    auto summary = summarise(actual);
    // A 1.8 m person is roughly 0.06-0.09 m^3: about 480k-720k voxels of 5 mm per frame.
    double per_frame = double(summary.occupied_per_frame[0]) * 0.005 * 0.005 * 0.005;
    EXPECT_GT(per_frame, 0.04);
    EXPECT_LT(per_frame, 0.12);
}

TEST(Normalise, ResampleIndicesFollowEquation12) {
    EXPECT_EQ(resample_indices(10, 5), (std::vector<int>{0, 2, 4, 6, 8}));
    EXPECT_EQ(resample_indices(7, 7), (std::vector<int>{0, 1, 2, 3, 4, 5, 6}));
    EXPECT_EQ(resample_indices(3, 6), (std::vector<int>{0, 0, 1, 1, 2, 2}));
    auto pair = normalise_pair(48, 40);
    EXPECT_EQ(pair.length, 40);
    EXPECT_EQ(pair.frames_b, resample_indices(40, 40));
    ASSERT_EQ(pair.frames_a.size(), 40u);
    for (int m = 0; m < 40; ++m) EXPECT_EQ(pair.frames_a[std::size_t(m)], m * 48 / 40);
    EXPECT_EQ(pair.frames_a.back(), 46);
    EXPECT_THROW(resample_indices(0, 4), Error);
}

}  // namespace
}  // namespace amhv
