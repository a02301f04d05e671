// The plan of one Vulkan sweep: which overlap tests decide each stage, on which column volumes,
// which of them go as overlap maps, and how many angles one batch holds.
#include <algorithm>
#include <cstring>

#include "src/core/error.hpp"
#include "src/core/parallel.hpp"
#include "src/sweep/sweep_vulkan_run.hpp"

namespace amhv::gpu::sweep_detail {

namespace {

PoseRange levels_of(PoseRange range, int first, int count) {
    range.z_first = first;
    range.z_last = first + count - 1;
    return range;
}

// Column volumes to build, each a plain function of the segment's volumes: they are built on all
// cores (a serial step of every sweep before), then added in the order they were asked for. A's
// volumes go to the sweep's HeightShare, by name, and are built only by the first height's run.
class ColumnJobs {
public:
    ColumnJobs(HeightShare& share, std::uint64_t& fixed_built) : share_(share), fixed_built_(fixed_built) {}
    // B's volume: this height's own.
    std::size_t add(std::function<ColumnVolume()> job) {
        jobs_.push_back({std::move(job), {}});
        return jobs_.size() - 1;
    }
    // A's volume `name` (unique among A's volumes of the sweep), shared by every height.
    std::size_t add_fixed(std::string name, std::function<ColumnVolume()> job) {
        if (share_.fixed.count(name)) job = nullptr;
        jobs_.push_back({std::move(job), std::move(name)});
        return jobs_.size() - 1;
    }
    // Every volume asked for, in order: B's added to the run by `add_moving`.
    std::vector<GpuVolume*> run(const std::function<GpuVolume*(ColumnVolume)>& add_moving) const {
        std::vector<ColumnVolume> built(jobs_.size());
        parallel_for(jobs_.size(), [&](std::size_t k) {
            if (jobs_[k].build) built[k] = jobs_[k].build();
        });
        std::vector<GpuVolume*> volumes;
        for (std::size_t k = 0; k < jobs_.size(); ++k) {
            if (jobs_[k].fixed_name.empty()) {
                volumes.push_back(add_moving(std::move(built[k])));
                continue;
            }
            std::unique_ptr<GpuVolume>& shared = share_.fixed[jobs_[k].fixed_name];
            volumes.push_back(shared ? shared.get() : HeightShare::keep(shared, std::move(built[k]), fixed_built_));
        }
        return volumes;
    }

private:
    struct Job {
        std::function<ColumnVolume()> build;  // null: A's volume is shared already
        std::string fixed_name;               // empty: B's
    };
    HeightShare& share_;
    std::uint64_t& fixed_built_;
    std::vector<Job> jobs_;
};

// An overlap test of stage `stage` on the column volumes `fixed` and `moving` (ColumnJobs indices).
struct PlannedTest {
    int stage;
    std::size_t fixed, moving;
    int frames;
    Want want;
    int needed = 0;
};

}  // namespace

SweepRun::SweepRun(const SweepProblem& problem, SweepTools tools, HeightShare& share, int level_first, int heights)
    : problem_(problem),
      tools_(tools),
      share_(share),
      frames_(problem.frames()),
      last_(problem.frames() - 1),
      type_(problem.type),
      range_(levels_of(problem.range, level_first, heights)),
      heights_(heights),
      width_(problem.range.width()),
      height_(problem.range.height()),
      block_(std::max(1, tools.options.block)),
      per_angle_(std::uint64_t(problem.range.width()) * std::uint64_t(problem.range.height())),
      sequence_(tools.context),
      no_poses_(tools.context, 16, Buffer::Memory::Host) {
    if (frames_ > VulkanSweeper::kMaxFrameWords * 32)
        fail("key segment", "has {} normalised frames; the sweep handles at most {}", frames_, VulkanSweeper::kMaxFrameWords * 32);
    std::vector<const VoxelGrid*> grids_a{&problem.a.whole.grid()}, grids_b{&problem.b.whole.grid()};
    if (problem.visibility) grids_a.push_back(&problem.a.view_cone.grid), grids_b.push_back(&problem.b.view_cone.grid);
    // One frame for every height, so that A's volumes are the same bits at each (HeightShare).
    z_ = z_frame_covering(grids_a, grids_b, problem.range.z_first, problem.range.z_last);
    if (heights < 1 || (heights > 1 && !heights_in_one(tools.options)) || range_.z_last > problem.range.z_last)
        fail("sweep", "internal: a run of {} heights from level {}", heights, level_first);
    z_b_ = raised_frame(z_, level_first);
    plan_stages();
    for (int stage = 0; stage < 4; ++stage)
        for (const OverlapTest& test : stages_[std::size_t(stage)]) pose_iterations_[std::size_t(stage)] += pose_test_iterations(test);
    if (tools_.options.maps) plan_maps();
    root_a_ = problem.root_a_q();
    root_b_ = problem.root_b_q();
    trig_.resize(std::size_t(range_.angles));
    for (int k = 0; k < range_.angles; ++k) trig_[std::size_t(k)] = problem.trig(k);
    upload_angle_tables();
    blocks_x_ = (width_ + block_ - 1) / block_;
    blocks_y_ = (height_ + block_ - 1) / block_;
}

double pose_test_iterations(const OverlapTest& test) {
    const ColumnVolume& fixed = test.fixed->columns;
    const ColumnVolume& moving = test.moving->columns;
    double fixed_columns = 0;
    for (const auto& row : fixed.rows) fixed_columns += row[0] <= row[1] ? row[1] - row[0] + 1 : 0;
    const double moving_area = moving.empty() ? 0.0 : 2.0 * (moving.x_last - moving.x_first + 1) * (moving.y_last - moving.y_first + 1);
    return std::min(fixed_columns, moving_area) * test.words() * std::max(1, test.frames);
}

GpuVolume* SweepRun::add(ColumnVolume columns) {
    auto v = std::make_unique<GpuVolume>();
    v->columns = std::move(columns);
    volumes_.push_back(std::move(v));
    return volumes_.back().get();
}

// Contact: the interest unions meet. Dictionary: a '+' ('-') label fails when a contact voxel of
// that object is off its end (start) surface, i.e. when that object's off-surface voxels meet the
// other's volume; the lateral pairs by their frames. Fidelity: no frame where the fidelity volumes
// meet. Visibility: each cone meets the other's whole body.
void SweepRun::plan_stages() {
    const SweepObject& A = problem_.a;
    const SweepObject& B = problem_.b;
    ColumnJobs jobs(share_, tools_.stats.fixed_volumes_built);
    const bool frames_of_interest = type_.lateral_pair() && (type_.variant == 'a' || type_.variant == 'b');
    const std::size_t interest_a = jobs.add_fixed("interest", [&] { return columns_of(A.interest, z_, frames_of_interest); });
    const std::size_t interest_b = jobs.add([&] { return columns_of(B.interest, z_b_, frames_of_interest); });
    std::vector<PlannedTest> planned{{0, interest_a, interest_b, 0, Want::Overlap}};
    const int last = last_, tolerance = problem_.tolerance;
    auto off_surface = [last, tolerance](const Amhv& volume, SurfaceLabel label, const ZFrame& z) {
        return [&volume, label, &z, last, tolerance] {
            return columns_where(volume, z, [&, label](std::size_t v) {
                return label == SurfaceLabel::Plus ? volume.t_end(v) < last - tolerance : volume.t_start(v) > tolerance;
            });
        };
    };
    if (!type_.lateral_pair()) {
        if (type_.a != SurfaceLabel::Lateral)
            planned.push_back({1, jobs.add_fixed("off surface", off_surface(A.interest, type_.a, z_)), interest_b, 0, Want::NoOverlap});
        if (type_.b != SurfaceLabel::Lateral) planned.push_back({1, interest_a, jobs.add(off_surface(B.interest, type_.b, z_b_)), 0, Want::NoOverlap});
    } else if (type_.variant == 'a') {
        planned.push_back({1, interest_a, interest_b, frames_, Want::Frames, problem_.touching_frames_needed()});
    } else if (type_.variant == 'b') {
        planned.push_back({1, interest_a, interest_b, frames_, Want::Overlap});
    } else {
        // (c) fails when some contact voxel has t_start^A <= t_end^B, i.e. when for some t the
        // voxels A has reached by t meet the voxels B still occupies at or after t.
        planned.push_back({1, jobs.add_fixed("started by", [&] { return columns_cumulative(A.interest, z_, true); }),
                           jobs.add([&] { return columns_cumulative(B.interest, z_b_, false); }), frames_, Want::NoOverlap});
    }
    planned.push_back({2, jobs.add_fixed("fidelity", [&] { return columns_of(A.fidelity, z_, true); }),
                       jobs.add([&] { return columns_of(B.fidelity, z_b_, true); }), frames_, Want::NoOverlap});
    if (A.has_clearance())  // multi-party: the other placed objects never meet B's whole body
        planned.push_back({2, jobs.add_fixed("clearance", [&] { return columns_of(A.clearance, z_, true); }),
                           jobs.add([&] { return columns_of(B.whole, z_b_, true); }), frames_, Want::NoOverlap});
    if (problem_.per_frame_visibility()) {
        // Each cone at frame t against the other's body at frame t, on enough frames.
        const int needed = problem_.visibility_frames;
        planned.push_back({3, jobs.add_fixed("cone frames", [&] { return columns_of(A.view_cone, z_, true); }),
                           jobs.add([&] { return columns_of(B.whole, z_b_, true); }), frames_, Want::Frames, needed});
        planned.push_back({3, jobs.add_fixed("whole frames", [&] { return columns_of(A.whole, z_, true); }),
                           jobs.add([&] { return columns_of(B.view_cone, z_b_, true); }), frames_, Want::Frames, needed});
    } else if (problem_.visibility) {
        planned.push_back({3, jobs.add_fixed("cone", [&] { return columns_of(A.view_cone, z_); }),
                           jobs.add([&] { return columns_of(B.whole, z_b_, false); }), 0, Want::Overlap});
        planned.push_back({3, jobs.add_fixed("whole", [&] { return columns_of(A.whole, z_, false); }),
                           jobs.add([&] { return columns_of(B.view_cone, z_b_); }), 0, Want::Overlap});
    }
    std::vector<GpuVolume*> volumes;
    for (GpuVolume* volume : jobs.run([this](ColumnVolume columns) { return add(std::move(columns)); })) volumes.push_back(volume);
    interest_a_ = volumes[interest_a];
    interest_b_ = volumes[interest_b];
    for (const PlannedTest& test : planned)
        stages_[std::size_t(test.stage)].push_back({volumes[test.fixed], volumes[test.moving], test.frames, test.want, test.needed});
}

// Overlap maps (SweeperOptions::maps): tests decided for every offset of an angle at once from
// slice runs. `required_maps_` replace the stage's pose tests: contact, and the dictionary's
// lateral types and surface test. `optional_maps_` are the stage's pose tests as maps; a batch
// uses them when its poses in that stage would cost more pose by pose (the cost model).
void SweepRun::plan_maps() {
    std::vector<int> every_frame(static_cast<std::size_t>(frames_));
    for (int t = 0; t < frames_; ++t) every_frame[std::size_t(t)] = 1 + t;
    auto map_test = [](const ColumnVolume& fixed, const ColumnVolume& moving, std::vector<int> slots, Want want, int needed = 0) {
        return MapTest{&fixed, &moving, std::move(slots), want, nullptr, nullptr, {}, 0, 0, {}, needed};
    };
    auto map_of = [&](const OverlapTest& test) {
        std::vector<int> slots{0};
        if (test.frames > 0) slots = every_frame;
        return map_test(test.fixed->columns, test.moving->columns, slots, test.want, test.needed);
    };
    required_maps_[0].push_back(map_of(stages_[0].front()));
    if (!type_.lateral_pair()) {
        // A pose in contact passes a labelled type only if the labelled surfaces (for a '0', the
        // whole part) meet, since all its contact voxels lie on them. The surfaces are small, so
        // this necessary test is cheap and leaves few poses for the exact ones.
        const int last = last_, tolerance = problem_.tolerance;
        auto on_surface = [&](const Amhv& volume, SurfaceLabel label, const ZFrame& z) {
            return columns_where(volume, z, [&, label](std::size_t v) {
                return label == SurfaceLabel::Plus ? volume.t_end(v) >= last - tolerance : volume.t_start(v) <= tolerance;
            });
        };
        const ColumnVolume& surface_a = type_.a == SurfaceLabel::Lateral
                                            ? interest_a_->columns
                                            : shared_fixed("on surface", [&] { return on_surface(problem_.a.interest, type_.a, z_); })->columns;
        const ColumnVolume& surface_b =
            type_.b == SurfaceLabel::Lateral ? interest_b_->columns : add(on_surface(problem_.b.interest, type_.b, z_b_))->columns;
        required_maps_[1].push_back(map_test(surface_a, surface_b, {0}, Want::Overlap));
        for (const OverlapTest& test : stages_[1]) optional_maps_[1].push_back(map_of(test));
    } else if (type_.variant == 'a' || type_.variant == 'b') {
        required_maps_[1].push_back(map_of(stages_[1].front()));
    } else {
        // (c): the voxels A has reached by t meet those B still occupies at or after t for some t
        // exactly when they meet those B occupies at t itself for some t (take t = t_end^B of the
        // shared voxel); single frames of B give far fewer runs.
        required_maps_[1].push_back(
            map_test(stages_[1].front().fixed->columns, add(columns_of(problem_.b.interest, z_b_, true))->columns, every_frame, Want::NoOverlap));
    }
    for (int stage = 2; stage < 4; ++stage)
        for (const OverlapTest& test : stages_[std::size_t(stage)]) optional_maps_[std::size_t(stage)].push_back(map_of(test));
    std::vector<MapTest*> tests;
    for (auto* all : {&required_maps_, &optional_maps_})
        for (auto& stage : *all)
            for (MapTest& test : stage) tests.push_back(&test);
    cut_map_volumes(tests);
    for (MapTest* test : tests) prepare_map(*test);
}

GpuVolume* SweepRun::shared_fixed(const std::string& name, const std::function<ColumnVolume()>& build) {
    std::unique_ptr<GpuVolume>& shared = share_.fixed[name];
    return shared ? shared.get() : HeightShare::keep(shared, build(), tools_.stats.fixed_volumes_built);
}

void SweepRun::cut_map_volumes(const std::vector<MapTest*>& tests) {
    // The runs are plain functions of the volumes, cut on all cores: A's once for every height.
    std::vector<MapTest*> first_cuts;
    for (MapTest* test : tests) {
        if (!share_.holds(test->fixed)) fail("sweep", "internal: a map's fixed volume is not A's shared one");
        std::unique_ptr<FixedSide>& side = share_.fixed_sides[{test->fixed, test->slots}];
        if (!side) side = std::make_unique<FixedSide>(), first_cuts.push_back(test);
        test->fixed_side = side.get();
    }
    parallel_for(first_cuts.size(), [&](std::size_t k) { first_cuts[k]->fixed_side->runs = fixed_runs(*first_cuts[k]->fixed, first_cuts[k]->slots); });
    // With several heights, the pruning reads A's runs lowered over them (once per count of heights).
    std::vector<MapTest*> first_reaches;
    for (MapTest* test : tests) {
        if (heights_ == 1) {
            test->reach = &test->runs();
            continue;
        }
        auto [entry, added] = test->fixed_side->reach_by_heights.try_emplace(heights_);
        if (added) first_reaches.push_back(test);
        test->reach = &entry->second;
    }
    parallel_for(first_reaches.size(), [&](std::size_t k) {
        MapTest& test = *first_reaches[k];
        FixedRuns reach = fixed_runs(lowered_union(*test.fixed, heights_), test.slots);
        reach.runs = {};  // the prune reads its boxes and hulls only
        test.fixed_side->reach_by_heights[heights_] = std::move(reach);
    });
    parallel_for(tests.size(), [&](std::size_t k) {
        tests[k]->moving_words = sparse_columns(*tests[k]->moving, tests[k]->slots);
        tests[k]->z_phase = densest_shared_slice(tests[k]->runs(), tests[k]->moving_words);
    });
}

void SweepRun::prepare_map(MapTest& test) {
    // Packed (y, x_first | x_last << 16) relative to the volume's origin.
    if (test.fixed->nx > 0xffff || test.fixed->ny > 0xffff)
        fail("key segment", "a volume {} x {} columns wide is more than the sweep handles (65,535); use a larger voxel", test.fixed->nx,
             test.fixed->ny);
    // The map kernel reads the fixed runs as texels, one a run.
    if (test.runs().runs.size() > tools_.context.selected().max_texel_buffer_elements)
        fail("key segment", "{} slice runs are more than the device's texel buffers hold ({} texels, one a run); use a larger voxel",
             test.runs().runs.size(), tools_.context.selected().max_texel_buffer_elements);
    // Pulled runs are cut to word_clips, which start here or later for every angle and row (a word's
    // runs lie in the volume's occupied columns).
    test.pulled_x0 = std::int32_t(test.fixed->x0) + test.fixed->x_first - range_.i_last;
    if (test.fixed_side->packed) return;  // uploaded by an earlier height's run
    std::vector<std::array<std::uint32_t, 2>> packed;
    packed.reserve(test.runs().runs.size());
    for (const SliceRun& run : test.runs().runs)
        packed.push_back({std::uint32_t(run.y - test.fixed->y0),
                          std::uint32_t(run.x_first - test.fixed->x0) | std::uint32_t(run.x_last - test.fixed->x0) << 16});
    FixedSide& side = *test.fixed_side;
    side.packed = upload_for_kernels(tools_.context, packed.data(), packed.size() * 8);
    side.keys = upload_for_kernels(tools_.context, side.runs.by_key.data(), side.runs.by_key.size() * 8);
}

void SweepRun::upload_angle_tables() {
    Context& context = tools_.context;
    for_each_test([&](const OverlapTest& test) {
        if (test.fixed->columns.slots != test.moving->columns.slots) fail("sweep", "internal: slot counts differ in one test");
    });
    if (heights_ > 1) return;  // only pose tests read them
    for_each_test([&](const OverlapTest& test) {
        if (test.moving->angles) return;
        std::vector<std::uint8_t> table(32 + std::size_t(range_.angles) * sizeof(GpuAngle));
        std::int64_t roots[4] = {root_a_[0], root_a_[1], root_b_[0], root_b_[1]};
        std::memcpy(table.data(), roots, sizeof(roots));
        for (int k = 0; k < range_.angles; ++k) {
            GpuAngle angle{{trig_[std::size_t(k)].cos_q, trig_[std::size_t(k)].sin_q}, {}};
            auto bounds = mapped_bounds(test.moving->columns, trig_[std::size_t(k)], root_a_, root_b_);
            std::copy(bounds.begin(), bounds.end(), angle.bounds);
            std::memcpy(table.data() + 32 + std::size_t(k) * sizeof(GpuAngle), &angle, sizeof(angle));
        }
        test.moving->angles = upload_for_kernels(context, table.data(), table.size());
    });
    for_each_test([&](const OverlapTest& test) {
        if (test.want != Want::Frames) return;
        if (!test.fixed->frame_boxes) {
            const auto& boxes = test.fixed->columns.slot_boxes;
            test.fixed->frame_boxes = upload_for_kernels(context, boxes.data() + 1, (boxes.size() - 1) * 16);
        }
        if (!test.moving->angle_frame_boxes) {
            const ColumnVolume& m = test.moving->columns;
            std::vector<std::array<std::int32_t, 4>> boxes;
            for (int k = 0; k < range_.angles; ++k)
                for (int t = 0; t < m.frames(); ++t)
                    boxes.push_back(mapped_bounds(m, m.slot_boxes[std::size_t(1 + t)], trig_[std::size_t(k)], root_a_, root_b_));
            test.moving->angle_frame_boxes = upload_for_kernels(context, boxes.data(), boxes.size() * 16);
        }
    });
}

// Batches of angles: at most max_poses_per_batch poses, rounded up to whole rounds of angles over
// the cores (and, with one round per core, to balanced_rounds of them within max_balanced_poses),
// and no more than the map bytes a batch may hold (one bit per offset, a row of words
// per j, per angle and map). Pose-by-pose dispatches take a batch in slices (poses_per_dispatch).
void SweepRun::size_batches() {
    const SweeperOptions& options = tools_.options;
    const std::uint64_t max_poses = std::max<std::uint64_t>(1, options.max_poses_per_batch);
    if (per_angle_ > max_poses) fail("sweep", "one angle has {} poses, more than a batch of {}; narrow the x/y range", per_angle_, max_poses);
    row_words_ = (width_ + 31) / 32;
    std::uint64_t maps_per_angle = 0;
    for (const auto* all : {&required_maps_, &optional_maps_})
        for (const auto& stage : *all)
            for (const MapTest& test : stage) maps_per_angle = std::max<std::uint64_t>(maps_per_angle, std::uint64_t(test.maps_per_angle()));
    const std::uint64_t map_bytes_per_angle = maps_per_angle * std::uint64_t(heights_) * std::uint64_t(height_) * std::uint64_t(row_words_) * 4;
    const std::uint64_t max_map_bytes = std::min<std::uint64_t>(options.max_map_bytes, tools_.context.selected().max_storage_buffer_range);
    if (map_bytes_per_angle > max_map_bytes)
        fail("sweep", "the overlap maps of one angle need {} bytes, more than the {} a batch may hold; narrow the x/y range", map_bytes_per_angle,
             max_map_bytes);
    const bool per_core = options.angles_per_core_round <= 0;
    const std::uint64_t round = per_core ? core_count() : std::uint64_t(options.angles_per_core_round);
    const std::uint64_t poses_per_angle = per_angle_ * std::uint64_t(heights_);
    std::uint64_t batch_limit = (max_poses / poses_per_angle + round - 1) / round * round;
    if (per_core) {
        // Several rounds over the cores, as far as the balanced poses allow (whole rounds, one at least).
        const std::uint64_t rounds_in_poses = std::max<std::uint64_t>(1, options.max_balanced_poses / poses_per_angle / round);
        batch_limit = std::max(batch_limit, round * std::min<std::uint64_t>(std::uint64_t(std::max(1, options.balanced_rounds)), rounds_in_poses));
    }
    if (map_bytes_per_angle > 0) batch_limit = std::min(batch_limit, max_map_bytes / map_bytes_per_angle);
    angles_per_batch_ = int(std::max<std::uint64_t>(1, batch_limit));
    if (width_ > 0xffff || height_ > 0xffff)
        fail("sweep", "a range of {} x {} offsets is more than the sweep handles (65,535 per side); narrow it", width_, height_);
}

}  // namespace amhv::gpu::sweep_detail
