#include "src/pipeline/solutions_export.hpp"

#include <algorithm>
#include <fstream>
#include <map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "src/core/angles.hpp"
#include "src/core/error.hpp"
#include "src/results/solutions_csv.hpp"

namespace amhv::pipeline {

namespace fs = std::filesystem;

namespace {

// A's and B's facings from the segment's entry in result.json (what describe() needs).
SweepProblem facings_of(const fs::path& dir, int segment, const results::GroupLattice& lattice) {
    const fs::path file = dir / "result.json";
    std::ifstream in(file);
    if (!in) fail(file.string(), "cannot open: `amhv solutions` reads an output folder of `amhv sweep` or `amhv edit`");
    SweepProblem problem;
    problem.voxel = lattice.voxel;
    problem.angle_step_deg = lattice.angle_step_deg;
    try {
        const nlohmann::json json = nlohmann::json::parse(in);
        for (const auto& s : json.at("segments"))
            if (s.at("index").get<int>() == segment) {
                const auto fa = s.at("facing").at("A").get<std::array<double, 2>>(), fb = s.at("facing").at("B").get<std::array<double, 2>>();
                problem.a.facing = Eigen::Vector2d(fa[0], fa[1]);
                problem.b.facing = Eigen::Vector2d(fb[0], fb[1]);
                return problem;
            }
    } catch (const nlohmann::json::exception& e) {
        fail(file.string(), "is not a sweep's result.json ({})", e.what());
    }
    fail(file.string(), "has no key segment {}", segment);
}

}  // namespace

GroupRead read_group(const fs::path& dir, int segment) {
    const fs::path file = dir / fmt::format("segment_{}", segment) / "group.vdb";
    GroupRead group;
    group.lattice = results::read_group_lattice(file);
    if (group.lattice.segment != segment) fail(file.string(), "holds the group of key segment {}, not {}", group.lattice.segment, segment);
    const SweepProblem problem = facings_of(dir, segment, group.lattice);
    for (const auto& [i, j, k, l] : results::read_group_vdb(file, group.lattice)) group.solutions.push_back(describe(problem, i, j, k, l));
    group.file_bytes = fs::file_size(file);
    return group;
}

std::string group_report(const GroupRead& group) {
    const results::GroupLattice& lattice = group.lattice;
    std::string out = fmt::format("key segment {}: {} solutions on the {} m / {} deg lattice (group.vdb, {} bytes)\n", lattice.segment,
                                  group.solutions.size(), lattice.voxel, lattice.angle_step_deg, group.file_bytes);
    if (group.solutions.empty()) return out;
    auto span = [&](auto value) {
        const auto [lo, hi] = std::minmax_element(group.solutions.begin(), group.solutions.end(), [&](const Solution& a, const Solution& b) { return value(a) < value(b); });
        return fmt::format("[{:.3f}, {:.3f}]", value(*lo), value(*hi));
    };
    out += fmt::format("x {} m, y {} m, z {} m\n", span([](const Solution& s) { return s.x; }), span([](const Solution& s) { return s.y; }),
                       span([](const Solution& s) { return s.z; }));
    std::map<int, std::uint64_t> per_angle;
    for (const Solution& s : group.solutions) ++per_angle[s.k];
    const angles::AngleLattice angle_lattice{lattice.angle_step_deg, lattice.angles};
    out += "theta_deg  solutions\n";
    for (const auto& [k, count] : per_angle) out += fmt::format("{:>9g}  {}\n", angle_lattice.wrapped_degrees(k), count);
    return out;
}

void export_group_csv(const GroupRead& group, const fs::path& path) {
    if (fs::exists(fs::symlink_status(path))) fail(path.string(), "exists: amhv does not overwrite a file it did not create");
    const fs::path partial = path.parent_path() / (".partial-" + path.filename().string());
    if (fs::exists(fs::symlink_status(partial))) fail(partial.string(), "exists: remove it (a run that stopped) or write elsewhere");
    // The sweep's rows come out of it sorted by (z, theta, y, x): the same order.
    std::vector<Solution> rows = group.solutions;
    std::stable_sort(rows.begin(), rows.end(), [](const Solution& a, const Solution& b) { return std::tie(a.l, a.k, a.j, a.i) < std::tie(b.l, b.k, b.j, b.i); });
    try {
        write_solutions_csv(partial, rows);
    } catch (...) {
        std::error_code ignored;
        fs::remove(partial, ignored);
        throw;
    }
    fs::rename(partial, path);
}

}  // namespace amhv::pipeline
