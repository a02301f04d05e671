#include "src/io/mesh_sequence.hpp"

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>

#include <algorithm>
#include <charconv>
#include <cstring>
#include <fstream>
#include <limits>
#include <cmath>
#include <regex>
#include <set>
#include <sstream>

#include <Eigen/LU>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "src/core/error.hpp"
#include "src/io/mesh_precheck.hpp"

namespace amhv {

namespace fs = std::filesystem;

double parse_unit(const std::string& text, const std::string& what) {
    if (text == "m") return 1.0;
    if (text == "cm") return 0.01;
    if (text == "mm") return 0.001;
    if (text == "in") return 0.0254;
    if (text == "ft") return 0.3048;
    double value = 0;
    auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (ec != std::errc() || end != text.data() + text.size() || !(value > 0) || !std::isfinite(value))
        fail(what, "unit '{}' is not m, cm, mm, in, ft or a positive number of metres per unit", text);
    return value;
}

UpAxis parse_up_axis(const std::string& text, const std::string& what) {
    if (text == "z") return UpAxis::Z;
    if (text == "y") return UpAxis::Y;
    if (text == "x") return UpAxis::X;
    fail(what, "up axis '{}' is not x, y or z", text);
}

bool AxisMap::reflects() const {
    return matrix().determinant() < 0;
}

std::string AxisMap::describe() const {
    std::string out;
    for (int c = 0; c < 3; ++c) out += fmt::format("{}{}{}", c ? "," : "", sign[std::size_t(c)] < 0 ? "-" : "", "xyz"[source[std::size_t(c)]]);
    return out;
}

AxisMap axis_map_of(UpAxis up) {
    switch (up) {
        case UpAxis::Y: return {{0, 2, 1}, {1, -1, 1}};  // +90 degrees about x: y becomes z
        case UpAxis::X: return {{1, 2, 0}, {1, 1, 1}};   // cyclic: x becomes z
        default: return {};
    }
}

AxisMap parse_axes(const std::string& text, const std::string& what) {
    AxisMap map;
    std::array<bool, 3> used{};
    std::size_t at = 0;
    bool ok = true;
    for (int c = 0; c < 3 && ok; ++c) {
        const std::size_t comma = c < 2 ? text.find(',', at) : text.size();
        std::string item = comma == std::string::npos ? std::string() : text.substr(at, comma - at);
        item.erase(std::remove(item.begin(), item.end(), ' '), item.end());
        int sign = 1;
        if (!item.empty() && (item[0] == '-' || item[0] == '+')) sign = item[0] == '-' ? -1 : 1, item.erase(0, 1);
        ok = comma != std::string::npos && item.size() == 1 && item[0] >= 'x' && item[0] <= 'z' && !used[std::size_t(item[0] - 'x')];
        if (!ok) break;
        used[std::size_t(item[0] - 'x')] = true;
        map.source[std::size_t(c)] = item[0] - 'x';
        map.sign[std::size_t(c)] = sign;
        at = comma + 1;
    }
    if (!ok) fail(what, "'{}' is not three signed file axes for the scene's x, y, z, each axis once (e.g. \"x,-z,y\")", text);
    return map;
}

Vec3 to_scene_point(const Vec3& p, const UnitsAndAxes& units) {
    Vec3 v = units.map().apply(p * units.metres_per_unit);
    v.z() += units.lift;
    return v;
}

Vec3 to_scene_direction(const Vec3& v, const UnitsAndAxes& units) { return units.map().apply(v); }

FrameRange parse_frame_range(const std::string& text, const std::string& what) {
    auto colon = text.find(':');
    FrameRange range;
    auto parse = [&](std::string_view part, int& out) {
        auto [end, ec] = std::from_chars(part.data(), part.data() + part.size(), out);
        return ec == std::errc() && end == part.data() + part.size() && !part.empty();
    };
    if (colon == std::string::npos || !parse(std::string_view(text).substr(0, colon), range.first) ||
        !parse(std::string_view(text).substr(colon + 1), range.last))
        fail(what, "frame range '{}' is not FIRST:LAST (inclusive), e.g. 10:58", text);
    if (range.first < 0 || range.last < range.first) fail(what, "frame range '{}' is empty or negative", text);
    return range;
}

namespace {

// Vertices beyond this many metres from the origin (after units) are refused: a wrong unit or garbage.
constexpr double kMaxExtent = 10000;

std::string lower_extension(const fs::path& path) {
    auto ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return ext;
}

bool is_mesh_file(const fs::path& p) {
    const std::string ext = lower_extension(p);
    return ext == ".obj" || ext == ".ply" || ext == ".off" || ext == ".stl";
}

// Natural order: digit runs compare by value, so frame_2 < frame_10.
bool natural_less(const std::string& a, const std::string& b) {
    std::size_t i = 0, j = 0;
    while (i < a.size() && j < b.size()) {
        if (std::isdigit((unsigned char)a[i]) && std::isdigit((unsigned char)b[j])) {
            std::size_t i2 = i, j2 = j;
            while (i2 < a.size() && std::isdigit((unsigned char)a[i2])) ++i2;
            while (j2 < b.size() && std::isdigit((unsigned char)b[j2])) ++j2;
            auto na = a.substr(i, i2 - i), nb = b.substr(j, j2 - j);
            na.erase(0, std::min(na.find_first_not_of('0'), na.size()));
            nb.erase(0, std::min(nb.find_first_not_of('0'), nb.size()));
            if (na.size() != nb.size()) return na.size() < nb.size();
            if (na != nb) return na < nb;
            i = i2;
            j = j2;
        } else {
            if (a[i] != b[j]) return a[i] < b[j];
            ++i;
            ++j;
        }
    }
    return a.size() - i < b.size() - j;
}

// printf pattern "frame_%04d.obj" -> regex with one capture for the number.
// The pattern's %d as printf writes it: zero-padded to `width` digits (%04d), or plain (%d).
struct Conversion {
    bool zero = false;
    int width = 0;
    // Whether printf would write `number` as `digits` (so "f_%04d.obj" names f_0001.obj, not f_1.obj).
    bool writes(int number, const std::string& digits) const {
        const std::string plain = std::to_string(number);
        return digits == (zero && int(plain.size()) < width ? std::string(std::size_t(width) - plain.size(), '0') + plain : plain);
    }
};

Conversion pattern_conversion(const std::string& name) {
    static const std::regex conversion(R"(%(0?)(\d*)d)");
    std::smatch m;
    Conversion c;
    if (std::regex_search(name, m, conversion)) {
        c.zero = !m[1].str().empty();
        c.width = m[2].str().empty() ? 0 : std::min(9, std::stoi(m[2].str().substr(0, 2)));
    }
    return c;
}

std::regex pattern_regex(const std::string& name, const std::string& spec) {
    static const std::regex conversion(R"(%(0?\d*)d)");
    std::smatch m;
    if (!std::regex_search(name, m, conversion)) fail(spec, "pattern has no %d conversion (e.g. frame_%04d.obj)");
    auto escape = [](const std::string& s) { return std::regex_replace(s, std::regex(R"([.^$|()\[\]{}*+?\\])"), R"(\$&)"); };
    std::string rest = m.suffix().str();
    if (std::regex_search(rest, conversion)) fail(spec, "pattern has more than one %d conversion");
    return std::regex(escape(m.prefix().str()) + "(\\d+)" + escape(rest));
}

}  // namespace

std::vector<FrameFile> list_frames(const std::string& spec, const std::optional<FrameRange>& range) {
    std::vector<FrameFile> frames;
    fs::path path(spec);
    std::error_code ec;
    if (fs::is_directory(path, ec)) {
        std::vector<fs::path> files;
        for (const auto& entry : fs::directory_iterator(path, ec))
            if (entry.is_regular_file() && is_mesh_file(entry.path())) files.push_back(entry.path());
        std::sort(files.begin(), files.end(), [](const fs::path& a, const fs::path& b) {
            return natural_less(a.filename().string(), b.filename().string());
        });
        for (std::size_t i = 0; i < files.size(); ++i) frames.push_back({int(i), files[i]});
        if (frames.empty()) fail(spec, "folder holds no OBJ, PLY, OFF or STL files");
    } else if (spec.find('%') != std::string::npos) {
        fs::path folder = path.parent_path().empty() ? fs::path(".") : path.parent_path();
        std::regex re = pattern_regex(path.filename().string(), spec);
        const Conversion conversion = pattern_conversion(path.filename().string());
        if (!fs::is_directory(folder, ec)) fail(spec, "folder {} does not exist", folder.string());
        for (const auto& entry : fs::directory_iterator(folder, ec)) {
            std::smatch m;
            std::string name = entry.path().filename().string();
            if (!entry.is_regular_file() || !std::regex_match(name, m, re)) continue;
            int number = 0;
            const std::string digits = m[1].str();
            const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), number);
            if (error != std::errc() || end != digits.data() + digits.size())
                fail(entry.path().string(), "frame number {} is beyond {}", printable(digits), std::numeric_limits<int>::max());
            if (!conversion.writes(number, digits)) continue;  // not a name the pattern gives (f_1.obj for f_%04d.obj)
            frames.push_back({number, entry.path()});
        }
        std::sort(frames.begin(), frames.end(), [](const FrameFile& a, const FrameFile& b) { return a.number < b.number; });
        if (frames.empty()) fail(spec, "no file matches the pattern");
    } else {
        fail(spec, "is neither a folder of mesh frames nor a printf pattern such as walk/frame_%04d.obj");
    }
    if (!range) return frames;
    std::vector<FrameFile> selected;
    for (int n = range->first; n <= range->last; ++n) {
        auto it = std::find_if(frames.begin(), frames.end(), [n](const FrameFile& f) { return f.number == n; });
        if (it == frames.end())
            fail(spec, "frame {} of --frames {}:{} is missing (the sequence has frames {} to {}, {} files)", n, range->first,
                 range->last, frames.front().number, frames.back().number, frames.size());
        selected.push_back(*it);
    }
    return selected;
}


