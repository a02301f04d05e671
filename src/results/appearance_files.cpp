#include "src/results/appearance_files.hpp"

#include <algorithm>
#include <cctype>
#include <set>

#include <fmt/format.h>

#include "src/core/budget.hpp"
#include "src/core/error.hpp"
#include "src/io/files.hpp"

namespace amhv {

namespace fs = std::filesystem;

fs::path source_frame_file(const ObjectSource& source, int number) {
    return list_frames(source.spec().meshes, FrameRange{number, number}).front().path;
}

bool has_obj_appearance(const ObjectSource& source) {
    if (source.spec().meshes.empty()) return false;
    const fs::path first = source_frame_file(source, source.spec().frame_first);
    return is_obj_file(first) && read_obj_appearance(first, source.spec().files_root).has_appearance();
}

FileSpaceMove file_space_move(const EditResult& edit, int k, int object, const ObjectSource& source) {
    // Scene = M (unit p) + lift z; the edit: E (scene) + t. Back in the file: M^T (E M p) + M^T t / unit
    // (E keeps the lift, a turn about z).
    const ObjectFrameEdit& e = edit.frames[std::size_t(object)][std::size_t(k)];
    const UnitsAndAxes& units = source.spec().units;
    const Eigen::Matrix3d m = units.map().matrix();
    const Eigen::Matrix3d turn = m.transpose() * Eigen::AngleAxisd(e.yaw, Vec3::UnitZ()).toRotationMatrix() * m;
    FileSpaceMove move;
    move.linear = turn;
    move.turn = turn;
    move.shift = m.transpose() * Vec3(e.translation.x(), e.translation.y(), e.lift) / units.metres_per_unit;
    return move;
}

namespace {

// The deepest folder holding every path of `paths` (absolute, normalised).
fs::path common_folder(const std::vector<fs::path>& paths) {
    fs::path common = paths.front().parent_path();
    for (const fs::path& p : paths) {
        const fs::path folder = p.parent_path();
        fs::path shared;
        auto a = common.begin();
        for (auto b = folder.begin(); a != common.end() && b != folder.end() && *a == *b; ++a, ++b) shared /= *a;
        common = shared;
    }
    return common;
}

// Every material library of the frames and every file those name, absolute and resolved, each
// inside the object's files root (src/io/obj_appearance.hpp).
std::vector<fs::path> material_files(const std::vector<fs::path>& frames, const fs::path& files_root) {
    std::set<fs::path> files;
    for (const fs::path& frame : frames) {
        const fs::path root = files_root.empty() ? frame.parent_path() : files_root;
        for (const std::string& lib : read_obj_appearance(frame, files_root).mtllibs) {
            const fs::path mtl = confined_reference(frame.parent_path(), lib, root, frame.string(), "material library");
            if (!files.insert(mtl).second) continue;
            for (const fs::path& file : mtl_references(mtl, root)) files.insert(file);
        }
    }
    return {files.begin(), files.end()};
}

int write_object_obj_frames(const fs::path& folder, const EditResult& edit, int object, ObjectSource& source) {
    const std::string name(1, "AB"[object]);
    std::vector<fs::path> frames;
    for (int k = 0; k < edit.timeline.length(); ++k)
        frames.push_back(fs::weakly_canonical(source_frame_file(source, edit.frames[std::size_t(object)][std::size_t(k)].source)));
    // The materials keep their layout below the folder that holds them and every frame, so the
    // libraries' own references to textures stay right.
    const std::vector<fs::path> materials = material_files(frames, source.spec().files_root);
    std::vector<fs::path> everything = frames;
    everything.insert(everything.end(), materials.begin(), materials.end());
    const fs::path root = common_folder(everything);
    const fs::path store = name + "_materials";
    std::uintmax_t bytes = 0;
    for (const fs::path& f : everything) bytes += fs::file_size(f);
    budget::require_disk(folder, bytes + bytes / 4, fmt::format("frames/{}_NNNN.obj and {}_materials/", name, name), "free some disk or pass --no-frames");
    for (const fs::path& f : materials) {
        const fs::path to = folder / store / f.lexically_relative(root);
        fs::create_directories(to.parent_path());
        fs::copy_file(f, to, fs::copy_options::overwrite_existing);
    }
    for (int k = 0; k < edit.timeline.length(); ++k) {
        const fs::path& frame = frames[std::size_t(k)];
        const FileSpaceMove move = file_space_move(edit, k, object, source);
        auto rename = [&](const std::string& lib) {
            const fs::path files_root = source.spec().files_root.empty() ? frame.parent_path() : source.spec().files_root;
            return (store / confined_reference(frame.parent_path(), lib, files_root, frame.string(), "material library").lexically_relative(root)).generic_string();
        };
        const std::string text = transformed_obj_text(
            frame, [&](const Vec3& p) { return move.point(p); }, [&](const Vec3& n) { return move.direction(n); }, rename);
        write_file(folder / fmt::format("{}_{:04d}.obj", name, k), text);
    }
    return edit.timeline.length();
}

}  // namespace

int write_obj_frames(const fs::path& folder, const EditResult& edit, ObjectSource& a, ObjectSource& b) {
    int written = 0;
    ObjectSource* sources[2] = {&a, &b};
    for (int o = 0; o < 2; ++o)
        if (has_obj_appearance(*sources[o])) {
            fs::create_directories(folder);
            written += write_object_obj_frames(folder, edit, o, *sources[o]);
        }
    return written;
}

}  // namespace amhv
