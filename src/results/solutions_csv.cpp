#include "src/results/solutions_csv.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <string>

#include <fmt/format.h>

#include "src/core/error.hpp"
#include "src/core/parallel.hpp"
#include "src/io/files.hpp"

namespace amhv {

void write_solutions_csv(const std::filesystem::path& path, const std::vector<Solution>& solutions) {
    std::ofstream out(path, std::ios::binary);
    if (!out) fail(path.string(), "cannot create the file");
    out << kSolutionsHeader << '\n';
    // Groups of millions of solutions: chunks are formatted on all cores, then written in order.
    constexpr std::size_t kChunk = 1 << 16;
    const std::size_t chunks = (solutions.size() + kChunk - 1) / kChunk;
    constexpr std::size_t kInFlight = 16;  // chunks formatted at once: bounded memory
    std::vector<std::string> text(kInFlight);
    for (std::size_t first = 0; first < chunks; first += kInFlight) {
        const std::size_t count = std::min(kInFlight, chunks - first);
        parallel_for(count, [&](std::size_t c) {
            auto& buffer = text[c];
            const std::size_t begin = (first + c) * kChunk, end = std::min(solutions.size(), begin + kChunk);
            buffer.clear();
            // std::to_chars prints the correctly rounded "%.6f", like fmt, several times faster.
            constexpr int kRoom = 330;  // the longest fixed-point double with 6 decimals, and a separator
            char line[7 * kRoom];
            for (std::size_t i = begin; i < end; ++i) {
                const Solution& s = solutions[i];
                const double values[] = {s.x, s.y, s.z, s.theta_deg, s.distance, s.theta_a_deg, s.theta_b_deg};
                char* at = line;
                for (int v = 0; v < 7; ++v) {
                    at = std::to_chars(at, at + kRoom - 1, values[v], std::chars_format::fixed, 6).ptr;
                    *at++ = v < 6 ? ',' : '\n';
                }
                buffer.append(line, std::size_t(at - line));
            }
        });
        for (std::size_t c = 0; c < count; ++c) out.write(text[c].data(), std::streamsize(text[c].size()));
    }
    finish_file(out, path);
}

std::vector<Solution> read_solutions_csv(const std::filesystem::path& path, double voxel, const angles::AngleLattice& lattice) {
    std::ifstream rows(path);
    if (!rows) fail(path.string(), "cannot open the solution group");
    std::vector<Solution> solutions;
    std::string line;
    int number = 0;
    while (std::getline(rows, line)) {
        ++number;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        if (number == 1) {
            if (line != kSolutionsHeader) fail(path.string() + ":1", "expected the header {}", kSolutionsHeader);
            continue;
        }
        if (line.empty()) continue;
        // Seven comma-separated numbers (std::from_chars: exact, and far faster than streams on
        // groups of millions of rows).
        Solution sol;
        double* fields[] = {&sol.x, &sol.y, &sol.z, &sol.theta_deg, &sol.distance, &sol.theta_a_deg, &sol.theta_b_deg};
        const char* at = line.data();
        const char* end = line.data() + line.size();
        bool ok = true;
        for (int f = 0; f < 7 && ok; ++f) {
            while (at < end && *at == ' ') ++at;
            const auto [next, error] = std::from_chars(at, end, *fields[f]);
            ok = error == std::errc() && (f < 6 ? next < end && *next == ',' : next == end);
            at = next + 1;
        }
        if (!ok || !std::isfinite(sol.x + sol.y + sol.z + sol.theta_deg)) fail(fmt::format("{}:{}", path.string(), number), "expected seven numbers");
        // The file's edge: metres and degrees back to the lattice.
        sol.i = int(std::lround(std::clamp(sol.x / voxel, -1e9, 1e9)));
        sol.j = int(std::lround(std::clamp(sol.y / voxel, -1e9, 1e9)));
        sol.l = int(std::lround(std::clamp(sol.z / voxel, -1e9, 1e9)));
        sol.k = lattice.index_of_degrees(sol.theta_deg);
        if (angles::degrees_apart(sol.theta_deg, lattice.wrapped_degrees(sol.k)) > 2e-6)
            fail(fmt::format("{}:{}", path.string(), number), "theta {} deg is not on the sweep's {} deg steps", sol.theta_deg, lattice.step_deg);
        sol.theta_deg = lattice.wrapped_degrees(sol.k);  // as the sweep wrote it, from the index
        solutions.push_back(sol);
    }
    return solutions;
}

}  // namespace amhv
