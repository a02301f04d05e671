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
#include "src/io/obj_appearance.hpp"

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
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    for (int c = 0; c < 3; ++c) m(c, source[std::size_t(c)]) = sign[std::size_t(c)];
    return m.determinant() < 0;
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

namespace {

// A word of a text mesh that reads as a finite number.
bool is_finite_number(const std::string& word) {
    char* end = nullptr;
    const double value = std::strtod(word.c_str(), &end);
    return end != word.c_str() && std::isfinite(value);
}

// A face row of a text OFF or PLY file: a count, then that many indices of the file's vertices.
void check_face_row(const std::string& line, std::uint64_t vertices, std::uint64_t face, const std::string& where) {
    std::istringstream words(line);
    long long n = 0, index = 0;
    words >> n;
    for (long long k = 0; k < n; ++k)
        if (!(words >> index) || index < 0 || std::uint64_t(index) >= vertices)
            fail(where, "face {} names vertex {}, not one of the {} vertices", face, index, vertices);
}

// OBJ: every vertex coordinate finite, every face index naming a vertex of the file (1-based, or
// negative counting back from the last vertex so far).
void precheck_obj(std::istream& in, const std::string& source) {
    std::string line;
    std::uint64_t number = 0, vertex = 0;
    std::uint64_t highest = 0, highest_line = 0;
    while (std::getline(in, line)) {
        ++number;
        if (line.size() < 2 || !std::isspace(static_cast<unsigned char>(line[1]))) continue;
        std::istringstream words(line.substr(2));
        std::string word;
        if (line[0] == 'v') {
            for (int i = 0; i < 3 && words >> word; ++i)
                if (!is_finite_number(word))
                    fail(source + ":" + std::to_string(number), "vertex {} has a non-finite coordinate '{}'", vertex, printable(word));
            ++vertex;
        } else if (line[0] == 'f') {
            while (words >> word) {
                long long index = 0;
                const auto [end, ec] = std::from_chars(word.data(), word.data() + word.size(), index);
                if (ec != std::errc() || index == 0 || (end != word.data() + word.size() && *end != '/'))
                    fail(source + ":" + std::to_string(number), "face index '{}' is not a vertex number", printable(word));
                if (index < 0 && std::uint64_t(-index) > vertex)
                    fail(source + ":" + std::to_string(number), "face index {} reaches before the first vertex", index);
                if (index > 0 && std::uint64_t(index) > highest) highest = std::uint64_t(index), highest_line = number;
            }
        }
    }
    if (highest > vertex) fail(source + ":" + std::to_string(highest_line), "face index {} is past the last of the file's {} vertices", highest, vertex);
}

// OFF: the header's counts must be matched by the file (OpenMesh reads a header that promises a
// million vertices quadratically), coordinates finite, face indices in range.
void precheck_off(std::istream& in, const std::string& source, std::uint64_t size) {
    std::string line;
    std::uint64_t number = 0;
    auto next_line = [&]() {
        while (std::getline(in, line)) {
            ++number;
            const auto hash = line.find('#');
            if (hash != std::string::npos) line.erase(hash);
            if (line.find_first_not_of(" \t\r") != std::string::npos) return true;
        }
        return false;
    };
    if (!next_line()) fail(source, "malformed OFF: the file is empty");
    std::istringstream head(line);
    std::string magic;
    head >> magic;
    if (magic.find("OFF") == std::string::npos) fail(source + ":1", "malformed OFF: it does not start with OFF");
    if (magic != "OFF") return;  // COFF, NOFF, binary OFF ...: OpenMesh's own checks
    long long vertices = -1, faces = -1;
    if (!(head >> vertices) && next_line()) std::istringstream(line) >> vertices >> faces;
    else head >> faces;
    if (vertices < 0 || faces < 0) fail(fmt::format("{}:{}", source, number), "malformed OFF: expected the vertex and face counts");
    if (std::uint64_t(vertices) * 6 + std::uint64_t(faces) * 8 > size)
        fail(fmt::format("{}:{}", source, number), "malformed OFF: {} vertices and {} faces do not fit in a file of {} bytes", vertices, faces, size);
    for (long long v = 0; v < vertices; ++v) {
        if (!next_line()) fail(source, "malformed OFF: {} vertices declared, the file ends after {}", vertices, v);
        std::istringstream words(line);
        double x = 0, y = 0, z = 0;
        if (!(words >> x >> y >> z) || !std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
            fail(fmt::format("{}:{}", source, number), "vertex {} does not have three finite coordinates", v);
    }
    for (long long f = 0; f < faces; ++f) {
        if (!next_line()) fail(source, "malformed OFF: {} faces declared, the file ends after {}", faces, f);
        check_face_row(line, std::uint64_t(vertices), std::uint64_t(f), fmt::format("{}:{}", source, number));
    }
}

// PLY: the header's counts must be matched by the file; in ASCII files with the usual vertex and
// face elements, vertex rows must hold finite numbers and face rows indices of those vertices.
// One line of a PLY header, checked against the format's grammar before OpenMesh reads it (its
// reader crashes on some malformed headers: a property before any element, a word it does not
// know). Fills the format, the elements in order and their property names.
struct PlyHeader {
    std::string format;
    std::vector<std::pair<std::string, std::uint64_t>> elements;  // name, count
    std::vector<std::vector<std::string>> properties;             // per element: names (a list property as "list NAME")
    bool ended = false;
};

void read_ply_header_line(const std::string& line, std::uint64_t number, const std::string& source, PlyHeader& h) {
    static const std::set<std::string> kTypes{"char",  "uchar",  "short",  "ushort",  "int",    "uint",    "float",   "double",
                                              "int8",  "uint8",  "int16",  "uint16",  "int32",  "uint32",  "float32", "float64"};
    const std::string where = fmt::format("{}:{}", source, number);
    std::istringstream in(line);
    std::vector<std::string> w;
    for (std::string word; in >> word;) w.push_back(word);
    if (number == 1) {
        if (w.size() != 1 || w[0] != "ply") fail(where, "malformed PLY header: the first line must be 'ply'");
        return;
    }
    if (w.empty()) fail(where, "malformed PLY header: an empty line");
    if (w[0] == "comment" || w[0] == "obj_info") return;
    if (w[0] == "format") {
        if (w.size() != 3 || (w[1] != "ascii" && w[1] != "binary_little_endian" && w[1] != "binary_big_endian") || w[2] != "1.0" || !h.format.empty())
            fail(where, "malformed PLY header: a format line must be 'format ascii|binary_little_endian|binary_big_endian 1.0', once");
        h.format = w[1];
    } else if (w[0] == "element") {
        std::uint64_t count = 0;
        const auto [end, ec] = w.size() == 3 ? std::from_chars(w[2].data(), w[2].data() + w[2].size(), count) : std::from_chars_result{nullptr, std::errc::invalid_argument};
        if (w.size() != 3 || ec != std::errc() || end != w[2].data() + w[2].size() || count > 0xffffffffull)
            fail(where, "malformed PLY header: an element line must be 'element NAME COUNT'");
        h.elements.emplace_back(w[1], count);
        h.properties.emplace_back();
    } else if (w[0] == "property") {
        const bool list = w.size() == 5 && w[1] == "list" && kTypes.count(w[2]) && kTypes.count(w[3]);
        if (h.elements.empty() || !(list || (w.size() == 3 && kTypes.count(w[1]))))
            fail(where, "malformed PLY header: a property line must follow an element and be 'property TYPE NAME' or 'property list TYPE TYPE NAME'");
        h.properties.back().push_back(list ? "list " + w[4] : w[2]);
    } else if (w[0] == "end_header" && w.size() == 1) {
        h.ended = true;
    } else {
        fail(where, "malformed PLY header: '{}' is not a header line", printable(w[0]));
    }
}

void precheck_ply(std::istream& in, const std::string& source, std::uint64_t size) {
    std::string line;
    std::uint64_t vertices = 0, faces = 0, header_bytes = 0, header_lines = 0, lines = 0;
    PlyHeader header;
    while (header_bytes < 65536 && !header.ended && std::getline(in, line)) {
        header_bytes += line.size() + 1;
        ++header_lines;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        read_ply_header_line(line, header_lines, source, header);
    }
    const bool ended = header.ended;
    if (!ended) fail(source, "malformed PLY: no end_header in the first 64 KiB");
    if (header.format.empty()) fail(source, "malformed PLY: the header has no format line");
    std::vector<std::string> elements;
    for (std::size_t e = 0; e < header.elements.size(); ++e) {
        const auto& [name, count] = header.elements[e];
        const auto& props = header.properties[e];
        auto has = [&](const std::string& p) { return std::find(props.begin(), props.end(), p) != props.end(); };
        if (name == "vertex" && (!has("x") || !has("y") || !has("z"))) fail(source, "malformed PLY: the vertex element has no x, y and z");
        if (name == "face" && std::none_of(props.begin(), props.end(), [](const std::string& p) { return p.rfind("list ", 0) == 0; }))
            fail(source, "malformed PLY: the face element has no list of vertex indices");
        if (std::find(elements.begin(), elements.end(), name) != elements.end()) fail(source, "malformed PLY: element {} given twice", printable(name));
        elements.push_back(name);
        if (name == "vertex") vertices = count;
        if (name == "face") faces = count;
    }
    const std::string format = header.format;
    if (!ended) fail(source, "malformed PLY: no end_header in the first 64 KiB");
    if (format != "ascii") {
        if (header_bytes + vertices * 12 + faces * 13 > size)
            fail(source, "malformed PLY: {} vertices and {} faces need at least {} bytes but the file has {}", vertices, faces,
                 header_bytes + vertices * 12 + faces * 13, size);
        return;
    }
    const bool standard = elements.size() >= 2 && elements[0] == "vertex" && elements[1] == "face";
    while (std::getline(in, line)) {
        ++lines;
        if (!standard) continue;
        const std::string where = fmt::format("{}:{}", source, header_lines + lines);
        if (lines <= vertices) {
            std::istringstream words(line);
            std::string word;
            while (words >> word)
                if (!is_finite_number(word)) fail(where, "vertex {} has a non-finite or unreadable value '{}'", lines - 1, printable(word));
        } else if (lines <= vertices + faces) {
            check_face_row(line, vertices, lines - vertices - 1, where);
        }
    }
    if (lines < vertices + faces) fail(source, "malformed PLY: {} vertices and {} faces declared but only {} lines follow", vertices, faces, lines);
}

// Structural checks OpenMesh does not make before it allocates: a header that promises more data
// than the file holds would make it allocate without bound or read garbage. Text formats are
// scanned for non-finite coordinates, which OpenMesh would otherwise silently drop.
void precheck_mesh_file(const fs::path& path, const fs::path& files_root) {
    const std::string source = path.string();
    const auto size = fs::file_size(path);
    std::ifstream in(path, std::ios::binary);
    if (!in) fail(source, "cannot open file (permission denied?)");
    const std::string ext = lower_extension(path);
    if (ext == ".ply") {
        precheck_ply(in, source, size);
    } else if (ext == ".stl") {
        char head[84] = {};
        in.read(head, 84);
        bool ascii = std::string(head, std::min<std::size_t>(5, std::size_t(in.gcount()))) == "solid";
        if (!ascii) {
            if (in.gcount() < 84) fail(source, "malformed binary STL: shorter than its 84-byte header");
            std::uint32_t count = 0;
            std::memcpy(&count, head + 80, 4);
            if (84 + std::uint64_t(count) * 50 != size)
                fail(source, "malformed binary STL: {} triangles need {} bytes but the file has {}", count, 84 + std::uint64_t(count) * 50, size);
        }
    } else if (ext == ".obj") {
        precheck_obj(in, source);
        // Its appearance (texture coordinates, normals, materials) goes to the output: checked line
        // by line here, so that a missing material library is named rather than failing OpenMesh.
        read_obj_appearance(path, files_root);
    } else if (ext == ".off") {
        precheck_off(in, source, size);
    }
}

}  // namespace

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
