// The GPU voxeliser against the plain CPU reference, bit for bit, and both against geometry.
#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <random>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "src/body/shapes.hpp"
#include "src/io/mesh_sequence.hpp"
#include "src/voxelise/coverage_starts.hpp"
#include "src/core/error.hpp"
#include "src/voxelise/fixed_raster.hpp"
#include "src/voxelise/voxelise.hpp"
#include "src/voxelise/voxelise_vulkan.hpp"
#include "host/reference/voxelise_reference.hpp"
#include "support.hpp"

namespace amhv {
namespace {

MeshSequence sequence_of(std::vector<TriangleMesh> meshes) {
    MeshSequence sequence;
    for (std::size_t i = 0; i < meshes.size(); ++i) sequence.frames.push_back({std::move(meshes[i]), "frame " + std::to_string(i)});
    return sequence;
}

struct Both {
    Amhv reference, gpu;
    gpu::VulkanVoxeliser::Plan plan;
};

Both voxelise_both(const VoxelisationInput& input, std::uint64_t max_buffer_bytes = 0) {
    ReferenceVoxeliser reference;
    gpu::VulkanVoxeliser vulkan(test::context(), {.max_buffer_bytes = max_buffer_bytes});
    Both both{voxelise(input, reference), voxelise(input, vulkan), {}};
    both.plan = vulkan.last_plan();
    test::expect_no_validation_messages();
    return both;
}

void expect_identical(const Both& both) {
    ASSERT_EQ(both.reference.mask().size(), both.gpu.mask().size());
    std::size_t differing = 0, first = 0;
    for (std::size_t i = 0; i < both.reference.mask().size(); ++i)
        if (both.reference.mask()[i] != both.gpu.mask()[i] && differing++ == 0) first = i;
    EXPECT_EQ(differing, 0u) << "first differing word " << first;
}

std::size_t occupied(const Amhv& volume) { return summarise(volume).occupied_voxels; }

TEST(Voxelise, ShapesAreClosedAndOutward) {
    for (const auto& mesh : {shapes::sphere({0, 0, 0}, 1), shapes::capsule({0, 0, 0}, {1, 2, 3}, 0.5), shapes::box({0, 0, 0}, {1, 2, 3}),
                             shapes::torus({0, 0, 0}, 1, 0.25), shapes::capsule({1, 1, 1}, {1, 1, 1}, 0.3)}) {
        EXPECT_TRUE(mesh.is_closed());
        EXPECT_GT(shapes::signed_volume(mesh), 0);
    }
    EXPECT_NEAR(shapes::signed_volume(shapes::box({0, 0, 0}, {1, 2, 3})), 6.0, 1e-12);
}

// Closed means every edge is used as often in one direction as in the other: a missing face, a face
// turned over and a face twice the same way each leave some edge unbalanced; two closed surfaces
// sharing an edge stay closed.
TEST(Voxelise, ClosedMeansEveryEdgeIsUsedAsOftenBothWays) {
    const TriangleMesh tetrahedron{{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}}};
    ASSERT_TRUE(tetrahedron.is_closed());
    TriangleMesh missing = tetrahedron;
    missing.triangles.pop_back();
    EXPECT_FALSE(missing.is_closed());
    TriangleMesh flipped = tetrahedron;
    std::swap(flipped.triangles[3][0], flipped.triangles[3][1]);
    EXPECT_FALSE(flipped.is_closed());
    TriangleMesh doubled = tetrahedron;
    doubled.triangles.push_back(doubled.triangles[0]);
    EXPECT_FALSE(doubled.is_closed());
    TriangleMesh twice = tetrahedron;
    twice.triangles.push_back(twice.triangles[0]);
    twice.triangles.push_back({twice.triangles[0][0], twice.triangles[0][2], twice.triangles[0][1]});
    EXPECT_TRUE(twice.is_closed());  // a face and its reverse: a closed (flat) surface added
    // A second tetrahedron on vertices 0, 1, 4 and 5: edge 0-1 is used by four faces.
    TriangleMesh pair = tetrahedron;
    pair.vertices.push_back({0, -1, 0});
    pair.vertices.push_back({0, 0, -1});
    for (const auto& t : tetrahedron.triangles) {
        const auto to_second = [](std::uint32_t v) { return v < 2 ? v : v + 2; };
        pair.triangles.push_back({to_second(t[0]), to_second(t[1]), to_second(t[2])});
    }
    pair.triangles.push_back({0, 1, 4});  // a stray face on the shared edge: open
    EXPECT_FALSE(pair.is_closed());
    pair.triangles.pop_back();
    EXPECT_TRUE(pair.is_closed());
    EXPECT_TRUE(TriangleMesh{}.is_closed());
    TriangleMesh beyond = tetrahedron;
    beyond.triangles[0][0] = 9;  // a vertex the mesh lacks
    EXPECT_FALSE(beyond.is_closed());
}

// The Vulkan planner sizes every bucket and bounds the raster's work by each row's cross-section of
// a triangle. It must hold every column the exact test covers (else keys would overrun a bucket),
// also where an edge or vertex lies exactly on a column centre, and it should be tight.
TEST(Voxelise, CrossSectionsHoldEveryCoveredColumnAndLittleMore) {
    std::mt19937 random(7);
    const std::int32_t grid_extent = 1 << 17;  // the largest coordinates (2048 voxels of 64 units)
    std::uniform_int_distribution<std::int32_t> base(0, grid_extent - 64 * 48), offset(0, 64 * 40), small(0, 64 * 2);
    std::uniform_int_distribution<int> kind(0, 3);
    std::size_t covered = 0, spanned = 0, triangles = 0;
    for (int trial = 0; trial < 20000; ++trial) {
        const std::int32_t bx = base(random), by = base(random);
        fixed::Triangle t{};
        for (auto& v : t) {
            switch (kind(random)) {
                case 0: v = {bx + offset(random), by + offset(random), 0}; break;                         // anywhere
                case 1: v = {bx + offset(random) / 64 * 64 + 32, by + offset(random) / 64 * 64 + 32, 0}; break;  // on a centre
                case 2: v = {bx + small(random), by + offset(random), 0}; break;                          // a sliver
                default: v = {bx + offset(random), by + offset(random) / 64 * 64 + 32, 0}; break;         // on a row's centre line
            }
            v.z = offset(random);
        }
        if (trial % 5 == 0) t[1].y = t[0].y;  // a level edge
        fixed::Oriented oriented;
        if (!fixed::orient(t, oriented)) continue;
        ++triangles;
        const int y0 = oriented.columns_y.first, y1 = oriented.columns_y.last;
        if (y0 > y1) continue;
        fixed::CrossSections sections(t, y0);
        for (int y = y0; y <= y1; ++y) {
            const fixed::IndexRange span = sections.row(y - y0);
            for (int x = oriented.columns_x.first; x <= oriented.columns_x.last; ++x) {
                std::int64_t layer = 0;
                const bool crosses = fixed::column_crossing(oriented, x, y, layer);
                const bool in_span = x >= span.first && x <= span.last;
                covered += crosses ? 1 : 0;
                spanned += in_span ? 1 : 0;
                ASSERT_TRUE(!crosses || in_span) << "trial " << trial << ": column (" << x << ", " << y << ") is covered but outside the row's span ["
                                                 << span.first << ", " << span.last << "]";
            }
        }
    }
    EXPECT_GT(triangles, 15000u);
    EXPECT_GT(covered, 100000u);
    // Extra columns only where a centre lies on an edge (the top-left rule gives it to one side).
    EXPECT_LT(double(spanned), 1.05 * double(covered)) << spanned << " spanned, " << covered << " covered";
}

// The planner takes a small triangle's covered columns from a coverage mask: it must be exactly the
// columns the exact test covers, also for centres on edges and vertices and for level edges.
TEST(Voxelise, CoverageMasksAreExactlyTheCoveredColumns) {
    if (!fixed::coverage_masks_supported()) GTEST_SKIP() << "coverage masks need AVX2";
    std::mt19937 random(11);
    const std::int32_t grid_extent = 1 << 17;  // the largest coordinates (2048 voxels of 64 units)
    std::uniform_int_distribution<std::int32_t> base(0, grid_extent - 64 * 40);
    // Boxes up to 2 x 31, 4 x 8 and 8 x 4 columns: every row stride, up to all 32 lanes.
    const std::int32_t extents[3][2] = {{64 * 1, 64 * 30}, {64 * 3, 64 * 7}, {64 * 7, 64 * 3}};
    std::uniform_int_distribution<int> kind(0, 3);
    std::size_t masks = 0, beyond_16_lanes = 0, covered = 0;
    for (int trial = 0; trial < 60000; ++trial) {
        const std::int32_t bx = base(random), by = base(random);
        const std::int32_t* extent = extents[trial % 3];
        auto along_x = [&] { return std::uniform_int_distribution<std::int32_t>(0, extent[0])(random); };
        auto along_y = [&] { return std::uniform_int_distribution<std::int32_t>(0, extent[1])(random); };
        fixed::Triangle t{};
        for (auto& v : t) {
            switch (kind(random)) {
                case 0: v = {bx + along_x(), by + along_y(), 0}; break;                                      // anywhere
                case 1: v = {bx + along_x() / 64 * 64 + 32, by + along_y() / 64 * 64 + 32, 0}; break;        // on a centre
                case 2: v = {bx + along_x(), by + along_y() / 64 * 64 + 32, 0}; break;                       // on a row's centre line
                default: v = {bx + along_x() / 64 * 64 + 32, by + along_y(), 0}; break;                      // on a column's centre line
            }
        }
        if (trial % 5 == 0) t[1].y = t[0].y;  // a level edge
        if (trial % 7 == 0) t[1].x = t[0].x;  // a vertical one
        fixed::Oriented oriented;
        if (!fixed::orient(t, oriented)) continue;
        const int x0 = oriented.columns_x.first, x1 = oriented.columns_x.last, y0 = oriented.columns_y.first, y1 = oriented.columns_y.last;
        if (x0 > x1 || y0 > y1 || !fixed::fits_coverage_mask(x1 - x0 + 1, y1 - y0 + 1)) continue;
        ++masks;
        beyond_16_lanes += ((y1 - y0 + 1) << fixed::mask_stride_log2(x1 - x0 + 1)) > 16 ? 1 : 0;
        const std::uint32_t mask =
            fixed::coverage_mask(oriented.a.xy(), oriented.b.xy(), oriented.c.xy(), x0, y0, x1 - x0 + 1, y1 - y0 + 1);
        const int stride = fixed::mask_stride_log2(x1 - x0 + 1);
        for (int bit = 0; bit < 32; ++bit) {
            const int x = x0 + (bit & ((1 << stride) - 1)), y = y0 + (bit >> stride);
            std::int64_t layer = 0;
            const bool crosses = x <= x1 && y <= y1 && fixed::column_crossing(oriented, x, y, layer);
            covered += crosses ? 1 : 0;
            ASSERT_EQ(crosses, ((mask >> bit) & 1u) != 0) << "trial " << trial << ": column (" << x << ", " << y << ")";
        }
    }
    EXPECT_GT(masks, 25000u);
    EXPECT_GT(beyond_16_lanes, 2500u);
    EXPECT_GT(covered, 50000u) << masks << " masks, " << beyond_16_lanes << " beyond 16 lanes";
}

// The planner's first look at 8 triangles at a time must find what the scalar functions find one by
// one: box, kind and mask start, for triangles of every size, edge-on ones, ones partly or wholly
// outside the grid, and counts that leave a partial group of 8.
TEST(Voxelise, TriangleStartsMatchTheScalarPlanner) {
    if (!fixed::coverage_masks_supported()) GTEST_SKIP() << "the 8-lane planner needs AVX2";
    std::mt19937 random(23);
    const int nx = 300, ny = 200;  // columns; coordinates reach past the grid on every side
    std::uniform_int_distribution<std::int32_t> base_x(-64 * 20, 64 * (nx + 20)), base_y(-64 * 20, 64 * (ny + 20));
    std::uniform_int_distribution<std::int32_t> extent(0, 3), small(0, 64 * 3), large(0, 64 * 40);
    std::vector<fixed::Triangle> triangles;
    for (int i = 0; i < 20003; ++i) {
        const std::int32_t bx = base_x(random), by = base_y(random);
        auto offset = [&] { return extent(random) == 0 ? large(random) : small(random); };
        fixed::Triangle t{};
        for (auto& v : t) v = {bx + offset(), by + offset(), offset()};
        if (i % 7 == 0) t[1].y = t[0].y;                     // a level edge
        if (i % 11 == 0) t[2] = {t[0].x, t[0].y, t[2].z};     // edge-on from above
        if (i % 13 == 0) t[1].x = t[0].x;                     // a vertical edge
        if (i % 5 == 0) t[0] = {bx / 64 * 64 + 32, by / 64 * 64 + 32, 0};  // on a column centre
        triangles.push_back(t);
    }
    for (std::size_t count : {std::size_t(0), std::size_t(5), triangles.size()}) {
        fixed::TriangleStarts starts;
        fixed::find_starts(std::span(triangles).first(count), nx, ny, starts);
        std::size_t masked = 0, spanned = 0;
        for (std::size_t i = 0; i < count; ++i) {
            fixed::Oriented o{};
            const bool faces_up_or_down = fixed::orient(triangles[i], o);
            const int x0 = std::max(o.columns_x.first, 0), x1 = std::min(o.columns_x.last, nx - 1);
            const int y0 = std::max(o.columns_y.first, 0), y1 = std::min(o.columns_y.last, ny - 1);
            const bool valid = faces_up_or_down && x0 <= x1 && y0 <= y1;
            ASSERT_EQ(starts.kind[i] != fixed::TriangleStarts::kSkipped, valid) << "triangle " << i;
            if (!valid) continue;
            ASSERT_EQ(starts.x0[i], x0) << i;
            ASSERT_EQ(starts.x1[i], x1) << i;
            ASSERT_EQ(starts.y0[i], y0) << i;
            ASSERT_EQ(starts.y1[i], y1) << i;
            const bool fits = fixed::fits_coverage_mask(x1 - x0 + 1, y1 - y0 + 1);
            ASSERT_EQ(starts.kind[i], fits ? fixed::TriangleStarts::kMasked : fixed::TriangleStarts::kSpanned) << i;
            if (!fits) {
                ++spanned;
                continue;
            }
            ++masked;
            const fixed::MaskStart expected = fixed::mask_start(o.a.xy(), o.b.xy(), o.c.xy(), x0, y0), found = starts.start(i);
            for (int e = 0; e < 3; ++e) {
                ASSERT_EQ(found.corner[e], expected.corner[e]) << "triangle " << i << " edge " << e;
                ASSERT_EQ(found.per_row[e], expected.per_row[e]) << "triangle " << i << " edge " << e;
                ASSERT_EQ(found.per_column[e], expected.per_column[e]) << "triangle " << i << " edge " << e;
            }
        }
        if (count == triangles.size()) {
            EXPECT_GT(masked, 5000u);
            EXPECT_GT(spanned, 2000u);
        }
    }
}

TEST(Voxelise, SphereMatchesReferenceAndVolume) {
    const double r = 0.3, h = 0.01;
    auto mesh = shapes::sphere({0.1, -0.2, 1.0}, r, 48, 64);
    auto input = prepare_voxelisation(sequence_of({mesh}), h);
    auto both = voxelise_both(input);
    expect_identical(both);
    double expected = shapes::signed_volume(mesh) / (h * h * h);
    EXPECT_NEAR(double(occupied(both.gpu)), expected, 0.01 * expected);
}

TEST(Voxelise, BoxIsExact) {
    // Faces halfway between voxel centres: the count is exact.
    const double h = 0.01;
    auto mesh = shapes::box({0.0, 0.0, 0.0}, {0.40, 0.30, 0.20});
    auto both = voxelise_both(prepare_voxelisation(sequence_of({mesh}), h));
    expect_identical(both);
    EXPECT_EQ(occupied(both.gpu), 40u * 30u * 20u);
}

TEST(Voxelise, OverlappingCapsulesAreTheirUnion) {
    const double h = 0.005;
    TriangleMesh body = shapes::capsule({0, 0, 0}, {0.4, 0, 0}, 0.1, 12, 32);
    body.append(shapes::capsule({0.2, -0.2, 0}, {0.2, 0.2, 0.05}, 0.08, 12, 32));
    ASSERT_TRUE(body.is_closed());
    auto both = voxelise_both(prepare_voxelisation(sequence_of({body}), h));
    expect_identical(both);
    // The crossing point of the two capsules is inside (winding 2), not cancelled.
    auto grid = both.gpu.grid();
    Vec3 centre = (Vec3(0.2, 0, 0.0) - grid.origin) / h;
    EXPECT_TRUE(both.gpu.occupied(grid.index(int(centre.x()), int(centre.y()), int(centre.z())), 0));
    double single = shapes::signed_volume(shapes::capsule({0, 0, 0}, {0.4, 0, 0}, 0.1, 12, 32)) / (h * h * h);
    EXPECT_GT(double(occupied(both.gpu)), single * 1.3);
}

TEST(Voxelise, TorusHasAHole) {
    const double h = 0.01;
    auto mesh = shapes::torus({0, 0, 0.5}, 0.3, 0.1, 64, 32);
    auto both = voxelise_both(prepare_voxelisation(sequence_of({mesh}), h));
    expect_identical(both);
    auto grid = both.gpu.grid();
    Vec3 hole = (Vec3(0.0, 0.0, 0.5) - grid.origin) / h;
    EXPECT_FALSE(both.gpu.occupied(grid.index(int(hole.x()), int(hole.y()), int(hole.z())), 0));
    double expected = shapes::signed_volume(mesh) / (h * h * h);
    EXPECT_NEAR(double(occupied(both.gpu)), expected, 0.02 * expected);
}

// Star-shaped random closed meshes, moving and deforming over 40 frames, several overlapping.
TEST(Voxelise, RandomClosedMeshesMatchReference) {
    std::mt19937 rng(1234);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    std::vector<TriangleMesh> frames;
    for (int f = 0; f < 40; ++f) {
        TriangleMesh frame;
        for (int part = 0; part < 3; ++part) {
            auto blob = shapes::sphere(Vec3(0.3 * part + 0.01 * f, 0.05 * unit(rng), 0.5 + 0.1 * part), 0.15 + 0.05 * part, 12, 16);
            Vec3 centre = Vec3(0.3 * part + 0.01 * f, 0, 0.5 + 0.1 * part);
            for (auto& v : blob.vertices) v = centre + (v - centre) * (1.0 + 0.3 * unit(rng));
            frame.append(blob);
        }
        frames.push_back(frame);
    }
    const auto input = prepare_voxelisation(sequence_of(frames), 0.007);
    auto both = voxelise_both(input);
    expect_identical(both);
    EXPECT_GT(occupied(both.gpu), 10000u);
    // The planner without coverage masks (hosts without AVX2): cross-sections for every triangle.
    gpu::VulkanVoxeliser spans_only(test::context(), {.coverage_masks = false});
    expect_identical({both.reference, voxelise(input, spans_only), {}});
    test::expect_no_validation_messages();
}

// A file read through a reflecting axes map (`axes = "-x,y,z"`: winding flipped back) voxelises to
// the exact mirror image of the same file read as it is: voxel (gx, gy, gz) of one is voxel
// (-gx - 1, gy, gz) of the other, on both backends, at every frame.
TEST(Voxelise, ReflectedMeshVoxelisesToTheMirrorImage) {
    std::mt19937 rng(99);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    test::TempDir dir;
    MeshSequence plain, mirrored;
    UnitsAndAxes as_is, reflected;
    reflected.axes = parse_axes("-x,y,z", "test");
    for (int f = 0; f < 12; ++f) {
        TriangleMesh frame;
        for (int part = 0; part < 2; ++part) {
            const Vec3 centre(0.13 + 0.25 * part + 0.01 * f, 0.04 * unit(rng), 0.5 + 0.1 * part);
            auto blob = shapes::sphere(centre, 0.12 + 0.04 * part, 10, 14);
            for (auto& v : blob.vertices) v = centre + (v - centre) * (1.0 + 0.3 * unit(rng));
            frame.append(blob);
        }
        const auto file = dir.path() / fmt::format("{:02d}.obj", f);
        test::write_obj(file, frame);
        plain.frames.push_back({read_mesh(file, as_is), file.string()});
        mirrored.frames.push_back({read_mesh(file, reflected), file.string()});
    }
    const double h = 0.008;
    auto a = voxelise_both(prepare_voxelisation(plain, h));
    auto b = voxelise_both(prepare_voxelisation(mirrored, h));
    expect_identical(a);
    expect_identical(b);
    const VoxelGrid& ga = a.gpu.grid();
    const VoxelGrid& gb = b.gpu.grid();
    const auto oa = ga.lattice_origin(), ob = gb.lattice_origin();
    std::size_t differing = 0, occupied_voxels = 0;
    for (int z = 0; z < ga.dims[2]; ++z)
        for (int y = 0; y < ga.dims[1]; ++y)
            for (int x = 0; x < ga.dims[0]; ++x) {
                const std::int64_t mx = -(oa[0] + x) - 1 - ob[0], my = oa[1] + y - ob[1], mz = oa[2] + z - ob[2];
                const bool inside = mx >= 0 && my >= 0 && mz >= 0 && mx < gb.dims[0] && my < gb.dims[1] && mz < gb.dims[2];
                for (int w = 0; w < a.gpu.words(); ++w) {
                    const std::uint32_t word = a.gpu.word(w, ga.index(x, y, z));
                    const std::uint32_t mirror = inside ? b.gpu.word(w, gb.index(int(mx), int(my), int(mz))) : 0u;
                    differing += word != mirror;
                    occupied_voxels += word != 0;
                }
            }
    EXPECT_EQ(differing, 0u);
    EXPECT_GT(occupied_voxels, 5000u);
    EXPECT_EQ(summarise(a.gpu).occupied_voxels, summarise(b.gpu).occupied_voxels);
}


// scratch mask copied in (the path of discrete GPUs) must give the same bits. Both run here, with
// slabs split small so the in-place slabs start mid-page.
TEST(Voxelise, InPlaceAndCopiedMasksMatchReference) {
    std::vector<TriangleMesh> frames;
    for (int f = 0; f < 36; ++f) {
        TriangleMesh frame = shapes::capsule({0.1 + 0.01 * f, 0.2, 0.1}, {0.6, 0.5 - 0.005 * f, 0.9}, 0.12, 12, 16);
        frame.append(shapes::torus({0.4, 0.3 + 0.005 * f, 0.5}, 0.2, 0.06, 24, 12));
        frames.push_back(frame);
    }
    const auto input = prepare_voxelisation(sequence_of(frames), 0.006);
    const bool can_import = test::context().selected().shares_host_memory();
    ReferenceVoxeliser reference;
    const Amhv expected = voxelise(input, reference);
    for (bool in_place : {true, false})
        for (std::uint64_t budget : {std::uint64_t(0), std::uint64_t(1) << 20}) {
            gpu::VulkanVoxeliser vulkan(test::context(), {.max_buffer_bytes = budget, .write_in_place = in_place});
            const Both both{expected, voxelise(input, vulkan), vulkan.last_plan()};
            test::expect_no_validation_messages();
            EXPECT_EQ(both.plan.writes_in_place, in_place && can_import);
            if (budget) {
                EXPECT_GT(both.plan.slabs, 2);
            }
            expect_identical(both);
        }
    EXPECT_GT(occupied(expected), 10000u);
}

// A column window: the volume of its columns alone, their voxels those of the whole volume, on both
// backends. Frames with small triangles (coverage masks), a box whose faces make rows of runs, one
// open frame (the surface rule), 40 frames (two words); windows inside, on the grid's edges, one
// column wide, empty; a small buffer budget (slabs and batches) too.
TEST(Voxelise, ColumnWindowIsTheWholeVolumeCropped) {
    std::vector<TriangleMesh> meshes;
    for (int f = 0; f < 40; ++f) {
        TriangleMesh frame = shapes::box({0.0, 0.0, 0.0}, {0.9, 0.7, 0.05 + 0.002 * f});
        frame.append(shapes::sphere({0.3 + 0.01 * f, 0.35, 0.3}, 0.15, 16, 24));
        frame.append(shapes::torus({0.6, 0.3 + 0.005 * f, 0.4}, 0.2, 0.06, 24, 12));
        meshes.push_back(frame);
    }
    meshes[7].triangles.resize(meshes[7].triangles.size() - 5);  // open: the surface rule
    VoxelisationInput input = prepare_voxelisation(sequence_of(meshes), 0.005);
    ASSERT_FALSE(input.frames[7].closed);
    ReferenceVoxeliser reference;
    const Amhv whole = voxelise(input, reference);
    const auto& dims = input.grid.dims;
    for (const ColumnWindow window : {ColumnWindow{40, 30, 121, 97}, ColumnWindow{0, 0, 75, dims[1] - 1},
                                      ColumnWindow{90, 50, dims[0] - 1, dims[1] - 1}, ColumnWindow{61, 70, 61, 70}, ColumnWindow{}}) {
        const std::string what = fmt::format("window {}..{} x {}..{}", window.x0, window.x1, window.y0, window.y1);
        input.window = window;
        for (std::uint64_t budget : {std::uint64_t(0), std::uint64_t(2) << 20}) {
            const Both both = voxelise_both(input, budget);
            expect_identical(both);
        }
        const Amhv cropped = voxelise(input, reference);
        const VoxelGrid& grid = cropped.grid();
        if (window.x0 > window.x1) {
            EXPECT_EQ(grid.voxel_count(), 0u) << what;
            continue;
        }
        ASSERT_EQ(grid.dims, (std::array<int, 3>{window.x1 - window.x0 + 1, window.y1 - window.y0 + 1, dims[2]})) << what;
        const auto lattice = input.grid.lattice_origin();
        EXPECT_EQ(grid.lattice_origin(), (std::array<std::int64_t, 3>{lattice[0] + window.x0, lattice[1] + window.y0, lattice[2]})) << what;
        std::size_t differing = 0, occupied_inside = 0;
        for (int w = 0; w < whole.words(); ++w)
            for (int z = 0; z < grid.dims[2]; ++z)
                for (int y = 0; y < grid.dims[1]; ++y)
                    for (int x = 0; x < grid.dims[0]; ++x) {
                        const std::uint32_t expected = whole.word(w, input.grid.index(x + window.x0, y + window.y0, z));
                        differing += cropped.word(w, grid.index(x, y, z)) != expected;
                        occupied_inside += std::size_t(std::popcount(expected));
                    }
        EXPECT_EQ(differing, 0u) << what;
        EXPECT_GT(occupied_inside, 0u) << what;
    }
}

// Frames stacked (prepare_voxelisation_stacked): each on its own grid, laid at one corner. The
// frames lie metres apart, and 40 of them take two occupancy words; a small buffer budget splits
// the grid into slabs. Each frame's bits are its voxels on its own grid alone, on both backends.
TEST(Voxelise, StackedFramesAreEachFramesOwnVoxels) {
    std::vector<MeshFrame> frames;
    std::vector<VoxelGrid> grids;
    for (int f = 0; f < 40; ++f) {
        const Vec3 at(0.37 * f, -0.21 * f, 0.05 * (f % 3));
        TriangleMesh mesh = shapes::capsule(at + Vec3(0.1, 0.2, 0.1), at + Vec3(0.6, 0.5 - 0.005 * f, 0.9), 0.12, 12, 16);
        mesh.append(shapes::sphere(at + Vec3(0.5, 0.2 + 0.01 * f, 0.4), 0.2 + 0.002 * f, 16, 24));
        grids.push_back(grid_covering(mesh.bounds(), 0.006, "frame"));
        frames.push_back({std::move(mesh), fmt::format("frame {}", f)});
    }
    std::vector<const MeshFrame*> pointers;
    for (const MeshFrame& frame : frames) pointers.push_back(&frame);
    const VoxelisationInput input = prepare_voxelisation_stacked(pointers, grids);
    for (std::size_t axis = 0; axis < 3; ++axis) {
        int largest = 0;
        for (const VoxelGrid& grid : grids) largest = std::max(largest, grid.dims[axis]);
        EXPECT_EQ(input.grid.dims[axis], largest);
    }
    for (std::uint64_t budget : {std::uint64_t(0), std::uint64_t(1) << 20}) {
        const Both both = voxelise_both(input, budget);
        expect_identical(both);
        if (budget) {
            EXPECT_GT(both.plan.slabs, 2);
        }
    }
    ReferenceVoxeliser reference;
    const Amhv stacked = voxelise(input, reference);
    for (int f : {0, 17, 31, 32, 39}) {
        const Amhv alone = voxelise(prepare_voxelisation({pointers[std::size_t(f)]}, grids[std::size_t(f)]), reference);
        const VoxelGrid& own = grids[std::size_t(f)];
        std::size_t differing = 0, occupied_alone = 0;
        for (int z = 0; z < input.grid.dims[2]; ++z)
            for (int y = 0; y < input.grid.dims[1]; ++y)
                for (int x = 0; x < input.grid.dims[0]; ++x) {
                    const bool inside = x < own.dims[0] && y < own.dims[1] && z < own.dims[2];
                    const bool expected = inside && alone.word(0, own.index(x, y, z)) & 1u;
                    const bool got = stacked.word(f / 32, input.grid.index(x, y, z)) >> (f % 32) & 1u;
                    differing += expected != got;
                    occupied_alone += expected;
                }
        EXPECT_EQ(differing, 0u) << "frame " << f;
        EXPECT_GT(occupied_alone, 1000u) << "frame " << f;
    }
}

// Shapes that force every split: a tiny buffer budget makes many z slabs and several batches per
// occupancy word; a 1.6 m box at 5 mm covers 320 x 320 = 102,400 columns with each of its faces
// (more than one invocation may loop over on lavapipe); 40 frames need two occupancy words.
TEST(Voxelise, SplittingAndLargeTrianglesMatchReference) {
    std::vector<TriangleMesh> frames;
    for (int f = 0; f < 40; ++f) {
        TriangleMesh frame = shapes::box({0.0, 0.0, 0.0}, {1.6, 1.6, 0.05 + 0.002 * f});
        frame.append(shapes::sphere({0.8 + 0.01 * f, 0.8, 0.15}, 0.1, 16, 24));
        frames.push_back(frame);
    }
    auto input = prepare_voxelisation(sequence_of(frames), 0.005);
    auto both = voxelise_both(input, 2u << 20);
    EXPECT_GT(both.plan.slabs, 4);
    EXPECT_LT(both.plan.frames_per_batch, 32);
    expect_identical(both);
    // Frame f's box is 0.05 m + 2 mm per frame high: count the layers of one column away from the sphere.
    auto grid = both.gpu.grid();
    int cx = int((0.2 - grid.origin.x()) / 0.005), cy = int((0.2 - grid.origin.y()) / 0.005);
    for (int f : {0, 20, 39}) {
        int layers = 0;
        for (int z = 0; z < grid.dims[2]; ++z) layers += both.gpu.occupied(grid.index(cx, cy, z), f);
        EXPECT_NEAR(layers, (0.05 + 0.002 * f) / 0.005, 1.0) << "frame " << f;
    }
}

// Triangles a thousand voxels across: their edge values pass 2^30, where the raster's 32-bit
// coverage test clamps them. A thin slab turned about z and tilted, so no edge is axis-aligned.
TEST(Voxelise, HugeTrianglesMatchReference) {
    std::vector<TriangleMesh> frames;
    for (double turn : {0.5, 1.1}) {
        TriangleMesh slab = shapes::box({0.0, 0.0, 0.0}, {3.0, 3.0, 0.03});
        const double c = std::cos(turn), s = std::sin(turn), tilt = 0.02;
        for (Vec3& v : slab.vertices) {
            Vec3 turned(c * v.x() - s * v.y(), s * v.x() + c * v.y(), v.z());
            v = Vec3(turned.x(), std::cos(tilt) * turned.y() - std::sin(tilt) * turned.z(),
                     std::sin(tilt) * turned.y() + std::cos(tilt) * turned.z());
        }
        frames.push_back(slab);
    }
    auto input = prepare_voxelisation(sequence_of(frames), 0.004);
    ASSERT_GT(input.grid.dims[0], 900);
    auto both = voxelise_both(input);
    expect_identical(both);
    const double expected = 3.0 * 3.0 * 0.03 / (0.004 * 0.004 * 0.004);
    for (std::size_t count : summarise(both.gpu).occupied_per_frame) EXPECT_NEAR(double(count), expected, 0.05 * expected);
}

// The voxeliser keeps its scratch buffers between calls. Calls on a large grid, a small one (the
// buffers are larger than it needs, and hold the large call's leftovers) and the large one again
// must each match the reference, as must a call with a different slab height.
TEST(Voxelise, ReusedVoxeliserMatchesReferenceOnEveryCall) {
    std::vector<TriangleMesh> large, small;
    for (int f = 0; f < 36; ++f) {
        TriangleMesh frame = shapes::capsule({0.1 + 0.01 * f, 0.2, 0.1}, {0.6, 0.5 - 0.005 * f, 0.9}, 0.12, 12, 16);
        frame.append(shapes::sphere({0.5, 0.2 + 0.01 * f, 0.4}, 0.2, 16, 24));
        large.push_back(frame);
        if (f < 7) small.push_back(shapes::sphere({0.1 * f, 0.0, 0.2}, 0.08 + 0.01 * f, 12, 16));
    }
    const auto large_input = prepare_voxelisation(sequence_of(large), 0.006);
    const auto small_input = prepare_voxelisation(sequence_of(small), 0.004);
    // The same frames backwards: the same grid, other flips in every batch. Each batch clears only
    // the flips of its own columns with room, whatever the calls before left in the others.
    const auto reversed_input = prepare_voxelisation(sequence_of({large.rbegin(), large.rend()}), 0.006);
    ASSERT_EQ(reversed_input.grid.dims, large_input.grid.dims);
    ReferenceVoxeliser reference;
    gpu::VulkanVoxeliser vulkan(test::context());
    for (const auto* input : {&large_input, &reversed_input, &small_input, &small_input, &large_input, &large_input, &reversed_input}) {
        const Both both{voxelise(*input, reference), voxelise(*input, vulkan), vulkan.last_plan()};
        test::expect_no_validation_messages();
        expect_identical(both);
        EXPECT_GT(occupied(both.gpu), 1000u);
    }
}

// A ScratchHold keeps the voxeliser's buffers between calls whatever their size (a series of
// calls then allocates once: on a discrete GPU every allocation is a driver call that clears its
// pages); without one, or once the last hold ends, buffers beyond the kept limit go back. The
// volumes are the reference's either way.
TEST(Voxelise, ScratchHoldKeepsBuffersUntilTheLastHoldEnds) {
    std::vector<TriangleMesh> large, small;
    for (int f = 0; f < 20; ++f) {
        large.push_back(shapes::capsule({0.1 + 0.01 * f, 0.2, 0.1}, {0.6, 0.5 - 0.005 * f, 0.9}, 0.12, 12, 16));
        if (f < 5) small.push_back(shapes::sphere({0.05 * f, 0.0, 0.2}, 0.08 + 0.01 * f, 12, 16));
    }
    const auto large_input = prepare_voxelisation(sequence_of(large), 0.006);
    const auto small_input = prepare_voxelisation(sequence_of(small), 0.006);
    ReferenceVoxeliser reference;
    const Amhv large_expected = voxelise(large_input, reference), small_expected = voxelise(small_input, reference);
    gpu::VulkanVoxeliser vulkan(test::context(), {.kept_bytes = 1});  // nothing is kept without a hold
    const auto matches = [&](const VoxelisationInput& input, const Amhv& expected) {
        expect_identical({expected, voxelise(input, vulkan), {}});
        test::expect_no_validation_messages();
    };
    matches(large_input, large_expected);
    EXPECT_EQ(vulkan.scratch_bytes(), 0u);
    std::uint64_t kept = 0;
    {
        const Voxeliser::ScratchHold outer(vulkan);
        {
            const Voxeliser::ScratchHold inner(vulkan);
            matches(large_input, large_expected);
            kept = vulkan.scratch_bytes();
            EXPECT_GT(kept, 0u);
        }
        // The outer hold still keeps them, and the smaller grid fits them: nothing is allocated.
        EXPECT_EQ(vulkan.scratch_bytes(), kept);
        matches(small_input, small_expected);
        EXPECT_EQ(vulkan.scratch_bytes(), kept);
        matches(large_input, large_expected);
        EXPECT_EQ(vulkan.scratch_bytes(), kept);
    }
    EXPECT_EQ(vulkan.scratch_bytes(), 0u);
    matches(small_input, small_expected);
    EXPECT_EQ(vulkan.scratch_bytes(), 0u);
}

// Stacked slabs cross their shared columns twice each per frame. Ten slabs (20 crossings) put
// every bucket beyond the register sort of 8 keys into the bitonic one of 32; twenty slabs (40)
// beyond that into the sort in the key list (heap sort past 12 keys). Half of the columns of
// each stack hold half as many slabs (10 and 20 crossings: the bitonic sorts of 16 and 32 keys),
// so two kinds of bucket meet in one batch. The triangles
// are shuffled, so the crossings reach their buckets in every order the sorts must handle. 40
// frames fill a whole word and spill into a second one; the slabs thicken frame by frame so no
// two frames agree.
TEST(Voxelise, ManyCrossingsPerColumnSortAndMatchReference) {
    std::mt19937 rng(99);
    for (int slabs : {10, 20}) {
        std::vector<TriangleMesh> frames;
        for (int f = 0; f < 40; ++f) {
            TriangleMesh stack;
            for (int k = 0; k < slabs; ++k)
                stack.append(shapes::box({0.0, 0.0, 0.06 * k}, {k % 2 ? 0.15 : 0.3, 0.25, 0.06 * k + 0.02 + 0.0005 * f}));
            std::shuffle(stack.triangles.begin(), stack.triangles.end(), rng);
            frames.push_back(stack);
        }
        auto both = voxelise_both(prepare_voxelisation(sequence_of(frames), 0.005));
        expect_identical(both);
        // Twenty slabs over a whole word's 32 frames cross a column 1280 times, more than the 1024
        // the column pass takes: that word is redone in two halves.
        EXPECT_EQ(both.plan.overflow_retries, slabs == 20 ? 1 : 0);
        // A column crossing every slab: each 4 layers thick in frame 0.
        auto grid = both.gpu.grid();
        int cx = int((0.07 - grid.origin.x()) / 0.005), cy = int((0.12 - grid.origin.y()) / 0.005), layers = 0;
        for (int z = 0; z < grid.dims[2]; ++z) layers += both.gpu.occupied(grid.index(cx, cy, z), 0);
        EXPECT_EQ(layers, 4 * slabs) << slabs << " slabs";
    }
}

// A batch whose column has more crossings than the column kernel sorts is redone with fewer
// frames; a single frame with too many is an error that names it, never a silently wrong volume.
// Frame 0 (one box) crosses a column twice, frame 1 (two stacked boxes) four times: a limit of 4
// splits the two-frame batch and matches the reference, a limit of 3 must refuse frame 1. The
// refusal leaves the skipped column's flips behind: the voxeliser's next call must not see them
// (each batch clears the flips of its columns with room before its kernels run).
TEST(Voxelise, TooManyCrossingsPerColumnIsAnErrorNamingTheFrame) {
    TriangleMesh stacked = shapes::box({0.0, 0.0, 0.0}, {0.2, 0.2, 0.1});
    stacked.append(shapes::box({0.0, 0.0, 0.2}, {0.2, 0.2, 0.3}));
    auto input = prepare_voxelisation(sequence_of({shapes::box({0.0, 0.0, 0.0}, {0.2, 0.2, 0.1}), stacked}), 0.01);
    gpu::VulkanVoxeliser strict(test::context(), {.max_column_crossings = 3});
    try {
        voxelise(input, strict);
        ADD_FAILURE() << "expected an error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("frame 1: a voxel column crosses the surface 4 times, more than the 3"), std::string::npos)
            << e.what();
    }
    ReferenceVoxeliser reference;
    {
        auto single = prepare_voxelisation(sequence_of({shapes::box({0.0, 0.0, 0.0}, {0.2, 0.2, 0.1})}), 0.01);
        Both after_error{voxelise(single, reference), voxelise(single, strict), strict.last_plan()};
        expect_identical(after_error);
        EXPECT_GT(occupied(after_error.gpu), 100u);
    }
    gpu::VulkanVoxeliser enough(test::context(), {.max_column_crossings = 4});
    Both both{voxelise(input, reference), voxelise(input, enough), {}};
    both.plan = enough.last_plan();
    EXPECT_EQ(both.plan.overflow_retries, 1);
    expect_identical(both);
    test::expect_no_validation_messages();
}

}  // namespace
}  // namespace amhv
