#include "src/pipeline/solutions_export.hpp"

#include <algorithm>
#include <array>
#include <climits>
#include <fstream>
#include <map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "src/core/angles.hpp"
#include "src/core/budget.hpp"
#include "src/core/error.hpp"
#include "src/results/solutions_csv.hpp"
#include "src/io/files.hpp"
#include "src/io/json_problem.hpp"

namespace amhv::pipeline {

namespace fs = std::filesystem;

namespace {

// A's and B's facings from the segment's entry in result.json (what describe() needs).
PoseDescriber facings_of(const fs::path& dir, int segment, const results::GroupLattice& lattice) {
    const fs::path file = dir / "result.json";
    if (!fs::exists(file)) fail(file.string(), "cannot open: `amhv solutions` reads an output folder of `amhv sweep` or `amhv edit`");
    const std::string text = read_file_bytes(file, std::uintmax_t(1) << 30);
    PoseDescriber describe;
    describe.voxel = lattice.voxel;
    describe.angle_step_deg = lattice.angle_step_deg;
    try {
        const nlohmann::json json = nlohmann::json::parse(text);
        for (const auto& s : json.at("segments"))
            if (json_integer<int>(s.at("index")) == segment) {
                const auto fa = s.at("facing").at("A").get<std::array<double, 2>>(), fb = s.at("facing").at("B").get<std::array<double, 2>>();
                describe.facing_a = Eigen::Vector2d(fa[0], fa[1]);
                describe.facing_b = Eigen::Vector2d(fb[0], fb[1]);
                return describe;
            }
    } catch (const nlohmann::json::exception& e) {
        fail(file.string(), "is not a sweep's result.json ({})", json_problem(e));
    }
    fail(file.string(), "has no key segment {}", segment);
}

}  // namespace

GroupRead read_group(const fs::path& dir, int segment) {
    const fs::path file = dir / fmt::format("segment_{}", segment) / "group.vdb";
    GroupRead group;
    group.lattice = results::read_group_lattice(file);
    if (group.lattice.segment != segment) fail(file.string(), "holds the group of key segment {}, not {}", group.lattice.segment, segment);
    group.describe = facings_of(dir, segment, group.lattice);
    group.group = results::read_group_vdb(file, group.lattice);
    group.file_bytes = fs::file_size(file);
    return group;
}

std::string group_report(const GroupRead& group) {
    const results::GroupLattice& lattice = group.lattice;
    std::string out = fmt::format("key segment {}: {} solutions on the {} m / {} deg lattice (group.vdb, {} bytes)\n", lattice.segment,
                                  group.group.size(), lattice.voxel, lattice.angle_step_deg, group.file_bytes);
    if (group.group.empty()) return out;
    std::array<int, 2> i{INT_MAX, INT_MIN}, j = i, l = i;
    std::map<int, std::uint64_t> per_angle;
    for (const PoseRun& r : group.group.runs()) {
        i = {std::min(i[0], r.i_first), std::max(i[1], r.i_last)};
        j = {std::min(j[0], r.j), std::max(j[1], r.j)};
        l = {std::min(l[0], r.l), std::max(l[1], r.l)};
        per_angle[r.k] += r.size();
    }
    const double h = lattice.voxel;
    const auto span = [h](const std::array<int, 2>& v) { return fmt::format("[{:.3f}, {:.3f}]", v[0] * h, v[1] * h); };
    out += fmt::format("x {} m, y {} m, z {} m\n", span(i), span(j), span(l));
    const angles::AngleLattice angle_lattice{lattice.angle_step_deg, lattice.angles};
    out += "theta_deg  solutions\n";
    for (const auto& [k, count] : per_angle) out += fmt::format("{:>9g}  {}\n", angle_lattice.wrapped_degrees(k), count);
    return out;
}

void export_group_csv(const GroupRead& group, const fs::path& path) {
    if (fs::exists(fs::symlink_status(path))) fail(path.string(), "exists: amhv does not overwrite a file it did not create");
    const fs::path partial = path.parent_path() / (".partial-" + path.filename().string());
    if (fs::exists(fs::symlink_status(partial))) fail(partial.string(), "exists: remove it (a run that stopped) or write elsewhere");
    // A row is at most about 100 characters: the whole file must fit the disk before a byte is
    // written (a crafted group of billions of members is refused here, not after filling the disk).
    budget::require_disk(path.parent_path().empty() ? fs::path(".") : path.parent_path(), group.group.size() * 100,
                         fmt::format("{} ({} solutions)", path.string(), group.group.size()), "write fewer solutions or free some disk");
    // The group is held in the sweep's order (z, theta, y, x): the rows come out as the sweep writes them.
    try {
        write_solutions_csv(partial, group.group, group.describe);
    } catch (...) {
        std::error_code ignored;
        fs::remove(partial, ignored);
        throw;
    }
    fs::rename(partial, path);
}

}  // namespace amhv::pipeline
