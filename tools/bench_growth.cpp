// B4 (docs/benchmarks.md): how the sweep's cost grows with the sampling. One run sweeps one key
// segment of a scene at one voxel size and angle step (Vulkan, the device amhv picks) and prints
// one CSV row: the sampling, poses, solutions, the volumes' and the sweep's seconds per stage, the
// sweeper's counters and the process's peak resident memory. tools/bench_growth.sh runs it over a
// grid of samplings, one process each (so each peak is its own), and draws the plot with --plot.
//
//   build/tools/amhv_bench_growth SCENE SEGMENT VOXEL_M ANGLE_STEP_DEG
//   build/tools/amhv_bench_growth --header
//   build/tools/amhv_bench_growth --plot TABLE.csv OUT.png
//
// Per stage figures (seconds, poses, maps, runs cut, pulled runs, run pairs, blocks, pose tests) go to stderr.
// For trying the sweeper's settings: AMHV_MAP_PASSES, AMHV_POSE_TEST_PAIRS, AMHV_POSES_PER_BATCH and
// AMHV_ANGLES_PER_ROUND set SweeperOptions::map_passes, ::pose_test_pairs, ::max_poses_per_batch and
// ::angles_per_core_round.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <cairo.h>
#include <fmt/format.h>

#include "src/core/clock.hpp"
#include "src/core/error.hpp"
#include "src/core/process.hpp"
#include "src/scene/segment.hpp"
#include "src/sweep/sweep_vulkan.hpp"
#include "src/voxelise/voxelise_vulkan.hpp"

