// B1 - voxelisation throughput on a human-sized mesh sequence: 120 frames of CMU subject 18
// (walking into a handshake, 120 fps) as capsule bodies (about 5.2k triangles per frame), at 10 mm and
// 5 mm, on the Vulkan device amhv picks (lavapipe on CI machines) and with the single-threaded CPU
// reference in the same run. Reports frames/s and voxel-frames/s (grid voxels x frames per second)
// with mean, median and spread over repetitions.
//
// B1c - the same 120 frames as the shipped character (data/characters/cmu_18_01.glb, the CC0 human
// driven by 18_01, about 16k vertices): voxelising the frames skinned and posed beforehand
// (quantised and voxelised), against skinning them on the device (VulkanSkinner), posing the
// parts, quantising and voxelising, at 10 mm and 5 mm.
//
// The repetitions of all four runs go in random interleaved order (Google Benchmark's
// --benchmark_enable_random_interleaving, on by default here): the VMs this runs on change speed
// in phases of tens of seconds, and run one after another the Vulkan path and the reference would
// meet different phases, so their ratio would measure the VM as much as the code.
//
//   build/tools/amhv_bench_voxelise [--benchmark_filter=vulkan/10] [--benchmark_enable_random_interleaving=false]
// (each run sets its own 9 repetitions, which --benchmark_repetitions does not override)
#include <cstdio>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include "src/body/character_body.hpp"
#include "src/body/skeleton_body.hpp"
#include "src/body/skin_vulkan.hpp"
#include "src/core/grid.hpp"
#include "src/voxelise/voxelise.hpp"
#include "src/voxelise/voxelise_vulkan.hpp"
#include "src/io/bvh.hpp"
#include "host/reference/voxelise_reference.hpp"

