#include "src/pipeline/shard_stage.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <map>

#include <fstream>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <zlib.h>

#include "src/core/clock.hpp"
#include "src/core/error.hpp"
#include "src/io/files.hpp"
#include "src/results/group_vdb.hpp"

namespace amhv::pipeline {

namespace fs = std::filesystem;

namespace {

std::string own_program() { return std::string("amhv ") + AMHV_VERSION; }

std::string manifest_path(const fs::path& folder) { return (folder / results::kShardManifestFile).string(); }

// A whole number in [1, 2^31), or -1.
int positive_int(std::string_view text) {
    int value = 0;
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
    return error == std::errc() && end == text.data() + text.size() && value > 0 ? value : -1;
}

int slurm_variable(const char* name) {
    const char* value = std::getenv(name);
    if (!value)
        fail("--shard", "no K/N given and {} is not set (outside a Slurm job array, say --shard K/N)", name);
    const int n = positive_int(value);
    if (n < 0 && std::string_view(value) != "0") fail("--shard", "{}={} is not a whole number", name, printable(value));
    return std::max(n, 0);
}

// The array task's place in its array, from 1 (arrays may count from 0 or any first id).
int slurm_shard_index() {
    const int id = slurm_variable("SLURM_ARRAY_TASK_ID");
    const int first = std::getenv("SLURM_ARRAY_TASK_MIN") ? slurm_variable("SLURM_ARRAY_TASK_MIN") : 1;
    return id - first + 1;
}

std::uint32_t file_crc(const fs::path& path) {
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) fail(path.string(), "is not a regular file");
    std::ifstream in(path, std::ios::binary);
    if (!in) fail(path.string(), "cannot open the file");
    std::vector<char> buffer(std::size_t(1) << 20);
    auto crc = std::uint32_t(crc32(0, nullptr, 0));
    while (in) {
        in.read(buffer.data(), std::streamsize(buffer.size()));
        crc = std::uint32_t(crc32(crc, reinterpret_cast<const Bytef*>(buffer.data()), uInt(in.gcount())));
    }
    if (in.bad()) fail(path.string(), "reading the file failed");
    return crc;
}

// A file's size; a file removed or replaced since it was listed is one clear line, not an exception.
std::uintmax_t size_of(const fs::path& path) {
    std::error_code error;
    const std::uintmax_t size = fs::file_size(path, error);
    if (error) fail(path.string(), "cannot read its size: {}", error.message());
    return size;
}

// "name size time;" of every file in `folder`, by name.
std::string folder_listing(const fs::path& folder) {
    std::vector<std::string> lines;
    std::error_code error;
    for (fs::directory_iterator it(folder, error), end; !error && it != end; it.increment(error)) {
        if (!it->is_regular_file(error)) continue;
        const auto written = it->last_write_time(error);
        if (error) break;
        lines.push_back(fmt::format("{} {} {};", it->path().filename().string(), size_of(it->path()), written.time_since_epoch().count()));
    }
    if (error) fail(folder.string(), "cannot list the folder: {}", error.message());
    std::sort(lines.begin(), lines.end());
    return fmt::format("{}", fmt::join(lines, ""));
}

results::ShardManifest manifest_header(const Scene& scene, const Backends& backends, ShardIndex shard) {
    results::ShardManifest m;
    m.program = own_program();
    m.scene = scene.file.string();
    m.scene_hash = results::scene_hash(scene);
    m.inputs = inputs_fingerprint(scene);
    m.voxel = scene.sampling.voxel;
    m.angle_step_deg = scene.sampling.angle_step_deg;
    m.angles = scene.sampling.angles();
    m.index = shard.index;
    m.count = shard.count;
    m.backend = backends.backend;
    m.device = backends.device;
    return m;
}

bool same_poses(const PoseRange& a, const PoseRange& b) {
    return a.i_first == b.i_first && a.i_last == b.i_last && a.j_first == b.j_first && a.j_last == b.j_last && a.z_first == b.z_first &&
           a.z_last == b.z_last && a.angles == b.angles;
}

std::string range_text(const PoseRange& r) {
    return fmt::format("i {}..{}, j {}..{}, z {}..{}, {} angles", r.i_first, r.i_last, r.j_first, r.j_last, r.z_first, r.z_last, r.angles);
}

// Key segment `segment`'s outcomes from the shards that swept its angles; adds their sweep seconds.
SweepResult gather_outcomes(const ShardSet& set, const KeySegment& segment, const SweepProblem& problem, double& sweep_seconds) {
    SweepResult result;
    result.range = problem.range;
    result.outcomes.assign(problem.range.size(), PoseOutcome::FailsContact);
    for (std::size_t s = 0; s < set.shards.size(); ++s)
        for (const results::ShardPieceRecord& record : set.shards[s].pieces) {
            if (record.piece.segment != segment.index) continue;
            if (!same_poses(record.range, problem.range))
                fail(manifest_path(set.folders[s]), "key segment {} was swept over poses {} where the scene's volumes now give {}: the inputs changed since (sweep the shards again)",
                     segment.index, range_text(record.range), range_text(problem.range));
            results::read_piece_outcomes(set.folders[s], record, result);
            sweep_seconds += record.sweep_seconds;
        }
    result.count();
    return result;
}

// "a" when every shard ran on a, else "a, b" in shard order.
template <typename Field>
std::string shards_agree(const ShardSet& set, Field field) {
    std::vector<std::string> seen;
    for (const results::ShardManifest& m : set.shards)
        if (std::find(seen.begin(), seen.end(), field(m)) == seen.end()) seen.push_back(field(m));
    return fmt::format("{}", fmt::join(seen, ", "));
}

results::Json shard_timings(const ShardSet& set) {
    results::Json per_shard = results::Json::array();
    double sum = 0, longest = 0, memory = 0;
    for (const results::ShardManifest& m : set.shards) {
        per_shard.push_back({{"index", m.index}, {"total", m.total_seconds}, {"peak_memory_mb", m.peak_memory_mb}});
        sum += m.total_seconds;
        longest = std::max(longest, m.total_seconds);
        memory = std::max(memory, m.peak_memory_mb);
    }
    return {{"count", set.shards.size()}, {"seconds", sum}, {"longest_s", longest}, {"peak_memory_mb", memory}, {"per_shard", per_shard}};
}

}  // namespace