TriangleMesh read_mesh(const fs::path& path, const UnitsAndAxes& units, const fs::path& files_root) {
    const ReadingFile reading(path.string());
    using OMesh = OpenMesh::TriMesh_ArrayKernelT<>;
    std::error_code ec;
    if (!fs::exists(path, ec)) fail(path.string(), "file does not exist");
    if (!fs::is_regular_file(path, ec)) fail(path.string(), "is not a regular file");
    precheck_mesh_file(path, files_root);
    OMesh mesh;
    // With face status, OpenMesh marks the faces its half-edge structure cannot take (non-manifold:
    // it adds them on copies of their vertices); they are left out below, as the warning says.
    mesh.request_face_status();
    std::ostringstream diagnostics;
    OpenMesh::IO::Options options;
    omerr().disconnect(std::cerr);
    omerr().connect(diagnostics);
    bool ok = OpenMesh::IO::read_mesh(mesh, path.string(), options);
    omerr().disconnect(diagnostics);
    if (!ok) fail(path.string(), "cannot read mesh (unreadable, malformed or unsupported file)");
    std::size_t non_manifold = 0;
    for (auto fh : mesh.faces()) non_manifold += mesh.status(fh).fixed_nonmanifold();
    if (!diagnostics.str().empty()) {
        // Anything OpenMesh complains of but non-manifold faces is a broken file.
        const std::string first_line = diagnostics.str().substr(0, diagnostics.str().find('\n'));
        if (first_line.find("complex") == std::string::npos)
            fail(path.string(), "malformed mesh: {}",
                 first_line.find("invalid vertex index") != std::string::npos ? "a face names a vertex the file does not have"
                                                                               : "the reader could not take all of it");
    }
    if (non_manifold > 0)
        spdlog::warn("{}: {} face{} shared an edge or a vertex with others in a way a closed surface cannot (non-manifold); "
                     "{} left out",
                     path.string(), non_manifold, non_manifold == 1 ? "" : "s", non_manifold == 1 ? "it is" : "they are");
    if (mesh.n_faces() == 0) fail(path.string(), "empty frame: the mesh has no faces");

    TriangleMesh out;
    out.vertices.reserve(mesh.n_vertices());
    for (auto vh : mesh.vertices()) {
        auto p = mesh.point(vh);
        Vec3 v(p[0], p[1], p[2]);
        if (!v.allFinite())
            fail(path.string(), "vertex {} has a non-finite coordinate ({}, {}, {})", vh.idx(), p[0], p[1], p[2]);
        out.vertices.push_back(to_scene_point(v, units));
        if (out.vertices.back().cwiseAbs().maxCoeff() > kMaxExtent)
            fail(path.string(), "vertex {} lies {:.3g} m from the origin; amhv takes scenes within {} km of it (is --unit right?)", vh.idx(),
                 out.vertices.back().norm(), kMaxExtent / 1000);
    }
    out.triangles.reserve(mesh.n_faces());
    for (auto fh : mesh.faces()) {
        if (mesh.status(fh).fixed_nonmanifold()) continue;
        std::array<std::uint32_t, 3> t{};
        int i = 0;
        for (auto vh : mesh.fv_range(fh)) {
            if (i < 3) t[std::size_t(i)] = std::uint32_t(vh.idx());
            ++i;
        }
        if (i == 3) out.triangles.push_back(t);
    }
    if (out.triangles.empty()) fail(path.string(), "empty frame: every face of the mesh was left out as non-manifold");
    // A mirrored file turns outward normals inward: the winding flips back.
    if (units.map().reflects())
        for (auto& t : out.triangles) std::swap(t[1], t[2]);
    return out;
}

MeshSequence read_mesh_sequence(const std::string& spec, const std::optional<FrameRange>& range, const UnitsAndAxes& units) {
    MeshSequence sequence;
    sequence.source = spec;
    for (const auto& file : list_frames(spec, range)) sequence.frames.push_back({read_mesh(file.path, units), file.path.string()});
    return sequence;
}

}  // namespace amhv
