#include "gpu/sweep_vulkan.hpp"

#include <algorithm>
#include <exception>
#include <chrono>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <optional>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "sweep/column_volume.hpp"
#include "sweep/slice_runs.hpp"
#include "sweep_map.spv.h"
#include "sweep_overlap.spv.h"

namespace amhv::gpu {

namespace {

struct OverlapParams {
    std::uint32_t item_base, item_count;
    std::int32_t static_x0, static_y0, static_nx, static_ny;
    std::int32_t moving_x0, moving_y0, moving_nx, moving_ny;
    std::int32_t slots, zwords, frames, mode;
    std::int32_t columns_per_item, rows_per_item, items_x;
    std::int32_t chunk_first, chunks_in_wave;
    std::int32_t range_i0, range_j0, range_ni, range_nj;
    std::int32_t angle_first, explicit_poses, flag_words, flag_offset;
    std::int32_t word_first, word_last;
    std::int32_t frames_per_item, spatial_items;
};
static_assert(sizeof(OverlapParams) <= 128, "push constants beyond the guaranteed 128 bytes");

struct MapParams {
    std::uint32_t item_base, item_count;
    std::int32_t chunks, runs_per_chunk;
    std::int32_t zbits, slot_count;
    std::int32_t range_i0, range_j0, range_ni, range_nj, row_words;
    std::int32_t map_per_slot;
    std::int32_t fixed_x0, fixed_y0, pulled_x0;
};
static_assert(sizeof(MapParams) <= 128, "push constants beyond the guaranteed 128 bytes");

// A pulled run as the map kernel reads it: x packed relative to the batch's pulled_x0, and the
// rows j (first | last << 16) it is paired on.
struct PulledRun {
    std::int32_t y;
    std::uint32_t x;
    std::int32_t key;
    std::uint32_t rows;
};
static_assert(sizeof(PulledRun) == 16);

struct GpuAngle {
    std::int64_t trig[2];
    std::int32_t bounds[4];
};
static_assert(sizeof(GpuAngle) == 32);

constexpr std::int32_t kModeAny = 0, kModePerFrame = 1;

// A column volume; uploaded when a pose-by-pose test first reads it (overlap maps read slice runs
// instead), and its angle table (used when it is the moving side) on demand.
struct GpuVolume {
    ColumnVolume columns;
    std::unique_ptr<Buffer> bits, rows, angles;
    std::unique_ptr<Buffer> frame_boxes, angle_frame_boxes;  // PER_FRAME tests only
};

enum class Want { Overlap, NoOverlap, EveryFrame };

struct OverlapTest {
    GpuVolume* fixed;   // A's side: its columns are visited
    GpuVolume* moving;  // B's side: pulled under A's columns
    int frames;         // 0: unions only
    Want want;
    std::int32_t mode() const { return want == Want::EveryFrame ? kModePerFrame : kModeAny; }
    // The z words where both volumes have bits (first > last: the test cannot find an overlap).
    int word_first() const { return std::max(fixed->columns.word_first, moving->columns.word_first); }
    int word_last() const { return std::min(fixed->columns.word_last, moving->columns.word_last); }
    int words() const { return std::max(0, word_last() - word_first() + 1); }
    int flag_words() const { return want == Want::EveryFrame ? (frames + 31) / 32 : 1; }
};

// One overlap test decided for every offset of an angle at once (shaders/sweep_map.comp). Slot s
// of the fixed volume pairs with slot s of the moving one: slot 0 for unions, 1..frames for frames.
struct MapTest {
    const ColumnVolume* fixed;
    const ColumnVolume* moving;
    std::vector<int> slots;
    Want want;  // Overlap: in some slot pair; NoOverlap: in none; EveryFrame: in every one
    FixedRuns runs;
    SparseColumns moving_words;  // the moving volume's slots, as the host cuts them into pulled runs
    std::int32_t pulled_x0 = 0;  // the first column pulled runs can start at (their packed x is relative to it)
    std::unique_ptr<Buffer> fixed_runs, fixed_keys;
    int maps_per_angle() const { return want == Want::EveryFrame ? int(slots.size()) : 1; }
};

// The overlap-map pass of z slice `z` out of `passes`: coarse to fine, slices whose index has
// more trailing zeros go first. With 5 passes: every 16th slice, then the slices halfway between
// them (as many again), then an eighth, a quarter and the remaining half of all slices. Each pass
// spans the whole height, so early passes find most overlaps with few pairs.
int pass_of(int z, int passes) {
    const int last = passes - 1;
    for (int p = 0; p < last; ++p)
        if (z % (1 << (last - p)) == 0) return p;
    return last;
}

struct Blocks {
    int columns, rows, items_x, items_per_pose;
    int frames_per_item = 0, spatial_items = 1;
};

}  // namespace

VulkanSweeper::VulkanSweeper(Context& context, SweeperOptions options)
    : context_(context),
      options_(options),
      overlap_(context, sweep_overlap_spv, 8, sizeof(OverlapParams), {kWorkgroup, std::uint32_t(kMaxFrameWords)}),
      map_(context, sweep_map_spv, 4, sizeof(MapParams), {kWorkgroup}) {}

std::string VulkanSweeper::name() const { return "vulkan:" + context_.selected().name; }

SweepResult VulkanSweeper::sweep(const SweepProblem& problem) {
    validate(problem);
    stats_ = {};
    const SweepObject& A = problem.a;
    const SweepObject& B = problem.b;
    const int frames = problem.frames();
    const int last = frames - 1;
    const InteractionType type = problem.type;
    if (frames > kMaxFrameWords * 32) fail("key segment", "has {} normalised frames; the sweep handles at most {}", frames, kMaxFrameWords * 32);

    // ---- column volumes ----
    std::vector<const VoxelGrid*> grids{&A.whole.grid(), &B.whole.grid()};
    if (problem.visibility) grids.insert(grids.end(), {&A.view_cone.grid, &B.view_cone.grid});
    const ZFrame z = z_frame_covering(grids);
    std::vector<std::unique_ptr<GpuVolume>> volumes;
    auto add = [&](ColumnVolume columns) {
        auto v = std::make_unique<GpuVolume>();
        v->columns = std::move(columns);
        volumes.push_back(std::move(v));
        return volumes.back().get();
    };
    const bool frames_of_interest = type.lateral_pair() && (type.variant == 'a' || type.variant == 'b');
    GpuVolume* interest_a = add(columns_of(A.interest, z, frames_of_interest));
    GpuVolume* interest_b = add(columns_of(B.interest, z, frames_of_interest));

    std::vector<std::vector<OverlapTest>> stages(4);
    stages[0].push_back({interest_a, interest_b, 0, Want::Overlap});
    // Dictionary: a '+' ('-') label fails when a contact voxel of that object is off its end
    // (start) surface, i.e. when that object's off-surface voxels meet the other's volume.
    auto off_surface = [&](const Amhv& volume, SurfaceLabel label) {
        return add(columns_where(volume, z, [&, label](std::size_t v) {
            return label == SurfaceLabel::Plus ? volume.t_end(v) < last - problem.tolerance : volume.t_start(v) > problem.tolerance;
        }));
    };
    if (!type.lateral_pair()) {
        if (type.a != SurfaceLabel::Lateral) stages[1].push_back({off_surface(A.interest, type.a), interest_b, 0, Want::NoOverlap});
        if (type.b != SurfaceLabel::Lateral) stages[1].push_back({interest_a, off_surface(B.interest, type.b), 0, Want::NoOverlap});
    } else if (type.variant == 'a') {
        stages[1].push_back({interest_a, interest_b, frames, Want::EveryFrame});
    } else if (type.variant == 'b') {
        stages[1].push_back({interest_a, interest_b, frames, Want::Overlap});
    } else {
        // (c) fails when some contact voxel has t_start^A <= t_end^B, i.e. when for some t the
        // voxels A has reached by t meet the voxels B still occupies at or after t.
        stages[1].push_back({add(columns_cumulative(A.interest, z, true)), add(columns_cumulative(B.interest, z, false)), frames,
                             Want::NoOverlap});
    }
    stages[2].push_back({add(columns_of(A.fidelity, z, true)), add(columns_of(B.fidelity, z, true)), frames, Want::NoOverlap});
    if (problem.visibility) {
        stages[3].push_back({add(columns_of(A.view_cone, z)), add(columns_of(B.whole, z, false)), 0, Want::Overlap});
        stages[3].push_back({add(columns_of(A.whole, z, false)), add(columns_of(B.view_cone, z)), 0, Want::Overlap});
    }

    // Overlap maps (SweeperOptions::maps): tests decided for every offset of an angle at once from
    // slice runs. `required_maps` replace the stage's pose tests: contact, and the dictionary's
    // lateral types and surface test. `optional_maps` are the stage's pose tests as maps; a batch
    // uses them when its poses in that stage would cost more pose by pose (the cost model).
    std::vector<std::vector<MapTest>> required_maps(4), optional_maps(4);
    if (options_.maps) {
        std::vector<int> every_frame(static_cast<std::size_t>(frames));
        for (int t = 0; t < frames; ++t) every_frame[std::size_t(t)] = 1 + t;
        auto map_test = [](const ColumnVolume& fixed, const ColumnVolume& moving, std::vector<int> slots, Want want) {
            return MapTest{&fixed, &moving, std::move(slots), want, {}, {}, 0, nullptr, nullptr};
        };
        auto map_of = [&](const OverlapTest& test) {
            std::vector<int> slots{0};
            if (test.frames > 0) slots = every_frame;
            return map_test(test.fixed->columns, test.moving->columns, slots, test.want);
        };
        required_maps[0].push_back(map_of(stages[0].front()));
        if (!type.lateral_pair()) {
            // A pose in contact passes a labelled type only if the labelled surfaces (for a '0', the
            // whole part) meet, since all its contact voxels lie on them. The surfaces are small, so
            // this necessary test is cheap and leaves few poses for the exact ones.
            auto on_surface = [&](const Amhv& volume, SurfaceLabel label, GpuVolume* whole) -> const ColumnVolume& {
                if (label == SurfaceLabel::Lateral) return whole->columns;
                return add(columns_where(volume, z, [&, label](std::size_t v) {
                           return label == SurfaceLabel::Plus ? volume.t_end(v) >= last - problem.tolerance : volume.t_start(v) <= problem.tolerance;
                       }))->columns;
            };
            required_maps[1].push_back(
                map_test(on_surface(A.interest, type.a, interest_a), on_surface(B.interest, type.b, interest_b), {0}, Want::Overlap));
            for (const OverlapTest& test : stages[1]) optional_maps[1].push_back(map_of(test));
        } else if (type.variant == 'a' || type.variant == 'b') {
            required_maps[1].push_back(map_of(stages[1].front()));
        } else {
            // (c): the voxels A has reached by t meet those B still occupies at or after t for some t
            // exactly when they meet those B occupies at t itself for some t (take t = t_end^B of the
            // shared voxel); single frames of B give far fewer runs.
            required_maps[1].push_back(map_test(stages[1].front().fixed->columns, add(columns_of(B.interest, z, true))->columns, every_frame,
                                                Want::NoOverlap));
        }
        for (int stage = 2; stage < 4; ++stage)
            for (const OverlapTest& test : stages[std::size_t(stage)]) optional_maps[std::size_t(stage)].push_back(map_of(test));
        for (auto* all : {&required_maps, &optional_maps})
            for (auto& stage : *all)
                for (MapTest& test : stage) {
                    test.runs = fixed_runs(*test.fixed, test.slots);
                    test.moving_words = sparse_columns(*test.moving, test.slots);
                    // Packed (y, x_first | x_last << 16) relative to the volume's origin.
                    if (test.fixed->nx > 0xffff || test.fixed->ny > 0xffff)
                        fail("key segment", "a volume {} x {} columns wide is more than the sweep handles (65,535); use a larger voxel",
                             test.fixed->nx, test.fixed->ny);
                    // Pulled runs are cut to pulled_clip, which starts here for every angle and row.
                    test.pulled_x0 = std::int32_t(test.fixed->x0) + test.fixed->x_first - problem.range.i_last;
                    std::vector<std::array<std::uint32_t, 2>> packed;
                    packed.reserve(test.runs.runs.size());
                    for (const SliceRun& run : test.runs.runs)
                        packed.push_back({std::uint32_t(run.y - test.fixed->y0),
                                          std::uint32_t(run.x_first - test.fixed->x0) | std::uint32_t(run.x_last - test.fixed->x0) << 16});
                    test.fixed_runs = upload_to_host(context_, packed.data(), packed.size() * 8);
                    test.fixed_keys = upload_to_host(context_, test.runs.by_key.data(), test.runs.by_key.size() * 8);
                }
    }

    auto for_each_test = [&](const auto& visit) {
        for (const auto& stage : stages)
            for (const OverlapTest& test : stage) visit(test);
    };

    // ---- per moving volume: every angle's rotation and mapped bounds ----
    const PoseRange& range = problem.range;
    const auto root_a = problem.root_a_q(), root_b = problem.root_b_q();
    std::vector<posemap::Trig> trig(std::size_t(range.angles));
    for (int k = 0; k < range.angles; ++k) trig[std::size_t(k)] = problem.trig(k);
    for_each_test([&](const OverlapTest& test) {
            if (test.fixed->columns.slots != test.moving->columns.slots) fail("sweep", "internal: slot counts differ in one test");
            if (test.moving->angles) return;
            std::vector<std::uint8_t> table(32 + std::size_t(range.angles) * sizeof(GpuAngle));
            std::int64_t roots[4] = {root_a[0], root_a[1], root_b[0], root_b[1]};
            std::memcpy(table.data(), roots, sizeof(roots));
            for (int k = 0; k < range.angles; ++k) {
                GpuAngle angle{{trig[std::size_t(k)].cos_q, trig[std::size_t(k)].sin_q}, {}};
                auto bounds = mapped_bounds(test.moving->columns, trig[std::size_t(k)], root_a, root_b);
                std::copy(bounds.begin(), bounds.end(), angle.bounds);
                std::memcpy(table.data() + 32 + std::size_t(k) * sizeof(GpuAngle), &angle, sizeof(angle));
            }
            test.moving->angles = upload_to_host(context_, table.data(), table.size());
        });
    for_each_test([&](const OverlapTest& test) {
            if (test.want != Want::EveryFrame) return;
            if (!test.fixed->frame_boxes) {
                const auto& boxes = test.fixed->columns.slot_boxes;
                test.fixed->frame_boxes = upload_to_host(context_, boxes.data() + 1, (boxes.size() - 1) * 16);
            }
            if (!test.moving->angle_frame_boxes) {
                const ColumnVolume& m = test.moving->columns;
                std::vector<std::array<std::int32_t, 4>> boxes;
                for (int k = 0; k < range.angles; ++k)
                    for (int t = 0; t < m.frames(); ++t)
                        boxes.push_back(mapped_bounds(m, m.slot_boxes[std::size_t(1 + t)], trig[std::size_t(k)], root_a, root_b));
                test.moving->angle_frame_boxes = upload_to_host(context_, boxes.data(), boxes.size() * 16);
            }
        });

    // Work blocks per test: loop iterations per item stay under the budget. `grow`: columns the
    // fixed volume will gain on each side in x and y (its pooled form, before it exists).
    auto blocks_of = [&](const OverlapTest& test, int grow = 0) {
        const int nx = test.fixed->columns.nx + grow, ny = test.fixed->columns.ny + grow;
        // PER_FRAME items loop frames outside and columns inside: size the spatial block for one
        // frame, then give the item as many frames as fit.
        const bool per_frame = test.want == Want::EveryFrame;
        const std::uint64_t per_column = per_frame ? std::uint64_t(test.words()) + 2 : std::uint64_t(test.words()) * (1 + test.frames) + 2;
        if (per_column > options_.loop_budget)
            fail("key segment", "one column test needs {} loop iterations, more than the {} one invocation may run; use a larger voxel "
                 "or a shorter segment", per_column, options_.loop_budget);
        Blocks b;
        b.columns = int(std::min<std::uint64_t>(std::uint64_t(std::max(nx, 1)), options_.loop_budget / per_column));
        b.rows = int(std::clamp<std::uint64_t>(options_.loop_budget / (per_column * std::uint64_t(b.columns)), 1, std::uint64_t(std::max(ny, 1))));
        b.items_x = (std::max(nx, 1) + b.columns - 1) / b.columns;
        b.items_per_pose = b.items_x * ((std::max(ny, 1) + b.rows - 1) / b.rows);
        if (per_frame) {
            const std::uint64_t per_frame_cost = per_column * std::uint64_t(b.columns) * std::uint64_t(b.rows) + 4;
            b.frames_per_item = int(std::clamp<std::uint64_t>(options_.loop_budget / per_frame_cost, 1, std::uint64_t(test.frames)));
            b.spatial_items = b.items_per_pose;
            b.items_per_pose *= (test.frames + b.frames_per_item - 1) / b.frames_per_item;
        }
        return b;
    };

    // Exact block pre-tests: the same tests with each fixed volume OR-pooled over a block of offsets
    // (dilated_columns). Pooled volumes are shared like the volumes they come from, and made when a
    // stage first goes pose by pose (with maps, most never do).
    const int block = std::max(1, options_.block);
    std::vector<std::vector<OverlapTest>> block_stages(4);
    std::array<bool, 4> blocks_made{};
    std::map<const GpuVolume*, GpuVolume*> pooled;
    auto block_stage = [&](int stage) -> const std::vector<OverlapTest>& {
        auto& tests = block_stages[std::size_t(stage)];
        if (blocks_made[std::size_t(stage)]) return tests;
        blocks_made[std::size_t(stage)] = true;
        for (OverlapTest test : stages[std::size_t(stage)]) {
            auto [it, added] = pooled.emplace(test.fixed, nullptr);
            if (added) it->second = add(dilated_columns(test.fixed->columns, block));
            GpuVolume* volume = it->second;
            if (test.want == Want::EveryFrame && !volume->frame_boxes) {
                const auto& boxes = volume->columns.slot_boxes;
                volume->frame_boxes = upload_to_host(context_, boxes.data() + 1, (boxes.size() - 1) * 16);
            }
            test.fixed = volume;
            tests.push_back(test);
        }
        return tests;
    };

    // ---- stages ----
    SweepResult result;
    result.range = range;
    result.outcomes.assign(range.size(), PoseOutcome::FailsContact);
    if (range.size() == 0) {
        result.count();
        return result;
    }
    Sequence sequence(context_);
    std::unique_ptr<Buffer> flags, poses;
    Buffer no_poses(context_, 16, Buffer::Memory::Host);

    // Pose p of the implicit list: every (i, j) of the range, angle by angle from `angle_first`.
    auto implicit_pose = [&](int angle_first, std::uint64_t p) -> std::array<std::int32_t, 4> {
        const std::uint64_t per_angle = std::uint64_t(range.width()) * std::uint64_t(range.height()), rest = p % per_angle;
        return {angle_first + std::int32_t(p / per_angle), range.i_first + std::int32_t(rest % std::uint64_t(range.width())),
                range.j_first + std::int32_t(rest / std::uint64_t(range.width())), 0};
    };
    // Runs every test of `stage` on `pose_list` (or, when null, on the `implicit_count` poses of the
    // range starting at angle `angle_first`) and returns, per test and pose, whether the pose meets
    // the test's criterion (`Want`). A pose's work items go out in waves (one block of frames, or a
    // quarter of the columns, at a time); a pose that a wave decides (an overlap found; a frame
    // without one) is not sent again, since items cannot tell each other to stop.
    auto run_stage = [&](const std::vector<OverlapTest>& stage, const std::vector<std::array<std::int32_t, 4>>* pose_list,
                         std::uint64_t implicit_count, int angle_first) {
        const std::uint64_t count = pose_list ? pose_list->size() : implicit_count;
        std::vector<std::vector<std::uint8_t>> meets(stage.size(), std::vector<std::uint8_t>(count, 1));
        if (count == 0 || stage.empty()) return meets;
        auto pose_at = [&](std::uint64_t p) { return pose_list ? (*pose_list)[p] : implicit_pose(angle_first, p); };
        for (std::size_t t = 0; t < stage.size(); ++t) {
            const OverlapTest& test = stage[t];
            for (GpuVolume* v : {test.fixed, test.moving})
                if (!v->bits) {
                    v->bits = upload_to_host(context_, v->columns.bits.data(), v->columns.bits.size() * 4);
                    v->rows = upload_to_host(context_, v->columns.rows.data(), v->columns.rows.size() * 8);
                }
            const ColumnVolume& s = test.fixed->columns;
            const ColumnVolume& m = test.moving->columns;
            const Blocks b = blocks_of(test);
            const int words = test.flag_words();
            const bool every_frame = test.want == Want::EveryFrame;
            const int wave = every_frame ? b.spatial_items : std::max(1, (b.items_per_pose + 3) / 4);
            std::vector<std::uint32_t> found(count * std::uint64_t(words), 0u);
            std::vector<std::uint64_t> live(count);
            for (std::uint64_t p = 0; p < count; ++p) live[p] = p;
            for (int chunk_first = 0; chunk_first < b.items_per_pose && !live.empty(); chunk_first += wave) {
                const int chunks = std::min(wave, b.items_per_pose - chunk_first);
                const bool implicit = !pose_list && live.size() == count;
                if (!implicit) {
                    ensure_host_capacity(context_, poses, live.size() * 16);
                    auto* out = poses->mapped<std::uint8_t>().data();
                    for (std::size_t l = 0; l < live.size(); ++l) {
                        const auto pose = pose_at(live[l]);
                        std::memcpy(out + l * 16, pose.data(), 16);
                    }
                }
                ensure_host_capacity(context_, flags, live.size() * std::uint64_t(words) * 4);
                sequence.fill(*flags, live.size() * std::uint64_t(words) * 4, 0u);
                // The clear must land before the test ORs its flags in.
                sequence.barrier();
                const BoundBuffers set = overlap_.bind(
                    {test.fixed->bits.get(), test.fixed->rows.get(), test.moving->bits.get(), test.moving->angles.get(),
                     implicit ? &no_poses : poses.get(), flags.get(), test.fixed->frame_boxes ? test.fixed->frame_boxes.get() : &no_poses,
                     test.moving->angle_frame_boxes ? test.moving->angle_frame_boxes.get() : &no_poses});
                const OverlapParams params{0, 0,
                                           std::int32_t(s.x0), std::int32_t(s.y0), s.nx, s.ny,
                                           std::int32_t(m.x0), std::int32_t(m.y0), m.nx, m.ny,
                                           s.slots, s.zwords, test.frames, test.mode(),
                                           b.columns, b.rows, b.items_x, chunk_first, chunks,
                                           range.i_first, range.j_first, range.width(), range.height(),
                                           angle_first, implicit ? 0 : 1, words, 0,
                                           test.word_first(), test.word_last(), b.frames_per_item, b.spatial_items};
                const std::uint64_t items = live.size() * std::uint64_t(chunks);
                stats_.work_items += items;
                sequence.dispatch(overlap_, set, params, std::uint32_t(items));
                // The host reads the flags after the fence.
                sequence.barrier_to_host();
                sequence.submit_and_wait();
                ++stats_.submits;
                const std::uint32_t* f = flags->mapped<std::uint32_t>().data();
                // Frames whose every item has run: a frame among them without overlap decides the pose.
                const int frames_done = every_frame ? std::min(frames, (chunk_first + chunks) / b.spatial_items * b.frames_per_item) : 0;
                std::vector<std::uint64_t> undecided;
                for (std::size_t l = 0; l < live.size(); ++l) {
                    std::uint32_t* w = found.data() + live[l] * std::uint64_t(words);
                    for (int q = 0; q < words; ++q) w[q] |= f[l * std::size_t(words) + std::size_t(q)];
                    bool decided = false;
                    if (every_frame) {
                        for (int t2 = 0; t2 < frames_done && !decided; ++t2) decided = (w[t2 >> 5] & (1u << (t2 & 31))) == 0;
                    } else {
                        decided = w[0] != 0;
                    }
                    if (!decided) undecided.push_back(live[l]);
                }
                live = std::move(undecided);
            }
            for (std::uint64_t p = 0; p < count; ++p) {
                const std::uint32_t* w = found.data() + p * std::uint64_t(words);
                bool ok;
                if (every_frame) {
                    ok = true;
                    for (int q = 0; q < words; ++q) {
                        int bits = std::min(32, frames - q * 32);
                        std::uint32_t all = bits == 32 ? 0xffffffffu : ((1u << bits) - 1u);
                        ok = ok && (w[q] & all) == all;
                    }
                } else {
                    ok = (w[0] != 0) == (test.want == Want::Overlap);
                }
                meets[t][p] = ok;
            }
        }
        return meets;
    };

    // Batches of angles small enough for the flag buffer and 32-bit item counts.
    const std::uint64_t per_angle = std::uint64_t(range.width()) * range.height();
    std::uint64_t max_items = 1;
    for_each_test([&](const OverlapTest& test) {
        max_items = std::max<std::uint64_t>(max_items, std::uint64_t(blocks_of(test).items_per_pose));
        if (block > 1) max_items = std::max<std::uint64_t>(max_items, std::uint64_t(blocks_of(test, block - 1).items_per_pose));
    });
    const std::uint64_t max_poses = std::max<std::uint64_t>(1, std::min(options_.max_poses_per_batch, (std::uint64_t(1) << 31) / max_items));
    if (per_angle > max_poses) fail("sweep", "one angle has {} poses, more than a batch of {}; narrow the x/y range", per_angle, max_poses);
    // Overlap maps: one bit per offset, a row of words per j, per angle and map.
    const int row_words = (range.width() + 31) / 32;
    std::uint64_t maps_per_angle = 0;
    for (const auto* all : {&required_maps, &optional_maps})
        for (const auto& stage : *all)
            for (const MapTest& test : stage) maps_per_angle = std::max<std::uint64_t>(maps_per_angle, std::uint64_t(test.maps_per_angle()));
    const std::uint64_t map_bytes_per_angle = maps_per_angle * std::uint64_t(range.height()) * std::uint64_t(row_words) * 4;
    const std::uint64_t max_map_bytes = std::min<std::uint64_t>(options_.max_map_bytes, context_.selected().max_storage_buffer_range);
    if (map_bytes_per_angle > max_map_bytes)
        fail("sweep", "the overlap maps of one angle need {} bytes, more than the {} a batch may hold; narrow the x/y range", map_bytes_per_angle,
             max_map_bytes);
    std::uint64_t batch_limit = std::max<std::uint64_t>(1, max_poses / per_angle);
    if (map_bytes_per_angle > 0) batch_limit = std::min(batch_limit, max_map_bytes / map_bytes_per_angle);
    const int angles_per_batch = int(std::max<std::uint64_t>(1, batch_limit));

    using Rows = std::vector<std::array<std::int32_t, 2>>;
    // Cuts one angle's pulled runs for a map test (sorted by key), cut to the columns that can reach
    // the rows in play. Returns the longest run.
    auto cut_pulled_runs = [&](const MapTest& test, int angle, int angle_in_batch, std::array<std::int32_t, 2> rows, std::vector<SliceRun>& out) {
        if (rows[0] > rows[1] || test.runs.runs.empty()) return 0;
        const auto clip = pulled_clip(*test.fixed, range.i_first, range.i_last, range.j_first + rows[0], range.j_first + rows[1]);
        return append_pulled_runs(test.moving_words, trig[std::size_t(angle)], root_a, root_b, angle_in_batch, clip, out);
    };
    // Gives each of an angle's pulled runs (of one map pass) the rows j it must be paired on: those
    // where the fixed runs at its key lie and, where only some poses are in play (`open`: per pose
    // of the angle, in outcome order; null: all), the band from the first to the last row whose
    // fixed runs' hull, moved by the run, holds a pose in play (a pair can only set bits inside it).
    // Runs that reach none are dropped. The map is then exact on the poses in play, the only ones
    // read of it (fidelity, for one, reaches few: most pairs of body runs meet far from any pose in
    // play). A box test (2D prefix sums of the poses in play) first drops most runs cheaply.
    // Returns the pairs of runs the kernel will visit.
    struct PulledPruner {  // scratch reused by one thread
        std::vector<std::uint32_t> prefix;  // (height + 1) x (width + 1) counts of poses in play
    };
    const int width = range.width(), height = range.height();
    if (width > 0xffff || height > 0xffff) fail("sweep", "a range of {} x {} offsets is more than the sweep handles (65,535 per side); narrow it", width, height);
    auto prune_pulled_runs = [&](PulledPruner& pruner, const MapTest& test, std::array<std::int32_t, 2> rows, const std::vector<SliceRun>& runs,
                                 const std::uint8_t* open, std::vector<PulledRun>& out) {
        std::uint64_t pairs = 0;
        if (rows[0] > rows[1] || runs.empty()) return pairs;
        const std::size_t stride = std::size_t(width) + 1;
        if (open) {
            // Only the rows in play are ever queried: prefix rows rows[0] .. rows[1] + 1.
            pruner.prefix.resize(stride * (std::size_t(height) + 1));
            std::fill_n(pruner.prefix.begin() + std::ptrdiff_t(std::size_t(rows[0]) * stride), stride, 0u);
            for (int j = rows[0]; j <= rows[1]; ++j) {
                const std::uint8_t* row_open = open + std::size_t(j) * std::size_t(width);
                const std::uint32_t* above = pruner.prefix.data() + std::size_t(j) * stride;
                std::uint32_t* below = pruner.prefix.data() + (std::size_t(j) + 1) * stride;
                std::uint32_t row_count = 0;
                below[0] = 0;
                for (int i = 0; i < width; ++i) {
                    row_count += row_open[i];
                    below[i + 1] = above[i + 1] + row_count;
                }
            }
        }
        // Poses in play in columns i0..i1 and rows j0..j1.
        auto in_play = [&](int i0, int i1, int j0, int j1) {
            const auto at = [&](int j, int i) { return pruner.prefix[std::size_t(j) * stride + std::size_t(i)]; };
            return at(j1 + 1, i1 + 1) - at(j0, i1 + 1) - at(j1 + 1, i0) + at(j0, i0);
        };
        const std::int32_t keys_per_angle = test.runs.zbits * std::int32_t(test.slots.size());
        for (const SliceRun& run : runs) {
            const std::int32_t fixed_key = run.key % keys_per_angle;
            const auto& box = test.runs.key_boxes[std::size_t(fixed_key)];
            if (box[0] > box[1]) continue;
            // A pair with fixed run (y_a, [xa0, xa1]) sets row j = y_a - y - j_first, offsets xa0 - x_last .. xa1 - x_first.
            int j0 = std::max(rows[0], box[2] - run.y - range.j_first), j1 = std::min(rows[1], box[3] - run.y - range.j_first);
            if (j0 > j1) continue;
            if (open) {
                const int i0 = std::max(0, box[0] - run.x_last - range.i_first), i1 = std::min(width - 1, box[1] - run.x_first - range.i_first);
                if (i0 > i1 || in_play(i0, i1, j0, j1) == 0) continue;
                // The first and last rows where a pose in play lies within reach of the fixed row
                // at the other end: its runs' hull, moved by this run.
                const auto* hulls = test.runs.row_hulls.data() + test.runs.row_hull_first[std::size_t(fixed_key)];
                int reach_first = j1 + 1, reach_last = j0 - 1;
                for (int j = j0; j <= j1; ++j) {
                    const auto& hull = hulls[run.y + range.j_first + j - box[2]];
                    if (hull[0] > hull[1]) continue;
                    const int h0 = std::max(0, hull[0] - run.x_last - range.i_first), h1 = std::min(width - 1, hull[1] - run.x_first - range.i_first);
                    if (h0 > h1 || in_play(h0, h1, j, j) == 0) continue;
                    reach_first = std::min(reach_first, j), reach_last = j;
                }
                if (reach_first > reach_last) continue;
                j0 = reach_first, j1 = reach_last;
            }
            const auto [key_first, key_count] = test.runs.by_key[std::size_t(fixed_key)];
            const auto key_begin = test.runs.runs.begin() + key_first, key_end = key_begin + key_count;
            const auto from = std::lower_bound(key_begin, key_end, run.y + range.j_first + j0, [](const SliceRun& r, std::int32_t y) { return r.y < y; });
            const auto to = std::upper_bound(from, key_end, run.y + range.j_first + j1, [](std::int32_t y, const SliceRun& r) { return y < r.y; });
            pairs += std::uint64_t(to - from);
            out.push_back({run.y, std::uint32_t(run.x_first - test.pulled_x0) | std::uint32_t(run.x_last - test.pulled_x0) << 16, run.key,
                           std::uint32_t(j0) | std::uint32_t(j1) << 16});
        }
        return pairs;
    };

    // Decides `test` for every pose of the batch (implicit order) with an overlap map, computed only
    // on the rows `rows[a]` (first, last j - j_first; empty: first > last) of each angle a of the
    // batch and, where `candidates` is given (per pose of the batch), exactly only on those poses.
    // The map goes in passes over the z slices, coarse to fine (pass_of): a pose that a pass decides
    // (an overlap found) leaves play, so later passes skip the runs that reach only decided poses.
    // For contact a sixteenth of the slices finds most overlaps, and the rest of the runs reach
    // little that is new.
    std::unique_ptr<Buffer> pulled, map_words;
    auto run_map = [&](MapTest& test, int stage, int angle_first, int batch_angles, const Rows& rows, const std::vector<std::uint8_t>* candidates) {
        // Pulled runs' x is packed in 16 bits relative to pulled_x0.
        const std::int64_t x_span = std::int64_t(test.fixed->x_last - test.fixed->x_first) + width;
        if (x_span > 0xffff) fail("key segment", "pulled runs span {} columns, more than the sweep handles (65,535); use a larger voxel", x_span);
        const int maps = test.maps_per_angle();
        // Every-frame maps (one per slot, ANDed) decide nothing before the last pass: one pass.
        const int passes = test.want != Want::EveryFrame ? std::clamp(options_.map_passes, 1, 16) : 1;
        // The poses in play not decided yet; without candidates, every pose once the first pass is in.
        std::vector<std::uint8_t> open;
        if (candidates) open = *candidates;
        Rows open_rows = rows;  // per angle: the rows j with poses in play
        // Host work per angle, on all cores while the device waits.
        auto for_each_angle = [&](const auto& work) {
            parallel_for(std::size_t(batch_angles), [&](std::size_t a) { work(int(a)); });
        };
        // Per angle and pass: the runs of the pass's z slices (pass_of), in key order.
        std::vector<std::vector<std::vector<SliceRun>>> slice_runs_of(static_cast<std::size_t>(batch_angles));
        std::vector<int> longest_of(static_cast<std::size_t>(batch_angles), 0);
        for_each_angle([&](int a) {
            auto& by_pass = slice_runs_of[std::size_t(a)];
            by_pass.resize(std::size_t(passes));
            longest_of[std::size_t(a)] = cut_pulled_runs(test, angle_first + a, a, rows[std::size_t(a)], by_pass[0]);
            if (passes == 1) return;
            std::vector<SliceRun> all = std::move(by_pass[0]);
            by_pass[0].clear();
            for (const SliceRun& run : all) by_pass[std::size_t(pass_of(run.key % test.runs.zbits, passes))].push_back(run);
        });
        const int longest = *std::max_element(longest_of.begin(), longest_of.end());
        const std::uint64_t map_bytes = std::uint64_t(batch_angles) * std::uint64_t(maps) * std::uint64_t(range.height()) * std::uint64_t(row_words) * 4;
        ensure_host_capacity(context_, map_words, map_bytes);
        sequence.fill(*map_words, map_bytes, 0u);
        // The clear must land before the runs OR their intervals in.
        sequence.barrier();
        ++stats_.maps_per_stage[std::size_t(stage)];
        for (int pass = 0; pass < passes; ++pass) {
            // Each angle's runs come sorted by key and keys grow with the angle, so joining them in
            // angle order sorts the batch: neighbouring invocations with the same key walk the same
            // fixed runs (uniform loops and loads across a subgroup).
            std::vector<std::vector<PulledRun>> angle_runs_of(static_cast<std::size_t>(batch_angles));
            std::vector<std::uint64_t> pairs_of(static_cast<std::size_t>(batch_angles), 0);
            for_each_angle([&](int a) {
                thread_local PulledPruner pruner;
                pairs_of[std::size_t(a)] = prune_pulled_runs(pruner, test, open_rows[std::size_t(a)], slice_runs_of[std::size_t(a)][std::size_t(pass)],
                                                             open.empty() ? nullptr : open.data() + std::size_t(a) * per_angle, angle_runs_of[std::size_t(a)]);
            });
            std::vector<PulledRun> runs;
            std::size_t total_runs = 0;
            for (int a = 0; a < batch_angles; ++a) {
                total_runs += angle_runs_of[std::size_t(a)].size();
                stats_.run_pairs_per_stage[std::size_t(stage)] += pairs_of[std::size_t(a)];
            }
            runs.reserve(total_runs);
            for (const auto& angle_runs : angle_runs_of) runs.insert(runs.end(), angle_runs.begin(), angle_runs.end());
            stats_.pulled_runs_per_stage[std::size_t(stage)] += runs.size();
            std::optional<BoundBuffers> set;  // lives until the submit below has finished
            if (!runs.empty()) {
                // Loop steps: the binary search, then per fixed run its test and the words its interval spans.
                const std::uint64_t search = 34, per_run = std::uint64_t(test.runs.longest + longest) / 32 + 4;
                if (search + per_run > options_.loop_budget)
                    fail("key segment", "a run of {} voxels is longer than one invocation may handle; use a larger voxel", test.runs.longest + longest);
                const int runs_per_chunk = int((options_.loop_budget - search) / per_run);
                const int chunks = std::max(1, (test.runs.most_per_key + runs_per_chunk - 1) / runs_per_chunk);
                const std::uint64_t items = std::uint64_t(runs.size()) * std::uint64_t(chunks);
                if (items > std::uint64_t(std::numeric_limits<std::uint32_t>::max()))
                    fail("sweep", "{} overlap-map work items in one batch are more than one dispatch takes; narrow the x/y range", items);
                ensure_host_capacity(context_, pulled, runs.size() * sizeof(PulledRun));
                std::memcpy(pulled->mapped<std::uint8_t>().data(), runs.data(), runs.size() * sizeof(PulledRun));
                set.emplace(map_.bind({test.fixed_runs.get(), test.fixed_keys.get(), pulled.get(), map_words.get()}));
                const MapParams params{0, 0, chunks, runs_per_chunk, test.runs.zbits, std::int32_t(test.slots.size()),
                                       range.i_first, range.j_first, range.width(), range.height(), row_words,
                                       test.want == Want::EveryFrame ? 1 : 0, std::int32_t(test.fixed->x0), std::int32_t(test.fixed->y0),
                                       test.pulled_x0};
                stats_.work_items += items;
                sequence.dispatch(map_, *set, params, std::uint32_t(items));
            }
            // The host reads the maps after the fence.
            sequence.barrier_to_host();
            sequence.submit_and_wait();
            ++stats_.submits;
            if (pass + 1 < passes) {
                // Poses with an overlap found are decided (one map per angle here); the rows in play
                // shrink to those with poses still open.
                const std::uint32_t* words = map_words->mapped<std::uint32_t>().data();
                if (open.empty()) open.assign(per_angle * std::size_t(batch_angles), 1);
                for (int a = 0; a < batch_angles; ++a) {
                    auto& band = open_rows[std::size_t(a)];
                    std::array<std::int32_t, 2> still{height, -1};
                    for (int j = band[0]; j <= band[1]; ++j) {
                        std::uint8_t* row_open = open.data() + std::size_t(a) * per_angle + std::size_t(j) * std::size_t(width);
                        const std::uint32_t* row = words + (std::size_t(a) * std::size_t(height) + std::size_t(j)) * std::size_t(row_words);
                        bool any = false;
                        for (int i = 0; i < width; ++i) {
                            row_open[i] &= std::uint8_t(~(row[i >> 5] >> (i & 31)) & 1u);
                            any |= row_open[i] != 0;
                        }
                        if (any) still = {std::min(still[0], j), j};
                    }
                    band = still;
                }
            }
        }
        const std::uint32_t* words = map_words->mapped<std::uint32_t>().data();
        std::vector<std::uint8_t> meets(per_angle * std::uint64_t(batch_angles));
        const std::uint8_t when_set = test.want == Want::NoOverlap ? 0 : 1;
        for (int a = 0; a < batch_angles; ++a)
            for (int j = 0; j < height; ++j) {
                std::uint8_t* out = meets.data() + std::size_t(a) * per_angle + std::size_t(j) * std::size_t(width);
                // EveryFrame: set in every slot's map; otherwise the one map's bit says it.
                const std::uint32_t* row = words + (std::size_t(a) * std::size_t(maps) * std::size_t(height) + std::size_t(j)) * std::size_t(row_words);
                for (int w = 0; w < row_words; ++w) {
                    std::uint32_t bits = row[w];
                    for (int m = 1; m < maps; ++m) bits &= row[std::size_t(m) * std::size_t(height) * std::size_t(row_words) + std::size_t(w)];
                    for (int i = w * 32; i < std::min(width, w * 32 + 32); ++i) out[i] = ((bits >> (i & 31)) & 1u) ? when_set : std::uint8_t(1 - when_set);
                }
            }
        return meets;
    };


    auto outcome_index = [&](const std::array<std::int32_t, 4>& p) {
        return (std::size_t(p[0]) * range.height() + std::size_t(p[2] - range.j_first)) * range.width() + std::size_t(p[1] - range.i_first);
    };
    using Pose = std::array<std::int32_t, 4>;  // angle, i, j, unused
    const int blocks_x = (range.width() + block - 1) / block, blocks_y = (range.height() + block - 1) / block;
    auto passes_all = [](const std::vector<std::vector<std::uint8_t>>& meets, std::size_t p) {
        return std::all_of(meets.begin(), meets.end(), [p](const auto& m) { return m[p] != 0; });
    };
    // What a block pre-test proves for every pose of its block: a pooled "no overlap" makes an
    // Overlap or EveryFrame test fail and a NoOverlap test pass; a pooled overlap proves nothing.
    enum class Verdict : std::uint8_t { Fail, Pass, Undecided };
    auto block_verdicts = [&](int stage, const std::vector<Pose>& bases) {
        std::vector<Verdict> verdicts(bases.size(), Verdict::Pass);
        if (bases.empty()) return verdicts;
        stats_.blocks_per_stage[std::size_t(stage)] += bases.size();
        const auto& tests = block_stage(stage);
        const auto meets = run_stage(tests, &bases, 0, 0);
        for (std::size_t b = 0; b < bases.size(); ++b)
            for (std::size_t t = 0; t < tests.size(); ++t) {
                if (verdicts[b] == Verdict::Fail) break;
                const bool proven = tests[t].want == Want::NoOverlap ? meets[t][b] != 0 : meets[t][b] == 0;
                if (proven && tests[t].want != Want::NoOverlap) verdicts[b] = Verdict::Fail;
                else if (!proven) verdicts[b] = Verdict::Undecided;
            }
        return verdicts;
    };
    // Decides stage `stage` (1..3) for `candidates` of the batch starting at `angle_first`: blocks
    // first, then pose by pose where a block is undecided. Returns per candidate whether it passes.
    auto decide = [&](int stage, const std::vector<Pose>& candidates, int angle_first, int batch_angles) {
        std::vector<std::uint8_t> passes(candidates.size(), 1);
        if (stages[std::size_t(stage)].empty() || candidates.empty()) return passes;
        std::vector<std::size_t> undecided;
        if (block > 1) {
            std::vector<std::int32_t> block_of(std::size_t(batch_angles) * std::size_t(blocks_x) * std::size_t(blocks_y), -1);
            std::vector<Pose> bases;
            std::vector<std::int32_t> pose_block(candidates.size());
            for (std::size_t p = 0; p < candidates.size(); ++p) {
                const Pose& q = candidates[p];
                const int bi = (q[1] - range.i_first) / block, bj = (q[2] - range.j_first) / block;
                const std::size_t key = (std::size_t(q[0] - angle_first) * std::size_t(blocks_y) + std::size_t(bj)) * std::size_t(blocks_x) + std::size_t(bi);
                if (block_of[key] < 0) {
                    block_of[key] = std::int32_t(bases.size());
                    bases.push_back({q[0], range.i_first + bi * block, range.j_first + bj * block, 0});
                }
                pose_block[p] = block_of[key];
            }
            const std::vector<Verdict> verdicts = block_verdicts(stage, bases);
            for (std::size_t p = 0; p < candidates.size(); ++p) {
                const Verdict v = verdicts[std::size_t(pose_block[p])];
                if (v == Verdict::Fail) passes[p] = 0;
                else if (v == Verdict::Undecided) undecided.push_back(p);
            }
        } else {
            undecided.resize(candidates.size());
            for (std::size_t p = 0; p < candidates.size(); ++p) undecided[p] = p;
        }
        std::vector<Pose> list;
        list.reserve(undecided.size());
        for (std::size_t p : undecided) list.push_back(candidates[p]);
        stats_.pose_tests_per_stage[std::size_t(stage)] += list.size();
        const auto meets = run_stage(stages[std::size_t(stage)], &list, 0, 0);
        for (std::size_t u = 0; u < undecided.size(); ++u) passes[undecided[u]] = passes_all(meets, u);
        return passes;
    };

    // The cost model: a stage's optional maps pay off when its poses, tested one by one, would cost
    // more than the run pairs of its maps (estimated from one angle of the batch).
    auto maps_pay_off = [&](int stage, std::size_t pose_count, int angle_first, int batch_angles, const Rows& rows,
                            const std::vector<std::uint8_t>& candidates) {
        if (optional_maps[std::size_t(stage)].empty() || pose_count == 0) return false;
        // The first angle with poses in play stands for every angle with some.
        int sample = 0, angles_in_play = 0;
        for (int a = batch_angles - 1; a >= 0; --a)
            if (rows[std::size_t(a)][0] <= rows[std::size_t(a)][1]) sample = a, ++angles_in_play;
        std::uint64_t pairs = 0;
        PulledPruner pruner;
        for (const MapTest& test : optional_maps[std::size_t(stage)]) {
            std::vector<SliceRun> runs;
            std::vector<PulledRun> pruned;
            cut_pulled_runs(test, angle_first + sample, 0, rows[std::size_t(sample)], runs);
            pairs += prune_pulled_runs(pruner, test, rows[std::size_t(sample)], runs, candidates.data() + std::size_t(sample) * per_angle, pruned);
        }
        const double pose_cost = double(pose_count) * options_.pose_test_pairs;
        return pose_cost > double(pairs) * double(angles_in_play);
    };
    for (int angle_first = 0; angle_first < range.angles; angle_first += angles_per_batch) {
        const int batch_angles = std::min(angles_per_batch, range.angles - angle_first);
        const std::uint64_t batch_poses = per_angle * std::uint64_t(batch_angles);
        stats_.poses_per_stage[0] += batch_poses;
        auto clock = std::chrono::steady_clock::now();
        auto lap = [&clock](double& total) {
            auto now = std::chrono::steady_clock::now();
            total += std::chrono::duration<double>(now - clock).count();
            clock = now;
        };
        std::vector<Pose> survivors;
        if (options_.maps) {
            // Contact, then the required dictionary maps on the poses in contact, every offset at once.
            const Rows all_rows(std::size_t(batch_angles), {0, range.height() - 1});
            const auto contact = run_map(required_maps[0].front(), 0, angle_first, batch_angles, all_rows, nullptr);
            lap(stats_.seconds_per_stage[0]);
            Rows contact_rows(std::size_t(batch_angles), {range.height(), -1});
            for (std::uint64_t p = 0; p < batch_poses; ++p)
                if (contact[p]) {
                    auto& r = contact_rows[std::size_t(p / per_angle)];
                    const std::int32_t j = std::int32_t(p % per_angle / std::uint64_t(range.width()));
                    r = {std::min(r[0], j), std::max(r[1], j)};
                }
            std::vector<std::vector<std::uint8_t>> dictionary;
            for (MapTest& test : required_maps[1]) dictionary.push_back(run_map(test, 1, angle_first, batch_angles, contact_rows, &contact));
            for (std::uint64_t p = 0; p < batch_poses; ++p) {
                if (!contact[p]) continue;
                ++stats_.poses_per_stage[1];
                const Pose pose = implicit_pose(angle_first, p);
                if (passes_all(dictionary, p)) survivors.push_back(pose);
                else result.outcomes[outcome_index(pose)] = PoseOutcome::FailsDictionary;
            }
        } else {
            // Contact on every pose of the batch: by block where blocks are on, then pose by pose.
            if (block > 1) {
                std::vector<Pose> bases;
                for (int k = angle_first; k < angle_first + batch_angles; ++k)
                    for (int bj = 0; bj < blocks_y; ++bj)
                        for (int bi = 0; bi < blocks_x; ++bi) bases.push_back({k, range.i_first + bi * block, range.j_first + bj * block, 0});
                const std::vector<Verdict> verdicts = block_verdicts(0, bases);
                std::vector<Pose> candidates;
                for (std::size_t b = 0; b < bases.size(); ++b) {
                    if (verdicts[b] == Verdict::Fail) continue;
                    for (int j = bases[b][2]; j < std::min(bases[b][2] + block, range.j_last + 1); ++j)
                        for (int i = bases[b][1]; i < std::min(bases[b][1] + block, range.i_last + 1); ++i) candidates.push_back({bases[b][0], i, j, 0});
                }
                stats_.pose_tests_per_stage[0] += candidates.size();
                const auto meets = run_stage(stages[0], &candidates, 0, 0);
                for (std::size_t p = 0; p < candidates.size(); ++p)
                    if (passes_all(meets, p)) survivors.push_back(candidates[p]);
            } else {
                stats_.pose_tests_per_stage[0] += batch_poses;
                const auto meets = run_stage(stages[0], nullptr, batch_poses, angle_first);
                for (std::uint64_t p = 0; p < batch_poses; ++p)
                    if (passes_all(meets, p)) survivors.push_back(implicit_pose(angle_first, p));
            }
            lap(stats_.seconds_per_stage[0]);
        }
        for (int stage = 1; stage < 4; ++stage) {
            if (!options_.maps || stage > 1) stats_.poses_per_stage[std::size_t(stage)] += survivors.size();
            if (options_.maps && stage == 1 && type.lateral_pair()) {  // the required maps decided it
                lap(stats_.seconds_per_stage[1]);
                continue;
            }
            std::vector<std::uint8_t> passes;
            Rows rows(std::size_t(batch_angles), {range.height(), -1});
            std::vector<std::uint8_t> candidates(batch_poses, 0);
            for (const Pose& q : survivors) {
                auto& r = rows[std::size_t(q[0] - angle_first)];
                r = {std::min(r[0], q[2] - range.j_first), std::max(r[1], q[2] - range.j_first)};
                candidates[outcome_index(q) - std::size_t(angle_first) * std::size_t(per_angle)] = 1;
            }
            if (maps_pay_off(stage, survivors.size(), angle_first, batch_angles, rows, candidates)) {
                std::vector<std::vector<std::uint8_t>> meets;
                for (MapTest& test : optional_maps[std::size_t(stage)]) meets.push_back(run_map(test, stage, angle_first, batch_angles, rows, &candidates));
                passes.resize(survivors.size());
                for (std::size_t p = 0; p < survivors.size(); ++p) {
                    const Pose& q = survivors[p];
                    // The maps hold the batch's poses in outcome order, starting at angle_first.
                    passes[p] = passes_all(meets, outcome_index(q) - std::size_t(angle_first) * std::size_t(per_angle));
                }
            } else {
                passes = decide(stage, survivors, angle_first, batch_angles);
            }
            std::vector<Pose> next;
            for (std::size_t p = 0; p < survivors.size(); ++p) {
                if (passes[p]) next.push_back(survivors[p]);
                else result.outcomes[outcome_index(survivors[p])] = PoseOutcome(stage);
            }
            survivors = std::move(next);
            lap(stats_.seconds_per_stage[std::size_t(stage)]);
        }
        for (const auto& p : survivors) result.outcomes[outcome_index(p)] = PoseOutcome::Solution;
        if (progress) progress(angle_first + batch_angles, range.angles);
    }
    result.count();
    return result;
}

}  // namespace amhv::gpu
