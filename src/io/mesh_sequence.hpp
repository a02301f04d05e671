#pragma once
// Reading mesh sequences (docs/method.md section 9): a folder of frames sorted naturally, or a
// printf-style pattern; OBJ, PLY, OFF and STL through OpenMesh; converted once to metres, z up.
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "src/core/geometry.hpp"

namespace amhv {

enum class UpAxis { X, Y, Z };

// A signed permutation from a file's axes to the scene's: scene axis c is sign[c] times file axis
// source[c]. It may be a reflection (a left-handed file): mesh readers then flip the triangles'
// winding so that solids stay solid.
struct AxisMap {
    std::array<int, 3> source{0, 1, 2};
    std::array<int, 3> sign{1, 1, 1};
    bool reflects() const;
    Vec3 apply(const Vec3& v) const { return {sign[0] * v[source[0]], sign[1] * v[source[1]], sign[2] * v[source[2]]}; }
    // The map as a matrix: column c is apply(unit c).
    Eigen::Matrix3d matrix() const {
        Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
        for (int r = 0; r < 3; ++r) m(r, source[std::size_t(r)]) = sign[std::size_t(r)];
        return m;
    }
    std::string describe() const;  // "x,-z,y"
};
// The map `up` stands for: the file's up axis becomes z, right-handedness kept.
AxisMap axis_map_of(UpAxis up);
// "x,-z,y": three signed axis names, each file axis once. Throws amhv::Error naming `what`.
AxisMap parse_axes(const std::string& text, const std::string& what);

struct UnitsAndAxes {
    double metres_per_unit = 1.0;
    UpAxis up = UpAxis::Z;
    std::optional<AxisMap> axes;  // when given, replaces `up`
    double lift = 0;              // metres added to z after the axes (the floor at z = 0)
    AxisMap map() const { return axes ? *axes : axis_map_of(up); }
};

// "m", "cm", "mm", "in", "ft" or a positive number of metres per unit.
double parse_unit(const std::string& text, const std::string& what);
UpAxis parse_up_axis(const std::string& text, const std::string& what);
// A point in the file's units and axes to the scene: scaled, mapped, lifted.
Vec3 to_scene_point(const Vec3& p, const UnitsAndAxes& units);
// A direction in the file's axes to the scene's (not scaled, not lifted).
Vec3 to_scene_direction(const Vec3& v, const UnitsAndAxes& units);

struct FrameRange {
    int first = 0;
    int last = 0;  // inclusive
    int count() const { return last - first + 1; }
};
// "first:last" (inclusive), e.g. "10:58".
FrameRange parse_frame_range(const std::string& text, const std::string& what);

struct FrameFile {
    int number;  // frame number: the pattern's number, or the position in a sorted folder
    std::filesystem::path path;
};

// The frames named by `spec` (folder or printf pattern), restricted to `range` if given. Every frame
// of the range must exist.
std::vector<FrameFile> list_frames(const std::string& spec, const std::optional<FrameRange>& range);

// One mesh file, triangulated, validated (finite coordinates, at least one face) and converted.
// `files_root`: where the files an OBJ names must lie (empty: the OBJ's folder).
TriangleMesh read_mesh(const std::filesystem::path& path, const UnitsAndAxes& units, const std::filesystem::path& files_root = {});

MeshSequence read_mesh_sequence(const std::string& spec, const std::optional<FrameRange>& range, const UnitsAndAxes& units);

}  // namespace amhv
