#include "src/results/party_files.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "src/core/budget.hpp"
#include "src/io/files.hpp"
#include "src/io/ply_file.hpp"
#include "src/results/edit_files.hpp"

namespace amhv::results {

namespace fs = std::filesystem;

namespace {

std::string pair_name(const std::vector<std::string>& names, std::size_t i, std::size_t j) { return names[i] + "&" + names[j]; }

}  // namespace

void write_party_transforms_json(const fs::path& path, const Scene& scene, const std::vector<std::string>& names,
                                 const std::vector<std::vector<ObjectFrameEdit>>& frames) {
    nlohmann::ordered_json json;
    json["program"] = std::string("amhv ") + AMHV_VERSION;
    json["scene"] = scene.file.string();
    json["convention"] = "scene point = R(yaw) * capture point + (x, y, z): a turn about the vertical (z) axis, then a move on the floor (and z "
                         "up or down); metres, z up, yaw in degrees counter-clockwise; matrix is the same map, row-major 4x4";
    json["frames"] = frames.empty() ? 0 : frames.front().size();
    nlohmann::ordered_json objects;
    for (const std::string& name : names) {
        const SceneObject& o = scene.object(name);
        objects[name] = object_source_path(o);
    }
    json["objects"] = objects;
    json["order"] = names;
    nlohmann::ordered_json output = nlohmann::ordered_json::array();
    for (std::size_t k = 0; k < (frames.empty() ? 0 : frames.front().size()); ++k) {
        nlohmann::ordered_json f;
        f["frame"] = k;
        for (std::size_t o = 0; o < names.size(); ++o) f[names[o]] = frame_transform_json(frames[o][k]);
        output.push_back(f);
    }
    json["output"] = output;
    write_file(path, json.dump(1) + '\n');
}

void write_pair_checks_csv(const fs::path& path, const std::vector<std::string>& names, const std::vector<PairRow>& rows, double voxel) {
    std::string text = "frame,pair,overlap_voxels,overlap_cm3,gap_mm\n";
    const double voxel_cm3 = std::pow(voxel * 100, 3);
    for (const PairRow& r : rows)
        text += fmt::format("{},{},{},{:.3f},{}\n", r.frame, pair_name(names, r.first, r.second), r.overlap, double(r.overlap) * voxel_cm3,
                            r.gap_m ? fmt::format("{:.1f}", *r.gap_m * 1000) : std::string());
    write_file(path, text);
}

int write_party_frames(const fs::path& folder, const std::vector<std::string>& names, const std::vector<std::vector<ObjectFrameEdit>>& frames,
                       const std::vector<ObjectSource*>& sources) {
    fs::create_directories(folder);
    const int length = frames.empty() ? 0 : int(frames.front().size());
    for (int k = 0; k < length; ++k) {
        TriangleMesh all;
        std::vector<std::array<std::uint8_t, 3>> colours;
        std::vector<std::string> comments{fmt::format("amhv edit output frame {}", k)};
        for (std::size_t o = 0; o < names.size(); ++o) {
            const TriangleMesh mesh = placed_mesh(frames[o][std::size_t(k)], *sources[o]);
            const auto& colour = kObjectColours[o % kObjectColours.size()];
            comments.push_back(fmt::format("object {}: source frame {}, vertices {}..{}, faces {}..{}, colour {} {} {}", names[o],
                                           frames[o][std::size_t(k)].source, all.vertices.size(), all.vertices.size() + mesh.vertices.size() - 1,
                                           all.triangles.size(), all.triangles.size() + mesh.triangles.size() - 1, colour[0], colour[1], colour[2]));
            all.append(mesh);
            colours.resize(all.vertices.size(), colour);
        }
        if (k == 0) {
            const std::uint64_t bytes = (all.vertices.size() * 15 + all.triangles.size() * 13 + 1024) * std::uint64_t(length);
            budget::require_disk(folder, bytes + bytes / 2, fmt::format("frames/ ({} PLY files)", length), "free some disk or pass --no-frames");
        }
        write_ply(folder / fmt::format("{:04d}.ply", k), all, colours, comments);
    }
    return length;
}

Json pair_summary(const std::vector<std::string>& names, const std::vector<PairRow>& rows, double voxel) {
    Json out = Json::array();
    for (std::size_t i = 0; i < names.size(); ++i)
        for (std::size_t j = i + 1; j < names.size(); ++j) {
            int frames = 0, overlapping = 0;
            std::uint64_t largest = 0;
            std::optional<double> gap;
            for (const PairRow& r : rows) {
                if (r.first != i || r.second != j) continue;
                ++frames;
                overlapping += r.overlap > 0;
                largest = std::max(largest, r.overlap);
                if (r.gap_m) gap = std::min(gap.value_or(*r.gap_m), *r.gap_m);
            }
            out.push_back({{"pair", pair_name(names, i, j)}, {"frames", frames}, {"overlapping_frames", overlapping}, {"max_overlap_voxels", largest},
                           {"max_overlap_cm3", double(largest) * std::pow(voxel * 100, 3)},
                           {"min_gap_m", gap ? Json(*gap) : Json(nullptr)}});
        }
    return out;
}

}  // namespace amhv::results
