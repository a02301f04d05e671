#pragma once
// The appearance of an OBJ frame (docs/scenes.md, "Appearance kept"): texture coordinates, normals
// and materials, which the solver does not need but the edited scene must keep. The file is read
// line by line; writing it back rewrites only the `v` and `vn` lines, so UVs, faces, groups,
// material names and every other line survive byte for byte.
#include <array>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "src/core/geometry.hpp"

namespace amhv {

struct ObjMaterial {
    std::array<double, 4> colour{0.8, 0.8, 0.8, 1.0};  // Kd and d
    std::filesystem::path texture;                     // map_Kd, resolved; empty for none
};

struct ObjCorner {
    int v = -1, vt = -1, vn = -1;  // zero-based; -1 when the face gives none
};

struct ObjAppearance {
    std::filesystem::path file;
    std::vector<Vec3> positions;                 // as in the file (its units and axes)
    std::vector<std::array<double, 2>> texcoords;
    std::vector<Vec3> normals;
    // Triangles (polygons fanned) per material, in the order materials are first used; "" for
    // faces before any usemtl.
    std::vector<std::pair<std::string, std::vector<std::array<ObjCorner, 3>>>> by_material;
    std::vector<std::string> mtllibs;            // as written in the file
    std::map<std::string, ObjMaterial> materials;
    bool has_appearance() const { return !texcoords.empty() || !normals.empty() || !mtllibs.empty(); }
};

// True for a file named *.obj (any case).
bool is_obj_file(const std::filesystem::path& file);

// Every file an OBJ or MTL names (mtllib, map_Kd, bump, ...) is untrusted: it must be a relative
// path that resolves (links followed) to a regular file inside `files_root`, by default the folder
// of the OBJ file itself (a scene widens it with an object's `files_root`). Anything else (an
// absolute path, "../../x" out of the folder, a link out of it) fails naming the file and line.
// `what` names the reference in messages ("material library", "texture").
std::filesystem::path confined_reference(const std::filesystem::path& from_folder, const std::string& reference,
                                         const std::filesystem::path& files_root, const std::string& where, const char* what);

// Reads an OBJ's geometry and appearance, and the materials of its mtllib files. Fails naming
// the file and line on a malformed number, an index out of range, a missing material library, or a
// named file outside `files_root` (empty: the OBJ's folder).
ObjAppearance read_obj_appearance(const std::filesystem::path& file, const std::filesystem::path& files_root = {});
// Every material of an MTL file (Kd, d, map_Kd with its options); fails naming the file and line.
std::map<std::string, ObjMaterial> read_mtl(const std::filesystem::path& file, const std::filesystem::path& files_root);
// The files an MTL file refers to (map_*, bump, disp, decal, refl, norm), each confined to
// `files_root` and resolved.
std::vector<std::filesystem::path> mtl_references(const std::filesystem::path& file, const std::filesystem::path& files_root);

// The OBJ text of `file` with each `v` line's position p replaced by point(p), each `vn` line's
// normal n by direction(n), and each `mtllib` file name f by rename(f); every other line kept.
std::string transformed_obj_text(const std::filesystem::path& file, const std::function<Vec3(const Vec3&)>& point,
                                 const std::function<Vec3(const Vec3&)>& direction,
                                 const std::function<std::string(const std::string&)>& rename);

}  // namespace amhv