std::string inputs_fingerprint(const Scene& scene) {
    std::string text;
    const std::vector<fs::path> inputs = scene_inputs(scene);
    // Paths relative to the scene's folder: the same scene mounted elsewhere has the same fingerprint.
    const fs::path folder = scene.file.parent_path();
    for (auto input = inputs.begin() + 1; input != inputs.end(); ++input) {  // the TOML itself is the scene hash
        const std::string name = fs::absolute(*input).lexically_relative(folder).string();
        if (is_file(*input)) text += fmt::format("{} {} {:08x}\n", name, size_of(*input), file_crc(*input));
        else if (is_folder(*input)) text += fmt::format("{}/ {}\n", name, folder_listing(*input));
    }
    return fmt::format("{:08x}", std::uint32_t(crc32(crc32(0, nullptr, 0), reinterpret_cast<const Bytef*>(text.data()), uInt(text.size()))));
}

std::uint64_t angle_cost(const Scene& scene, const KeySegment& segment) {
    const std::uint64_t frames = std::uint64_t(std::max(segment.a[1] - segment.a[0], segment.b[1] - segment.b[0]) + 1);
    std::uint64_t heights = 1;
    if (segment.z_range) {
        const double h = scene.sampling.voxel;
        const auto first = std::ceil((*segment.z_range)[0] / h - 1e-9), last = std::floor((*segment.z_range)[1] / h + 1e-9);
        heights = std::uint64_t(std::max(1.0, last - first + 1));
    }
    return frames * heights * (segment.visibility.enabled ? 2 : 1);
}

