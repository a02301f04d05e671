#pragma once
// The captured appearance carried into the edited scene (docs/scenes.md, "Appearance kept"): for
// an object whose frames are OBJ files with texture coordinates, normals or materials,
// frames/A_NNNN.obj (and B_) are its source frames with positions and normals moved by the edit,
// in the file's own units and axes, every other line kept; the material libraries and textures
// are copied once into frames/A_materials/, in the same folder layout, so the files open as
// captured.
#include <filesystem>
#include <optional>

#include "src/edit/edit.hpp"
#include "src/io/obj_appearance.hpp"
#include "src/scene/segment.hpp"

namespace amhv {

// The file of an object's source frame `number` (mesh sequences only).
std::filesystem::path source_frame_file(const ObjectSource& source, int number);

// True when the object's frames are OBJ files with texture coordinates, normals or materials.
bool has_obj_appearance(const ObjectSource& source);

// Output frame k's rigid move of `object` in the file's own units and axes: a position and a
// direction (a normal) of the source frame to where the edit puts them.
struct FileSpaceMove {
    Eigen::Matrix3d linear = Eigen::Matrix3d::Identity();  // acts on file coordinates
    Vec3 shift = Vec3::Zero();
    Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();    // for directions
    Vec3 point(const Vec3& p) const { return linear * p + shift; }
    Vec3 direction(const Vec3& n) const { return turn * n; }
};
FileSpaceMove file_space_move(const EditResult& edit, int k, int object, const ObjectSource& source);

// Writes frames/A_NNNN.obj and B_NNNN.obj for the objects with OBJ appearance, and their
// materials; returns the number of OBJ files written.
int write_obj_frames(const std::filesystem::path& folder, const EditResult& edit, ObjectSource& a, ObjectSource& b);

}  // namespace amhv
