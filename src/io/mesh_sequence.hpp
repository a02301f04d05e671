#pragma once
// Reading mesh sequences (docs/method.md section 9): a folder of frames sorted naturally, or a
// printf-style pattern; OBJ, PLY, OFF and STL through OpenMesh; converted once to metres, z up.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "src/core/geometry.hpp"

namespace amhv {

enum class UpAxis { X, Y, Z };

struct UnitsAndAxes {
    double metres_per_unit = 1.0;
    UpAxis up = UpAxis::Z;
};

// "m", "cm", "mm", "in", "ft" or a positive number of metres per unit.
double parse_unit(const std::string& text, const std::string& what);
UpAxis parse_up_axis(const std::string& text, const std::string& what);
// Input coordinates (after scaling) to the z-up world; right-handedness is kept.
Vec3 to_z_up(const Vec3& p, UpAxis up);

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
TriangleMesh read_mesh(const std::filesystem::path& path, const UnitsAndAxes& units);

MeshSequence read_mesh_sequence(const std::string& spec, const std::optional<FrameRange>& range, const UnitsAndAxes& units);

}  // namespace amhv