namespace {

using namespace amhv;

constexpr const char* kHeader =
    "voxel_m,angle_step_deg,poses,solutions,mhv_s,sweep_s,contact_s,dictionary_s,fidelity_s,visibility_s,"
    "run_pairs,pose_tests,pulled_runs,submits,peak_mib";

// VmHWM of this process, in MiB.
double peak_mib() {
    std::ifstream status("/proc/self/status");
    std::string line;
    while (std::getline(status, line))
        if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
    return 0;
}

int measure(const std::string& scene_file, int segment, double voxel, double step) {
    Scene scene = load_scene(scene_file);
    if (segment < 1 || segment > int(scene.segments.size())) fail(scene_file, "no key segment {}", segment);
    scene.sampling.voxel = voxel;
    scene.sampling.angle_step_deg = step;
    gpu::Context context;
    ObjectSource a(scene.a), b(scene.b);
    gpu::VulkanVoxeliser voxeliser(context);
    auto start = std::chrono::steady_clock::now();
    const SweepProblem problem = build_segment(scene, scene.segments[std::size_t(segment - 1)], a, b, voxeliser).problem;
    const double mhv = seconds_since(start);
    gpu::SweeperOptions options;
    if (const char* passes = std::getenv("AMHV_MAP_PASSES")) options.map_passes = std::atoi(passes);
    if (const char* pairs = std::getenv("AMHV_POSE_TEST_PAIRS")) options.pose_test_pairs = std::atof(pairs);
    if (const char* poses = std::getenv("AMHV_POSES_PER_BATCH")) options.max_poses_per_batch = std::strtoull(poses, nullptr, 10);
    if (const char* round = std::getenv("AMHV_ANGLES_PER_ROUND")) options.angles_per_core_round = std::atoi(round);
    gpu::VulkanSweeper sweeper(context, options);
    start = std::chrono::steady_clock::now();
    const SweepResult result = sweeper.sweep(problem);
    const double sweep = seconds_since(start);
    const gpu::SweepStats& s = sweeper.last_stats();
    std::uint64_t pairs = 0, tests = 0, pulled = 0;
    for (int k = 0; k < 4; ++k) {
        pairs += s.run_pairs_per_stage[std::size_t(k)];
        tests += s.pose_tests_per_stage[std::size_t(k)];
        pulled += s.pulled_runs_per_stage[std::size_t(k)];
    }
    // Per stage, for reading where the time goes (stderr: the table stays one row).
    const char* names[] = {"contact", "dictionary", "fidelity", "visibility"};
    for (int k = 0; k < 4; ++k)
        std::cerr << fmt::format("{:>10}: {:7.3f} s, {} poses, {} maps, {} runs cut, {} pulled runs, {} run pairs, {} blocks, {} pose tests\n",
                                 names[k], s.seconds_per_stage[std::size_t(k)], s.poses_per_stage[std::size_t(k)], s.maps_per_stage[std::size_t(k)],
                                 s.runs_cut_per_stage[std::size_t(k)], s.pulled_runs_per_stage[std::size_t(k)], s.run_pairs_per_stage[std::size_t(k)],
                                 s.blocks_per_stage[std::size_t(k)], s.pose_tests_per_stage[std::size_t(k)]);
    std::cerr << fmt::format("waiting for the device: {:.3f} s of {:.3f} s, {} submits, {} batches\n", s.device_wait_seconds, sweep, s.submits,
                             s.batches);
    std::cout << fmt::format("{},{},{},{},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{},{},{},{},{:.0f}\n", voxel, step, problem.range.size(),
                             result.solutions, mhv, sweep, s.seconds_per_stage[0], s.seconds_per_stage[1], s.seconds_per_stage[2],
                             s.seconds_per_stage[3], pairs, tests, pulled, s.submits, peak_mib());
    return 0;
}

struct Row {
    double voxel, step, sweep, peak;
};

std::vector<Row> read_table(const std::string& file) {
    std::ifstream in(file);
    if (!in) fail(file, "cannot be read");
    std::string line;
    std::getline(in, line);
    if (line != kHeader) fail(file, "line 1: not a table of amhv_bench_growth");
    std::vector<Row> rows;
    for (int number = 2; std::getline(in, line); ++number) {
        std::vector<std::string> cells;
        std::stringstream cut(line);
        for (std::string cell; std::getline(cut, cell, ',');) cells.push_back(cell);
        if (cells.size() != 15) fail(file, "line {}: {} cells, not 15", number, cells.size());
        Row row{};
        double* fields[] = {&row.voxel, &row.step, &row.sweep, &row.peak};
        const std::size_t columns[] = {0, 1, 5, 14};
        for (int f = 0; f < 4; ++f) {
            std::size_t used = 0;
            const std::string& cell = cells[columns[f]];
            try {
                *fields[f] = std::stod(cell, &used);
            } catch (const std::exception&) {
                used = 0;
            }
            if (used == 0 || used != cell.size() || !std::isfinite(*fields[f]) || *fields[f] <= 0)
                fail(file, "line {}: cell {} is \"{}\", not a positive number", number, columns[f] + 1, cell);
        }
        rows.push_back(row);
    }
    if (rows.empty()) fail(file, "no rows");
    return rows;
}

// One panel: a quantity against the voxel size (log-log), one line per angle step.
void draw_panel(cairo_t* cr, double x0, double y0, double w, double h, const std::vector<Row>& rows, bool memory) {
    const auto value = [&](const Row& r) { return memory ? r.peak / 1024.0 : r.sweep; };
    double lo = 1e30, hi = 0, vmin = 1e30, vmax = 0;
    for (const Row& r : rows) lo = std::min(lo, value(r)), hi = std::max(hi, value(r)), vmin = std::min(vmin, r.voxel), vmax = std::max(vmax, r.voxel);
    lo = std::pow(10.0, std::floor(std::log10(lo))), hi = std::pow(10.0, std::ceil(std::log10(hi)));
    const double left = x0 + 60, right = x0 + w - 10, top = y0 + 30, bottom = y0 + h - 45;
    // Voxel size grows to the left (finer to the right), as a user reads "finer costs more".
    const auto px = [&](double v) { return left + (std::log(vmax) - std::log(v)) / (std::log(vmax) - std::log(vmin)) * (right - left); };
    const auto py = [&](double q) { return bottom - (std::log(q) - std::log(lo)) / (std::log(hi) - std::log(lo)) * (bottom - top); };
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 1);
    cairo_rectangle(cr, left, top, right - left, bottom - top);
    cairo_stroke(cr);
    cairo_set_font_size(cr, 12);
    cairo_move_to(cr, left, y0 + 18);
    cairo_show_text(cr, memory ? "peak resident memory (GiB)" : "sweep time (s)");
    for (double q = lo; q <= hi * 1.001; q *= 10) {
        cairo_move_to(cr, x0 + 8, py(q) + 4);
        cairo_show_text(cr, fmt::format("{:g}", q).c_str());
        cairo_set_source_rgb(cr, 0.85, 0.85, 0.85);
        cairo_move_to(cr, left, py(q));
        cairo_line_to(cr, right, py(q));
        cairo_stroke(cr);
        cairo_set_source_rgb(cr, 0, 0, 0);
    }
    std::map<double, std::vector<Row>> by_step;
    for (const Row& r : rows) by_step[r.step].push_back(r);
    std::vector<double> voxels;
    for (const Row& r : rows)
        if (std::find(voxels.begin(), voxels.end(), r.voxel) == voxels.end()) voxels.push_back(r.voxel);
    for (const double v : voxels) {
        cairo_move_to(cr, px(v) - 12, bottom + 16);
        cairo_show_text(cr, fmt::format("{:g}", v * 1000).c_str());
    }
    cairo_move_to(cr, left + (right - left) / 2 - 30, bottom + 34);
    cairo_show_text(cr, "voxel (mm)");
    const double colours[][3] = {{0.15, 0.35, 0.75}, {0.85, 0.45, 0.1}, {0.2, 0.6, 0.25}, {0.6, 0.2, 0.6}};
    int line = 0;
    for (auto& [step, points] : by_step) {
        std::sort(points.begin(), points.end(), [](const Row& a, const Row& b) { return a.voxel > b.voxel; });
        const double* c = colours[line % 4];
        cairo_set_source_rgb(cr, c[0], c[1], c[2]);
        cairo_set_line_width(cr, 2);
        for (std::size_t i = 0; i < points.size(); ++i) {
            if (i == 0) cairo_move_to(cr, px(points[i].voxel), py(value(points[i])));
            else cairo_line_to(cr, px(points[i].voxel), py(value(points[i])));
        }
        cairo_stroke(cr);
        for (const Row& p : points) {
            cairo_arc(cr, px(p.voxel), py(value(p)), 3.5, 0, 6.2832);
            cairo_fill(cr);
        }
        cairo_move_to(cr, left + 10, top + 18 + 16 * line);
        cairo_show_text(cr, fmt::format("{:g}° step", step).c_str());
        ++line;
    }
}

