// B2 - placement sweep throughput at 10 mm / 2 degrees on a human-sized two-person scene: CMU
// subjects 18 and 19 (capsule bodies, 1.8 m), a 48-frame key segment, the shipped handshake scene
// (data/scenes/handshake.toml: right hands, 0&0 (a), fidelity on everything but the right arms,
// mutual visibility) and a variant with the whole right forearm and hand as interest under +&+.
// The Vulkan path sweeps all 180 angles; the single-threaded CPU reference sweeps a sample of
// angles spread evenly over the circle in the same run, and its throughput gives the estimated
// full-sweep time. Reports poses/s
// and seconds per full segment sweep, with mean, median and spread over repetitions.
//
//   build/tools/amhv_bench_sweep [--benchmark_filter=vulkan/0]
// (each run sets its own 3 repetitions, which --benchmark_repetitions does not override)
#include <chrono>
#include <map>
#include <memory>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include "src/sweep/sweep_vulkan.hpp"
#include "src/voxelise/voxelise_vulkan.hpp"
#include "host/reference/sweep_reference.hpp"
#include "src/scene/segment.hpp"

namespace {

using namespace amhv;

gpu::Context& context() {
    static gpu::Context instance;
    return instance;
}

// 0: the shipped handshake; 1: forearm and hand under +&+ (attack and guard), no visibility.
const SweepProblem& problem(int variant) {
    static std::map<int, SweepProblem> cache;
    if (auto it = cache.find(variant); it != cache.end()) return it->second;
    Scene scene = load_scene(std::string(AMHV_SOURCE_DIR) + "/data/scenes/handshake.toml");
    KeySegment segment = scene.segments.front();
    if (variant == 1) {
        segment.type = parse_interaction_type("+&+", "bench");
        segment.visibility.enabled = false;
        segment.interest_a.labels = segment.interest_b.labels = {"right_forearm", "right_hand"};
    }
    ObjectSource a(scene.a), b(scene.b);
    gpu::VulkanVoxeliser voxeliser(context());
    return cache.emplace(variant, build_segment(scene, segment, a, b, voxeliser).problem).first->second;
}

std::string describe_problem(const SweepProblem& p) {
    return fmt::format("{} | {} frames | {}x{} offsets x {} angles", p.type.name(), p.frames(), p.range.width(), p.range.height(),
                       p.range.angles);
}

void B2_sweep_vulkan(benchmark::State& state) {
    const SweepProblem& p = problem(int(state.range(0)));
    gpu::VulkanSweeper sweeper(context());
    std::uint64_t solutions = 0;
    for (auto _ : state) solutions = sweeper.sweep(p).solutions;
    state.counters["poses/s"] = benchmark::Counter(double(p.range.size()), benchmark::Counter::kIsIterationInvariantRate);
    state.counters["solutions"] = double(solutions);
    const auto& stats = sweeper.last_stats();
    const char* names[] = {"contact", "dictionary", "fidelity", "visibility"};
    for (int s = 0; s < 4; ++s) {
        state.counters[fmt::format("{}_s", names[s])] = stats.seconds_per_stage[std::size_t(s)];
        state.counters[fmt::format("{}_poses", names[s])] = double(stats.poses_per_stage[std::size_t(s)]);
        state.counters[fmt::format("{}_blocks", names[s])] = double(stats.blocks_per_stage[std::size_t(s)]);
        state.counters[fmt::format("{}_pose_tests", names[s])] = double(stats.pose_tests_per_stage[std::size_t(s)]);
        state.counters[fmt::format("{}_run_pairs", names[s])] = double(stats.run_pairs_per_stage[std::size_t(s)]);
    }
    state.SetLabel(fmt::format("{} | {} | full sweep", sweeper.name(), describe_problem(p)));
}

constexpr int kReferenceAngles = 6;

void B2_sweep_cpu_reference(benchmark::State& state) {
    const SweepProblem& p = problem(int(state.range(0)));
    ReferenceSweeper sweeper;
    const double sampled = double(p.range.size()) * kReferenceAngles / p.range.angles;
    double seconds = 0;
    for (auto _ : state) {
        auto start = std::chrono::steady_clock::now();
        // Angles spread evenly over the circle: contact (and the cost of a pose) varies with the angle.
        for (int n = 0; n < kReferenceAngles; ++n) {
            auto result = sweeper.sweep_angles(p, n * p.range.angles / kReferenceAngles, 1);
            benchmark::DoNotOptimize(result.solutions);
        }
        seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    state.counters["poses/s"] = benchmark::Counter(sampled, benchmark::Counter::kIsIterationInvariantRate);
    // Estimated time of the full sweep, from the sampled angles' throughput.
    state.counters["full_sweep_s"] = seconds / double(state.iterations()) * double(p.range.angles) / kReferenceAngles;
    state.SetLabel(fmt::format("{} | {} | {} of {} angles, evenly spread", sweeper.name(), describe_problem(p), kReferenceAngles, p.range.angles));
}

// Argument: scene variant (0 handshake, 1 forearm guard).
BENCHMARK(B2_sweep_vulkan)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(3)->UseRealTime();
BENCHMARK(B2_sweep_cpu_reference)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(3)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