std::vector<ShardWork> plan_shards(const Scene& scene, int count) {
    const int angles = scene.sampling.angles();
    const std::uint64_t units = std::uint64_t(angles) * scene.segments.size();
    if (count < 1 || std::uint64_t(count) > units)
        fail("--shard", "{} shards of a scene with {} key segment angles: give 1 to {}", count, units, units);
    std::uint64_t total = 0;
    for (const KeySegment& segment : scene.segments) total += angle_cost(scene, segment) * std::uint64_t(angles);
    // Each angle goes to the shard its cost's midpoint falls in: contiguous shards of about
    // total / count each, decided in integers so that every reader cuts alike.
    std::vector<ShardWork> shards(static_cast<std::size_t>(count));
    std::uint64_t before = 0;
    for (const KeySegment& segment : scene.segments) {
        const std::uint64_t cost = angle_cost(scene, segment);
        for (int k = 0; k < angles; ++k, before += cost) {
            const auto shard = std::min<std::uint64_t>(std::uint64_t(count) - 1, (2 * before + cost) * std::uint64_t(count) / (2 * total));
            ShardWork& work = shards[shard];
            if (!work.empty() && work.back().segment == segment.index && work.back().first_angle + work.back().angle_count == k)
                ++work.back().angle_count;
            else
                work.push_back({segment.index, k, 1});
        }
    }
    return shards;
}

ShardIndex parse_shard(const std::string& text) {
    const auto slash = text.find('/');
    if (!text.empty() && slash == std::string::npos) fail("--shard", "'{}' is not K/N (shard K of N, e.g. 3/8)", printable(text));
    const std::string k_text = text.empty() ? "" : text.substr(0, slash), n_text = text.empty() ? "" : text.substr(slash + 1);
    ShardIndex shard;
    shard.count = n_text.empty() ? slurm_variable("SLURM_ARRAY_TASK_COUNT") : positive_int(n_text);
    shard.index = k_text.empty() ? slurm_shard_index() : positive_int(k_text);
    if (shard.count < 1 || shard.index < 1 || shard.index > shard.count)
        fail("--shard", "'{}' is no shard: K/N with 1 <= K <= N (from Slurm: {} of {})", printable(text), shard.index, shard.count);
    return shard;
}

results::ShardManifest sweep_shard(const Scene& scene, Backends& backends, const fs::path& out, ShardIndex shard, bool timings,
                                   std::chrono::steady_clock::time_point start) {
    const std::vector<ShardWork> plan = plan_shards(scene, shard.count);
    results::ShardManifest manifest = manifest_header(scene, backends, shard);
    ObjectSource a(scene.a, backends.skinner), b(scene.b, backends.skinner);
    for (const results::ShardPiece& piece : plan[std::size_t(shard.index - 1)]) {
        const KeySegment& segment = scene.segments[std::size_t(piece.segment - 1)];
        SegmentBuild build = build_segment(scene, segment, a, b, backends.voxeliser);
        build.problem.first_angle = piece.first_angle;
        build.problem.angle_count = piece.angle_count;
        const auto t0 = std::chrono::steady_clock::now();
        const SweepResult result = backends.sweeper.sweep(build.problem);
        results::ShardPieceRecord record;
        record.piece = piece;
        record.sweep_seconds = seconds_since(t0);
        results::write_piece_outcomes(out, result, record);
        std::cout << fmt::format("shard {}/{}: segment {} ({}) angles {}..{}: {} solutions among {} poses ({:.2f} s sweep)\n", shard.index,
                                 shard.count, segment.index, segment.type.name(), piece.first_angle, piece.first_angle + piece.angle_count - 1,
                                 result.solutions, record.poses, record.sweep_seconds);
        manifest.pieces.push_back(std::move(record));
    }
    manifest.timed = timings;
    manifest.total_seconds = seconds_since(start);
    manifest.peak_memory_mb = results::peak_memory_mb();
    results::write_shard_manifest(out, manifest);
    return manifest;
}

