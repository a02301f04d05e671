// `amhv import-bvh`: a BVH take as files other tools (and scenes) read: the body mesh per frame,
// its per-vertex part labels, the view track, and a scene snippet that uses them.
#include <algorithm>
#include <fstream>
#include <iostream>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "src/body/skeleton_body.hpp"
#include "src/cli/bvh_options.hpp"
#include "src/cli/commands.hpp"
#include "src/core/error.hpp"
#include "src/io/bvh.hpp"
#include "src/io/files.hpp"
#include "src/io/output_dir.hpp"
#include "src/io/ply_file.hpp"

namespace amhv::cli {

namespace {

namespace fs = std::filesystem;

struct ImportArguments {
    std::string bvh, out, frames, unit, up;
    BvhArguments bvh_options;
};

// One colour per body part so a viewer shows the parts apart (labels/ holds the names).
std::array<std::uint8_t, 3> part_colour(std::size_t index) {
    static const std::array<std::array<std::uint8_t, 3>, 12> palette{{{31, 119, 180}, {255, 127, 14}, {44, 160, 44}, {214, 39, 40},
                                                                      {148, 103, 189}, {140, 86, 75}, {227, 119, 194}, {127, 127, 127},
                                                                      {188, 189, 34}, {23, 190, 207}, {174, 199, 232}, {255, 187, 120}}};
    return palette[index % palette.size()];
}

void run_import(const ImportArguments& args) {
    SkeletonBodyOptions options;
    if (!args.unit.empty()) options.units.metres_per_unit = parse_unit(args.unit, "--unit");
    if (!args.up.empty()) options.units.up = parse_up_axis(args.up, "--up");
    const BvhMotion motion = load_bvh(args.bvh, bvh_load_options(args.bvh_options));
    const FrameRange range = bvh_frames(motion, args.frames);
    const std::vector<TrackSample> track = skeleton_track(motion, options);
    const std::vector<std::string> part_names = body_part_names(motion);

    StagedOutput out(args.out, {args.bvh});
    fs::create_directories(out.dir() / "meshes");
    fs::create_directories(out.dir() / "labels");
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
        write_ply(out.dir() / fmt::format("meshes/frame_{:04d}.ply", f), body, colours,
                  {fmt::format("amhv import-bvh: {} frame {} ({:.4f} s), metres, z up; part labels in labels/frame_{:04d}.txt",
                               fs::path(args.bvh).filename().string(), f, f / motion.fps(), f)});
        write_file(out.dir() / fmt::format("labels/frame_{:04d}.txt", f), labels);
        const TrackSample& t = track[std::size_t(f)];
        csv += fmt::format("{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", f, t.eye.x(), t.eye.y(), t.eye.z(), t.gaze.x(), t.gaze.y(), t.gaze.z());
        vertices = std::max(vertices, body.vertices.size());
        triangles = std::max(triangles, body.triangles.size());
    }
    write_file(out.dir() / "track.csv", csv);
    write_file(out.dir() / "object.toml",
               fmt::format("# amhv import-bvh of {}: an object table for a scene ([objects.A] or [objects.B]).\n"
                           "# Paths are relative to this folder: prefix them with its path relative to the scene file.\n"
                           "meshes = \"meshes/frame_%04d.ply\"\nlabels = \"labels/frame_%04d.txt\"\ntrack = \"track.csv\"\n"
                           "unit = \"m\"\nup = \"z\"\nfps = {}\nframes = [{}, {}]\n",
                           fs::path(args.bvh).filename().string(), motion.fps(), range.first, range.last));
    nlohmann::ordered_json json;
    json["source"] = args.bvh;
    json["fps"] = motion.fps();
    json["tpose_skipped"] = motion.first_frame > 0;
    json["frames"] = {range.first, range.last};
    json["metres_per_unit"] = options.units.metres_per_unit;
    json["up"] = std::string(1, "xyz"[int(options.units.up)]);
    json["parts"] = part_names;
    json["vertices_per_frame"] = vertices;
    json["triangles_per_frame"] = triangles;
    write_file(out.dir() / "import.json", json.dump(2) + '\n');
    out.commit();
    std::cout << fmt::format("wrote {}/: meshes/ ({} PLY frames, {}..{}), labels/, track.csv, object.toml, import.json\n",
                             out.target().string(), range.count(), range.first, range.last);
}

}  // namespace

void add_import_bvh_command(CLI::App& app) {
    auto args = std::make_shared<ImportArguments>();
    auto* command = app.add_subcommand("import-bvh", "Turn a BVH take into a body mesh per frame (PLY), part labels and a view track (CSV)");
    command->add_option("bvh", args->bvh, "BVH motion capture file")->required();
    command->add_option("--out", args->out, "Output folder (replaced as a whole when the run succeeds)")->required();
    command->add_option("--frames", args->frames, "FIRST:LAST, inclusive (default: the whole take after a T-pose)");
    command->add_option("--unit", args->unit, "File unit: m, cm, mm, in, ft or metres per unit (default 0.0564444, CMU)");
    command->add_option("--up", args->up, "File up axis: x, y or z (default y)");
    add_bvh_options(*command, args->bvh_options);
    command->callback([args] { run_import(*args); });
}

}  // namespace amhv::cli
