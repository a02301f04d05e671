#include "src/pipeline/import_stage.hpp"

#include <algorithm>
#include <array>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "src/io/files.hpp"
#include "src/io/ply_file.hpp"
#include "src/results/character_glb.hpp"

namespace amhv::pipeline {

namespace fs = std::filesystem;

namespace {

// One colour per body part so a viewer shows the parts apart (labels/ holds the names).
std::array<std::uint8_t, 3> part_colour(std::size_t index) {
    static const std::array<std::array<std::uint8_t, 3>, 12> palette{{{31, 119, 180}, {255, 127, 14}, {44, 160, 44}, {214, 39, 40},
                                                                      {148, 103, 189}, {140, 86, 75}, {227, 119, 194}, {127, 127, 127},
                                                                      {188, 189, 34}, {23, 190, 207}, {174, 199, 232}, {255, 187, 120}}};
    return palette[index % palette.size()];
}

}  // namespace

void import_bvh_into(const BvhMotion& motion, const std::string& bvh, const FrameRange& range, const SkeletonBodyOptions& options,
                     const fs::path& out) {
    const std::vector<TrackSample> track = skeleton_track(motion, options);
    const std::vector<std::string> part_names = body_part_names(motion, options.skinned != nullptr);
    fs::create_directories(out / "meshes");
    fs::create_directories(out / "labels");
    std::string csv = "# amhv import-bvh: frame, eye x y z, gaze x y z (metres, z up)\n";
    std::size_t vertices = 0, triangles = 0;
    for (int f = range.first; f <= range.last; ++f) {
        TriangleMesh body;
        std::vector<std::array<std::uint8_t, 3>> colours;
        std::string labels;
        for (const BodyPart& part : skeleton_body_parts(motion, f, options)) {
            const auto index = std::size_t(std::find(part_names.begin(), part_names.end(), part.name) - part_names.begin());
            body.append(part.mesh);
            colours.resize(body.vertices.size(), part_colour(index));
            for (std::size_t v = 0; v < part.mesh.vertices.size(); ++v) labels += part.name + '\n';
        }
        write_ply(out / fmt::format("meshes/frame_{:04d}.ply", f), body, colours,
                  {fmt::format("amhv import-bvh: {} frame {} ({:.4f} s), metres, z up; part labels in labels/frame_{:04d}.txt",
                               fs::path(bvh).filename().string(), f, f / motion.fps(), f)});
        write_file(out / fmt::format("labels/frame_{:04d}.txt", f), labels);
        const TrackSample& t = track[std::size_t(f)];
        csv += fmt::format("{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", f, t.eye.x(), t.eye.y(), t.eye.z(), t.gaze.x(), t.gaze.y(), t.gaze.z());
        vertices = std::max(vertices, body.vertices.size());
        triangles = std::max(triangles, body.triangles.size());
    }
    write_file(out / "track.csv", csv);
    // The skinned human as an animated character (frame 0 of its animation is frame range.first).
    if (options.skinned) write_character_glb(skinned_body_animation(*options.skinned, motion, range, options.units), out / "character.glb");
    write_file(out / "object.toml",
               fmt::format("# amhv import-bvh of {}: an object table for a scene ([objects.A] or [objects.B]).\n"
                           "# Paths are relative to this folder: prefix them with its path relative to the scene file.\n"
                           "meshes = \"meshes/frame_%04d.ply\"\nlabels = \"labels/frame_%04d.txt\"\ntrack = \"track.csv\"\n"
                           "unit = \"m\"\nup = \"z\"\nfps = {}\nframes = [{}, {}]\n",
                           fs::path(bvh).filename().string(), motion.fps(), range.first, range.last));
    nlohmann::ordered_json json;
    json["source"] = bvh;
    json["fps"] = motion.fps();
    json["tpose_skipped"] = motion.first_frame > 0;
    json["frames"] = {range.first, range.last};
    json["metres_per_unit"] = options.units.metres_per_unit;
    json["up"] = std::string(1, "xyz"[int(options.units.up)]);
    json["parts"] = part_names;
    if (options.skinned) json["character"] = "character.glb";
    json["vertices_per_frame"] = vertices;
    json["triangles_per_frame"] = triangles;
    write_file(out / "import.json", json.dump(2) + '\n');
}

}  // namespace amhv::pipeline