ShardSet read_shard_set(const std::vector<fs::path>& folders) {
    if (folders.empty()) fail("amhv merge", "no shard folders given");
    ShardSet set;
    std::map<int, std::size_t> by_index;
    for (std::size_t n = 0; n < folders.size(); ++n) {
        results::ShardManifest m = results::read_shard_manifest(folders[n]);
        const results::ShardManifest& first = set.shards.empty() ? m : set.shards.front();
        const std::string where = manifest_path(folders[n]);
        if (m.program != own_program()) fail(where, "was written by {}, this is {}: sweep the shards again with one program", m.program, own_program());
        if (m.scene != first.scene || m.scene_hash != first.scene_hash || m.inputs != first.inputs)
            fail(where, "is a shard of {} (scene hash {}, inputs {}), {} one of {} ({}, {}): merge the shards of one scene", m.scene, m.scene_hash,
                 m.inputs, folders.front().string(), first.scene, first.scene_hash, first.inputs);
        if (m.count != first.count)
            fail(where, "is shard {} of {}, {} is shard {} of {}: merge the shards of one plan", m.index, m.count, folders.front().string(), first.index,
                 first.count);
        if (const auto seen = by_index.find(m.index); seen != by_index.end())
            fail(where, "is shard {} of {} again: {} holds it too (give each shard once)", m.index, m.count, folders[seen->second].string());
        by_index[m.index] = n;
        set.shards.push_back(std::move(m));
    }
    const int count = set.shards.front().count;
    for (int k = 1; k <= count; ++k)
        if (!by_index.count(k)) fail("amhv merge", "shard {} of {} is missing (given {} of the {} shard folders)", k, count, folders.size(), count);
    ShardSet ordered;
    for (const auto& [index, n] : by_index) {
        ordered.folders.push_back(folders[n]);
        ordered.shards.push_back(std::move(set.shards[n]));
    }
    return ordered;
}

void check_shard_set(const ShardSet& set, const Scene& scene) {
    const results::ShardManifest& first = set.shards.front();
    if (results::scene_hash(scene) != first.scene_hash)
        fail(scene.file.string(), "has changed since the shards were swept (scene hash {} now, {} in the shards): sweep them again", results::scene_hash(scene),
             first.scene_hash);
    if (inputs_fingerprint(scene) != first.inputs)
        fail(scene.file.string(), "its input files (takes, meshes, labels, tracks) have changed since the shards were swept: sweep them again");
    const std::vector<ShardWork> plan = plan_shards(scene, first.count);
    for (std::size_t s = 0; s < set.shards.size(); ++s) {
        const results::ShardManifest& m = set.shards[s];
        ShardWork pieces;
        for (const results::ShardPieceRecord& record : m.pieces) pieces.push_back(record.piece);
        if (pieces != plan[std::size_t(m.index - 1)] || m.voxel != scene.sampling.voxel || m.angle_step_deg != scene.sampling.angle_step_deg)
            fail(manifest_path(set.folders[s]), "does not hold the key segments and angles of shard {} of {} of this scene: sweep it again", m.index,
                 m.count);
    }
}

SweepStage merge_shards(const Scene& scene, const ShardSet& set, Voxeliser& voxeliser, const fs::path& out, const SweepStageOptions& options,
                        std::chrono::steady_clock::time_point start) {
    ObjectSource a(scene.a), b(scene.b);
    SweepStage stage;
    for (const KeySegment& segment : scene.segments) {
        results::Json timings;
        const auto t0 = std::chrono::steady_clock::now();
        const SegmentBuild build = build_segment(scene, segment, a, b, voxeliser);
        timings["mhv"] = seconds_since(t0);
        double sweep_seconds = 0;
        const SweepResult result = gather_outcomes(set, segment, build.problem, sweep_seconds);
        timings["sweep"] = sweep_seconds;
        finish_segment(scene, segment, build.problem, result, out, options, std::move(timings), stage);
    }
    results::Json json = results::result_header(scene, shards_agree(set, [](const auto& m) { return m.backend; }),
                                                shards_agree(set, [](const auto& m) { return m.device; }));
    json["segments"] = stage.segments;
    const bool shards_timed = std::all_of(set.shards.begin(), set.shards.end(), [](const auto& m) { return m.timed; });
    if (options.timings) {
        json["timings_s"] = {{"total", seconds_since(start)}};
        if (shards_timed) json["timings_s"]["shards"] = shard_timings(set);
    }
    results::write_json_file(out / "result.json", json);
    return stage;
}

}  // namespace amhv::pipeline
