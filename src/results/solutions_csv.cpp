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

void write_solutions_csv(const std::filesystem::path& path, const SolutionGroup& group, const PoseDescriber& describe) {
    std::ofstream out(path, std::ios::binary);
    if (!out) fail(path.string(), "cannot create the file");
    out << kSolutionsHeader << '\n';
    // Groups of millions of solutions: chunks are formatted on all cores, then written in order.
    constexpr std::size_t kChunk = 1 << 16;
    const std::size_t chunks = std::size_t((group.size() + kChunk - 1) / kChunk);
    constexpr std::size_t kInFlight = 16;  // chunks formatted at once: bounded memory
    std::vector<std::string> text(kInFlight);
    for (std::size_t first = 0; first < chunks; first += kInFlight) {
        const std::size_t count = std::min(kInFlight, chunks - first);
        parallel_for(count, [&](std::size_t c) {
            auto& buffer = text[c];
            const std::uint64_t begin = (first + c) * kChunk, end = std::min<std::uint64_t>(group.size(), begin + kChunk);
            buffer.clear();
            // std::to_chars prints the correctly rounded "%.6f", like fmt, several times faster.
            constexpr int kRoom = 330;  // the longest fixed-point double with 6 decimals, and a separator
            char line[7 * kRoom];
            group.for_range(begin, end, [&](const PoseIndex& pose) {
                const Solution s = describe(pose);
                const double values[] = {s.x, s.y, s.z, s.theta_deg, s.distance, s.theta_a_deg, s.theta_b_deg};
                char* at = line;
                for (int v = 0; v < 7; ++v) {
                    at = std::to_chars(at, at + kRoom - 1, values[v], std::chars_format::fixed, 6).ptr;
                    *at++ = v < 6 ? ',' : '\n';
                }
                buffer.append(line, std::size_t(at - line));
            });
        });
        for (std::size_t c = 0; c < count; ++c) out.write(text[c].data(), std::streamsize(text[c].size()));
    }
    finish_file(out, path);
}

}  // namespace amhv