namespace {

using namespace amhv;

const MeshSequence& human_sequence() {
    static MeshSequence sequence = [] {
        BvhMotion motion = read_bvh(std::string(AMHV_SOURCE_DIR) + "/data/cmu/18_01.bvh");
        return skeleton_body_sequence(motion, {1, 120}, {});
    }();
    return sequence;
}

gpu::Context& context() {
    static gpu::Context instance;
    return instance;
}

void report(benchmark::State& state, const VoxelisationInput& input, const std::string& label) {
    const double frames = double(input.frames.size());
    state.counters["frames/s"] = benchmark::Counter(frames, benchmark::Counter::kIsIterationInvariantRate);
    state.counters["voxel_frames/s"] =
        benchmark::Counter(frames * double(input.grid.voxel_count()), benchmark::Counter::kIsIterationInvariantRate);
    std::size_t triangles = 0;
    for (const auto& f : input.frames) triangles += f.triangles.size();
    state.counters["triangles/frame"] = double(triangles) / frames;
    state.SetLabel(fmt::format("{} | grid {}x{}x{}", label, input.grid.dims[0], input.grid.dims[1], input.grid.dims[2]));
}

// Two untimed calls before the timed ones, for either backend: the first pays one-off costs
// (lavapipe's first dispatches, page faults of the voxeliser's scratch and of the aMHV's pages it
// writes). The second gets the first call's aMHV memory back (core/amhv.hpp keeps the last large
// volume freed) and clears all of it, faulting in the pages the first call did not write (about
// 4 000 at 10 mm). From the third call on no page is faulted in.
void warm_up(const VoxelisationInput& input, Voxeliser& voxeliser) {
    for (int call = 0; call < 2; ++call) voxelise(input, voxeliser);
}

void B1_voxelise_vulkan(benchmark::State& state) {
    auto input = prepare_voxelisation(human_sequence(), double(state.range(0)) / 1000.0);
    gpu::VulkanVoxeliser voxeliser(context());
    warm_up(input, voxeliser);
    for (auto _ : state) {
        Amhv volume = voxelise(input, voxeliser);
        benchmark::DoNotOptimize(volume.mask().data());
    }
    report(state, input, voxeliser.name());
}

void B1_voxelise_cpu_reference(benchmark::State& state) {
    auto input = prepare_voxelisation(human_sequence(), double(state.range(0)) / 1000.0);
    ReferenceVoxeliser voxeliser;
    warm_up(input, voxeliser);
    for (auto _ : state) {
        Amhv volume = voxelise(input, voxeliser);
        benchmark::DoNotOptimize(volume.mask().data());
    }
    report(state, input, voxeliser.name());
}

// The shipped character, frames 1..120 (the take's 1..120 as the capsule bodies above), in the
// scene's axes (glTF: y up).
struct CharacterFrames {
    std::shared_ptr<const CharacterBody> body;
    UnitsAndAxes units{1.0, UpAxis::Y};
    std::vector<SkinFrame> palettes;
};

const CharacterFrames& character_frames() {
    static CharacterFrames frames = [] {
        CharacterFrames c;
        auto file = std::make_shared<const CharacterFile>(
            read_character(std::string(AMHV_SOURCE_DIR) + "/data/characters/cmu_18_01.glb", std::nullopt, std::nullopt));
        c.body = build_character_body(file);
        for (int f = 1; f <= 120; ++f) c.palettes.push_back(skin_frame(*file, f, c.units));
        return c;
    }();
    return frames;
}

// Each frame's parts as one mesh (every part is closed: the non-zero winding rule takes the union).
std::vector<MeshFrame> posed_frames(const std::vector<float>& skinned) {
    const CharacterFrames& c = character_frames();
    const std::size_t n = character_skin(*c.body).count();
    std::vector<MeshFrame> out(c.palettes.size());
    for (std::size_t f = 0; f < out.size(); ++f) {
        out[f].source = fmt::format("character frame {}", f + 1);
        for (const BodyPart& part : character_body_parts(*c.body, skinned_points(skinned, n, f, c.palettes[f]), int(f + 1))) out[f].mesh.append(part.mesh);
    }
    return out;
}

VoxelGrid character_grid(const std::vector<MeshFrame>& frames, double voxel) {
    Box3 bounds;
    for (const MeshFrame& f : frames) bounds.extend(f.mesh.bounds());
    return grid_covering(bounds, voxel, "character");
}

std::vector<const MeshFrame*> pointers(const std::vector<MeshFrame>& frames) {
    std::vector<const MeshFrame*> out;
    for (const MeshFrame& f : frames) out.push_back(&f);
    return out;
}

void B1c_character_voxelise_vulkan(benchmark::State& state) {
    const CharacterFrames& c = character_frames();
    std::vector<float> skinned;
    CpuSkinner().skin(character_skin(*c.body), c.palettes, skinned);
    const std::vector<MeshFrame> frames = posed_frames(skinned);
    const VoxelGrid grid = character_grid(frames, double(state.range(0)) / 1000.0);
    gpu::VulkanVoxeliser voxeliser(context());
    VoxelisationInput input;
    auto quantise_and_voxelise = [&] {
        input = prepare_voxelisation(pointers(frames), grid);
        return voxelise(input, voxeliser);
    };
    for (int call = 0; call < 2; ++call) quantise_and_voxelise();
    for (auto _ : state) {
        Amhv volume = quantise_and_voxelise();
        benchmark::DoNotOptimize(volume.mask().data());
    }
    report(state, input, voxeliser.name() + " (quantised, voxelised)");
}

void B1c_character_skin_and_voxelise_vulkan(benchmark::State& state) {
    const CharacterFrames& c = character_frames();
    std::vector<float> skinned;
    CpuSkinner().skin(character_skin(*c.body), c.palettes, skinned);
    const VoxelGrid grid = character_grid(posed_frames(skinned), double(state.range(0)) / 1000.0);
    gpu::VulkanSkinner skinner(context());
    gpu::VulkanVoxeliser voxeliser(context());
    VoxelisationInput input;
    auto skin_and_voxelise = [&] {
        skinner.skin(character_skin(*c.body), c.palettes, skinned);
        const std::vector<MeshFrame> frames = posed_frames(skinned);
        input = prepare_voxelisation(pointers(frames), grid);
        return voxelise(input, voxeliser);
    };
    for (int call = 0; call < 2; ++call) skin_and_voxelise();
    for (auto _ : state) {
        Amhv volume = skin_and_voxelise();
        benchmark::DoNotOptimize(volume.mask().data());
    }
    report(state, input, skinner.name() + " (skinned, posed, quantised, voxelised)");
}

// Arguments: voxel edge in millimetres.
BENCHMARK(B1c_character_voxelise_vulkan)->Arg(10)->Arg(5)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(9)->UseRealTime();
BENCHMARK(B1c_character_skin_and_voxelise_vulkan)->Arg(10)->Arg(5)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(9)->UseRealTime();
BENCHMARK(B1_voxelise_vulkan)->Arg(10)->Arg(5)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(9)->UseRealTime();
BENCHMARK(B1_voxelise_cpu_reference)->Arg(10)->Arg(5)->Unit(benchmark::kMillisecond)->Iterations(1)->Repetitions(9)->UseRealTime();

}  // namespace

int main(int argc, char** argv) try {
    // Interleaving first, so that a flag given on the command line (parsed later) wins.
    std::string interleave = "--benchmark_enable_random_interleaving=true";
    std::vector<char*> arguments{argv[0], interleave.data()};
    arguments.insert(arguments.end(), argv + 1, argv + argc);
    int count = int(arguments.size());
    benchmark::Initialize(&count, arguments.data());
    if (benchmark::ReportUnrecognizedArguments(count, arguments.data())) return 1;
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "amhv_bench_voxelise: %s\n", e.what());
    return 1;
}
