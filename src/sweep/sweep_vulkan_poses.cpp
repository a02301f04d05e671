// Pose-by-pose tests of the Vulkan sweep (shaders/sweep_overlap.comp): work blocks under the loop
// budget, waves that drop decided poses, and the exact block pre-tests on OR-pooled volumes.
#include <algorithm>
#include <bit>
#include <cstring>

#include "src/core/error.hpp"
#include "src/sweep/sweep_vulkan_run.hpp"

namespace amhv::gpu::sweep_detail {

// Work blocks per test: loop iterations per item stay under the budget.
Blocks SweepRun::blocks_of(const OverlapTest& test) const {
    const std::uint32_t budget = tools_.options.loop_budget;
    const int nx = test.fixed->columns.nx, ny = test.fixed->columns.ny;
    // PER_FRAME items loop frames outside and columns inside: size the spatial block for one
    // frame, then give the item as many frames as fit.
    const bool per_frame = test.want == Want::Frames;
    const std::uint64_t per_column = per_frame ? std::uint64_t(test.words()) + 2 : std::uint64_t(test.words()) * (1 + test.frames) + 2;
    if (per_column > budget)
        fail("key segment", "one column test needs {} loop iterations, more than the {} one invocation may run; use a larger voxel "
             "or a shorter segment", per_column, budget);
    Blocks b;
    b.columns = int(std::min<std::uint64_t>(std::uint64_t(std::max(nx, 1)), budget / per_column));
    b.rows = int(std::clamp<std::uint64_t>(budget / (per_column * std::uint64_t(b.columns)), 1, std::uint64_t(std::max(ny, 1))));
    b.items_x = (std::max(nx, 1) + b.columns - 1) / b.columns;
    b.items_per_pose = b.items_x * ((std::max(ny, 1) + b.rows - 1) / b.rows);
    if (per_frame) {
        const std::uint64_t per_frame_cost = per_column * std::uint64_t(b.columns) * std::uint64_t(b.rows) + 4;
        b.frames_per_item = int(std::clamp<std::uint64_t>(budget / per_frame_cost, 1, std::uint64_t(test.frames)));
        b.spatial_items = b.items_per_pose;
        b.items_per_pose *= (test.frames + b.frames_per_item - 1) / b.frames_per_item;
    }
    return b;
}

// Exact block pre-tests: the same tests with each fixed volume OR-pooled over a block of offsets
// (dilated_columns). Pooled volumes are shared like the volumes they come from, and made when a
// stage first goes pose by pose (with maps, most never do).
const std::vector<OverlapTest>& SweepRun::block_stage(int stage) {
    auto& tests = block_stages_[std::size_t(stage)];
    if (blocks_made_[std::size_t(stage)]) return tests;
    blocks_made_[std::size_t(stage)] = true;
    for (OverlapTest test : stages_[std::size_t(stage)]) {
        // A's volumes pooled once for every height (HeightShare).
        if (!share_.holds(&test.fixed->columns)) fail("sweep", "internal: a test's fixed volume is not A's shared one");
        std::unique_ptr<GpuVolume>& pooled = share_.block_pooled[test.fixed];
        GpuVolume* volume =
            pooled ? pooled.get() : HeightShare::keep(pooled, dilated_columns(test.fixed->columns, block_), tools_.stats.fixed_volumes_built);
        if (test.want == Want::Frames && !volume->frame_boxes) {
            const auto& boxes = volume->columns.slot_boxes;
            volume->frame_boxes = upload_for_kernels(tools_.context, boxes.data() + 1, (boxes.size() - 1) * 16);
        }
        test.fixed = volume;
        tests.push_back(test);
    }
    return tests;
}

// Pose p of the implicit list: every (i, j) of the range, angle by angle from `angle_first`.
Pose SweepRun::implicit_pose(int angle_first, std::uint64_t p) const {
    const std::uint64_t rest = p % per_angle_;
    return {angle_first + std::int32_t(p / per_angle_), range_.i_first + std::int32_t(rest % std::uint64_t(width_)),
            range_.j_first + std::int32_t(rest / std::uint64_t(width_)), 0};
}

std::size_t SweepRun::outcome_index(const Pose& p) const {
    return ((std::size_t(p[3]) * std::size_t(range_.angles) + std::size_t(p[0])) * std::size_t(height_) + std::size_t(p[2] - range_.j_first)) *
               std::size_t(width_) +
           std::size_t(p[1] - range_.i_first);
}

// The most poses one dispatch of a wave takes: its items are indexed in 32 bits, and its pose
// list (16 bytes a pose) and flags are storage buffers. A batch may hold more poses than that (a
// batch's angles go by the cores, and maps have no such limit), so a wave goes in slices.
std::uint64_t SweepRun::poses_per_dispatch(int chunks, int words) const {
    if (std::uint64_t(chunks) >= (std::uint64_t(1) << 31)) fail("sweep", "internal: {} work items for one pose", chunks);
    const std::uint64_t range = tools_.context.selected().max_storage_buffer_range;
    std::uint64_t most = std::min({(std::uint64_t(1) << 31) / std::uint64_t(chunks), range / 16, range / (std::uint64_t(words) * 4)});
    if (tools_.options.max_poses_per_dispatch > 0) most = std::min(most, tools_.options.max_poses_per_dispatch);
    return std::max<std::uint64_t>(1, most);
}

// Items chunk_first .. chunk_first + chunks - 1 of the poses `slice` (indices into the pose list,
// or of the implicit poses from `angle_first` when `implicit`: then the slice is all of them, in
// order): one dispatch, waited for. Returns the flags, `words` per pose of the slice.
const std::uint32_t* SweepRun::dispatch_wave_slice(const OverlapTest& test, const Blocks& b, const std::vector<Pose>* pose_list, int angle_first,
                                                   bool implicit, int chunk_first, int chunks, std::span<const std::uint64_t> slice) {
    Context& context = tools_.context;
    const ColumnVolume& s = test.fixed->columns;
    const ColumnVolume& m = test.moving->columns;
    const int words = test.flag_words();
    if (!implicit) {
        poses_.ensure(context, slice.size() * 16);
        auto* out = poses_.host<std::uint8_t>().data();
        for (std::size_t l = 0; l < slice.size(); ++l) {
            const Pose pose = pose_list ? (*pose_list)[slice[l]] : implicit_pose(angle_first, slice[l]);
            std::memcpy(out + l * 16, pose.data(), 16);
        }
        poses_.copy_to_device(sequence_, slice.size() * 16);
    }
    const std::uint64_t flag_bytes = slice.size() * std::uint64_t(words) * 4;
    flags_.ensure(context, flag_bytes);
    sequence_.fill(flags_.device(), flag_bytes, 0u);
    // The clear must land before the test ORs its flags in.
    sequence_.barrier();
    const BoundBuffers set = tools_.overlap.bind(
        {test.fixed->bits.get(), test.fixed->rows.get(), test.moving->bits.get(), test.moving->angles.get(),
         implicit ? &no_poses_ : &poses_.device(), &flags_.device(), test.fixed->frame_boxes ? test.fixed->frame_boxes.get() : &no_poses_,
         test.moving->angle_frame_boxes ? test.moving->angle_frame_boxes.get() : &no_poses_});
    const OverlapParams params{0, 0,
                               std::int32_t(s.x0), std::int32_t(s.y0), s.nx, s.ny,
                               std::int32_t(m.x0), std::int32_t(m.y0), m.nx, m.ny,
                               s.slots, s.zwords, test.frames, test.mode(),
                               b.columns, b.rows, b.items_x, chunk_first, chunks,
                               range_.i_first, range_.j_first, width_, height_,
                               angle_first, implicit ? 0 : 1, words, 0,
                               test.word_first(), test.word_last(), b.frames_per_item, b.spatial_items};
    const std::uint64_t items = slice.size() * std::uint64_t(chunks);
    tools_.stats.work_items += items;
    sequence_.dispatch(tools_.overlap, set, params, std::uint32_t(items));
    // The host reads the flags after the fence.
    flags_.copy_to_host(sequence_, flag_bytes);
    sequence_.barrier_to_host();
    submit_and_wait();
    ++tools_.stats.submits;
    return flags_.host<std::uint32_t>().data();
}

// A pose's work items go out in waves (one block of frames, or a quarter of the columns, at a
// time); a pose that a wave decides (an overlap found; a frame without one) is not sent again,
// since items cannot tell each other to stop.
void SweepRun::run_test_waves(const OverlapTest& test, const std::vector<Pose>* pose_list, std::uint64_t count, int angle_first,
                              std::vector<std::uint32_t>& found) {
    const Blocks b = blocks_of(test);
    const int words = test.flag_words();
    const bool per_frame = test.want == Want::Frames;
    const int wave = per_frame ? b.spatial_items : std::max(1, (b.items_per_pose + 3) / 4);
    std::vector<std::uint64_t> live(count);
    for (std::uint64_t p = 0; p < count; ++p) live[p] = p;
    for (int chunk_first = 0; chunk_first < b.items_per_pose && !live.empty(); chunk_first += wave) {
        const int chunks = std::min(wave, b.items_per_pose - chunk_first);
        const std::uint64_t per_dispatch = poses_per_dispatch(chunks, words);
        const bool implicit = !pose_list && live.size() == count && count <= per_dispatch;
        // Frames whose every item has run: more frames among them without overlap than the test
        // allows decide the pose.
        const int frames_done = per_frame ? std::min(frames_, (chunk_first + chunks) / b.spatial_items * b.frames_per_item) : 0;
        std::vector<std::uint64_t> undecided;
        for (std::size_t first = 0; first < live.size(); first += per_dispatch) {
            const std::span<const std::uint64_t> slice(live.data() + first, std::min<std::size_t>(per_dispatch, live.size() - first));
            const std::uint32_t* f = dispatch_wave_slice(test, b, pose_list, angle_first, implicit, chunk_first, chunks, slice);
            for (std::size_t l = 0; l < slice.size(); ++l) {
                std::uint32_t* w = found.data() + slice[l] * std::uint64_t(words);
                for (int q = 0; q < words; ++q) w[q] |= f[l * std::size_t(words) + std::size_t(q)];
                if (!wave_decides(test, w, frames_done)) undecided.push_back(slice[l]);
            }
        }
        live = std::move(undecided);
    }
}

// Whether a pose's flags so far (`w`) decide the test, `frames_done` frames having run in full.
bool SweepRun::wave_decides(const OverlapTest& test, const std::uint32_t* w, int frames_done) const {
    if (test.want != Want::Frames) return w[0] != 0;
    // Too many frames without overlap fail it; enough frames with one pass it.
    int misses = 0, hits = 0;
    for (int t2 = 0; t2 < frames_; ++t2) {
        const bool hit = (w[t2 >> 5] & (1u << (t2 & 31))) != 0;
        hits += hit;
        misses += !hit && t2 < frames_done;
    }
    return misses > test.misses_allowed() || hits >= test.needed;
}

Meets SweepRun::run_stage(const std::vector<OverlapTest>& stage, const std::vector<Pose>* pose_list, std::uint64_t implicit_count,
                          int angle_first) {
    const std::uint64_t count = pose_list ? pose_list->size() : implicit_count;
    Meets meets(stage.size(), std::vector<std::uint8_t>(count, 1));
    if (count == 0 || stage.empty()) return meets;
    for (std::size_t t = 0; t < stage.size(); ++t) {
        const OverlapTest& test = stage[t];
        for (GpuVolume* v : {test.fixed, test.moving})
            if (!v->bits) {
                v->bits = upload_for_kernels(tools_.context, v->columns.bits.data(), v->columns.bits.size() * 4);
                v->rows = upload_for_kernels(tools_.context, v->columns.rows.data(), v->columns.rows.size() * 8);
            }
        const int words = test.flag_words();
        std::vector<std::uint32_t> found(count * std::uint64_t(words), 0u);
        run_test_waves(test, pose_list, count, angle_first, found);
        for (std::uint64_t p = 0; p < count; ++p) {
            const std::uint32_t* w = found.data() + p * std::uint64_t(words);
            bool ok;
            if (test.want == Want::Frames) {
                int frames_found = 0;
                for (int q = 0; q < words; ++q) {
                    int bits = std::min(32, frames_ - q * 32);
                    std::uint32_t all = bits == 32 ? 0xffffffffu : ((1u << bits) - 1u);
                    frames_found += std::popcount(w[q] & all);
                }
                ok = frames_found >= test.needed;
            } else {
                ok = (w[0] != 0) == (test.want == Want::Overlap);
            }
            meets[t][p] = ok;
        }
    }
    return meets;
}

std::vector<Verdict> SweepRun::block_verdicts(int stage, const std::vector<Pose>& bases) {
    std::vector<Verdict> verdicts(bases.size(), Verdict::Pass);
    if (bases.empty()) return verdicts;
    tools_.stats.blocks_per_stage[std::size_t(stage)] += bases.size();
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
}

std::vector<std::uint8_t> SweepRun::decide(int stage, const std::vector<Pose>& candidates, int angle_first, int batch_angles) {
    std::vector<std::uint8_t> passes(candidates.size(), 1);
    if (stages_[std::size_t(stage)].empty() || candidates.empty()) return passes;
    std::vector<std::size_t> undecided;
    if (block_ > 1) {
        std::vector<std::int32_t> block_of(std::size_t(batch_angles) * std::size_t(blocks_x_) * std::size_t(blocks_y_), -1);
        std::vector<Pose> bases;
        std::vector<std::int32_t> pose_block(candidates.size());
        for (std::size_t p = 0; p < candidates.size(); ++p) {
            const Pose& q = candidates[p];
            const int bi = (q[1] - range_.i_first) / block_, bj = (q[2] - range_.j_first) / block_;
            const std::size_t key = (std::size_t(q[0] - angle_first) * std::size_t(blocks_y_) + std::size_t(bj)) * std::size_t(blocks_x_) + std::size_t(bi);
            if (block_of[key] < 0) {
                block_of[key] = std::int32_t(bases.size());
                bases.push_back({q[0], range_.i_first + bi * block_, range_.j_first + bj * block_, 0});
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
    tools_.stats.pose_tests_per_stage[std::size_t(stage)] += list.size();
    const auto meets = run_stage(stages_[std::size_t(stage)], &list, 0, 0);
    for (std::size_t u = 0; u < undecided.size(); ++u) passes[undecided[u]] = passes_all(meets, u);
    return passes;
}

}  // namespace amhv::gpu::sweep_detail