int plot(const std::string& table, const std::string& png) {
    const std::vector<Row> rows = read_table(table);
    cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_RGB24, 900, 380);
    cairo_t* cr = cairo_create(surface);
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
    draw_panel(cr, 0, 0, 450, 380, rows, false);
    draw_panel(cr, 450, 0, 450, 380, rows, true);
    cairo_destroy(cr);
    const cairo_status_t status = cairo_surface_write_to_png(surface, png.c_str());
    cairo_surface_destroy(surface);
    if (status != CAIRO_STATUS_SUCCESS) fail(png, "cannot be written: {}", cairo_status_to_string(status));
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    amhv::keep_freed_memory();  // as amhv itself
    try {
        const std::vector<std::string> args(argv + 1, argv + argc);
        if (args.size() == 1 && args[0] == "--header") {
            std::cout << kHeader << "\n";
            return 0;
        }
        if (args.size() == 3 && args[0] == "--plot") return plot(args[1], args[2]);
        if (args.size() == 4) return measure(args[0], std::stoi(args[1]), std::stod(args[2]), std::stod(args[3]));
        std::cerr << "usage: amhv_bench_growth SCENE SEGMENT VOXEL_M ANGLE_STEP_DEG | --header | --plot TABLE.csv OUT.png\n";
        return 2;
    } catch (const std::exception& e) {
        std::cerr << "amhv_bench_growth: " << e.what() << "\n";
        return 1;
    }
}
