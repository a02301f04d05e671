#include "src/io/obj_appearance.hpp"

#include <cctype>
#include <charconv>
#include <cmath>
#include <sstream>

#include <fmt/format.h>

#include "src/core/error.hpp"
#include "src/io/files.hpp"

namespace amhv {

namespace fs = std::filesystem;

namespace {

// A file's lines without their line ends (LF or CRLF), each with its number for messages.
std::vector<std::string> lines_of(const std::string& text) {
    std::vector<std::string> lines;
    std::size_t start = 0;
    while (start < text.size()) {
        std::size_t end = text.find('\n', start);
        if (end == std::string::npos) end = text.size();
        std::string line = text.substr(start, end - start);
        if (!line.empty() && line.back() == '\r') line.pop_back();
        lines.push_back(std::move(line));
        start = end + 1;
    }
    return lines;
}

std::vector<std::string> words(const std::string& line) {
    std::istringstream in(line);
    std::vector<std::string> out;
    for (std::string w; in >> w;) out.push_back(w);
    return out;
}

double number(const std::string& word, const std::string& where) {
    double v = 0;
    auto [end, ec] = std::from_chars(word.data(), word.data() + word.size(), v);
    if (ec != std::errc() || end != word.data() + word.size() || !std::isfinite(v)) fail(where, "'{}' is not a finite number", printable(word));
    return v;
}

// `count` numbers from words[1..]; OBJ allows extra ones (w), which are ignored.
template <std::size_t N>
std::array<double, N> numbers(const std::vector<std::string>& w, std::size_t least, const std::string& where) {
    if (w.size() < 1 + least) fail(where, "'{}' needs {} numbers", w[0], least);
    std::array<double, N> out{};
    for (std::size_t i = 0; i < N && i + 1 < w.size(); ++i) out[i] = number(w[i + 1], where);
    return out;
}

// An OBJ index: 1-based, or negative from the end of what is defined so far; -1 when empty.
int index_of(const std::string& text, std::size_t defined, const std::string& what, const std::string& where) {
    if (text.empty()) return -1;
    long long i = 0;
    auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), i);
    if (ec != std::errc() || end != text.data() + text.size() || i == 0) fail(where, "'{}' is not an OBJ {} index", printable(text), what);
    const long long zero_based = i > 0 ? i - 1 : static_cast<long long>(defined) + i;
    if (zero_based < 0 || zero_based >= static_cast<long long>(defined))
        fail(where, "{} index {} is out of range (1..{} defined so far)", what, i, defined);
    return int(zero_based);
}

ObjCorner corner(const std::string& word, const ObjAppearance& obj, const std::string& where) {
    std::array<std::string, 3> parts;
    std::size_t part = 0;
    for (char c : word) {
        if (c == '/') {
            if (++part > 2) fail(where, "face corner '{}' has more than three indices", printable(word));
        } else {
            parts[part] += c;
        }
    }
    ObjCorner out;
    out.v = index_of(parts[0], obj.positions.size(), "vertex", where);
    if (out.v < 0) fail(where, "face corner '{}' has no vertex index", printable(word));
    out.vt = index_of(parts[1], obj.texcoords.size(), "texture coordinate", where);
    out.vn = index_of(parts[2], obj.normals.size(), "normal", where);
    return out;
}

// The file name at the end of an MTL statement (options such as "-s 1 1 1" come before it).
std::string last_word(const std::vector<std::string>& w) { return w.back(); }

bool names_a_file(const std::string& keyword) {
    return keyword.rfind("map_", 0) == 0 || keyword == "bump" || keyword == "disp" || keyword == "decal" || keyword == "refl" || keyword == "norm";
}

}  // namespace

bool is_obj_file(const fs::path& file) {
    std::string ext = file.extension().string();
    for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    return ext == ".obj";
}

fs::path confined_reference(const fs::path& from_folder, const std::string& reference, const fs::path& files_root, const std::string& where,
                            const char* what) {
    const fs::path named(reference);
    if (reference.empty() || named.is_absolute())
        fail(where, "{} '{}' is not a path relative to the file's folder; amhv reads only files inside {}", what, printable(reference, 80),
             files_root.string());
    std::error_code ec;
    const fs::path resolved = fs::canonical(from_folder / named, ec);
    if (ec) fail(where, "{} '{}' does not exist", what, printable(reference, 80));
    const fs::path root = fs::canonical(files_root, ec);
    if (ec) fail(files_root.string(), "does not exist (the folder an object's files may come from)");
    auto r = root.begin();
    for (auto p = resolved.begin(); r != root.end(); ++r, ++p)
        if (p == resolved.end() || *p != *r)
            fail(where, "{} '{}' lies outside {}, the folder this object's files may come from (the scene's files_root for the object widens it)",
                 what, printable(reference, 80), root.string());
    if (!fs::is_regular_file(resolved, ec)) fail(where, "{} '{}' is not a regular file", what, printable(reference, 80));
    return resolved;
}

std::map<std::string, ObjMaterial> read_mtl(const fs::path& file, const fs::path& files_root) {
    const std::vector<std::string> lines = lines_of(read_file_bytes(file, std::uintmax_t(1) << 28));
    std::map<std::string, ObjMaterial> out;
    ObjMaterial* current = nullptr;
    for (std::size_t n = 0; n < lines.size(); ++n) {
        const std::string where = fmt::format("{}:{}", file.string(), n + 1);
        const auto w = words(lines[n]);
        if (w.empty() || w[0][0] == '#') continue;
        if (names_a_file(w[0])) {
            if (w.size() < 2) fail(where, "{} needs a file", printable(w[0]));
            const fs::path named = confined_reference(file.parent_path(), last_word(w), files_root, where, w[0] == "map_Kd" ? "texture" : "file");
            if (w[0] == "map_Kd" && current) current->texture = named;
        }
        if (w[0] == "newmtl") {
            if (w.size() < 2) fail(where, "newmtl needs a name");
            current = &out[w[1]];
            continue;
        }
        if (!current) {
            if (w[0] == "Kd" || w[0] == "d" || w[0] == "map_Kd") fail(where, "'{}' before any newmtl", w[0]);
            continue;
        }
        if (w[0] == "Kd") {
            const auto kd = numbers<3>(w, 3, where);
            for (std::size_t c = 0; c < 3; ++c) current->colour[c] = std::clamp(kd[c], 0.0, 1.0);
        } else if (w[0] == "d") {
            current->colour[3] = std::clamp(numbers<1>(w, 1, where)[0], 0.0, 1.0);
        }
    }
    return out;
}

std::vector<fs::path> mtl_references(const fs::path& file, const fs::path& files_root) {
    std::vector<fs::path> out;
    const std::vector<std::string> lines = lines_of(read_file_bytes(file, std::uintmax_t(1) << 28));
    for (std::size_t n = 0; n < lines.size(); ++n) {
        const auto w = words(lines[n]);
        if (w.size() >= 2 && names_a_file(w[0]))
            out.push_back(confined_reference(file.parent_path(), last_word(w), files_root, fmt::format("{}:{}", file.string(), n + 1),
                                             w[0] == "map_Kd" ? "texture" : "file"));
    }
    return out;
}

ObjAppearance read_obj_appearance(const fs::path& file, const fs::path& files_root) {
    const fs::path root = files_root.empty() ? file.parent_path() : files_root;
    const std::vector<std::string> lines = lines_of(read_file_bytes(file));
    ObjAppearance obj;
    obj.file = file;
    std::size_t group = 0;
    std::vector<fs::path> libraries;
    auto use = [&](const std::string& name) {
        for (std::size_t g = 0; g < obj.by_material.size(); ++g)
            if (obj.by_material[g].first == name) return g;
        obj.by_material.push_back({name, {}});
        return obj.by_material.size() - 1;
    };
    for (std::size_t n = 0; n < lines.size(); ++n) {
        const std::string where = fmt::format("{}:{}", file.string(), n + 1);
        const auto w = words(lines[n]);
        if (w.empty() || w[0][0] == '#') continue;
        if (w[0] == "v") {
            const auto p = numbers<3>(w, 3, where);
            obj.positions.emplace_back(p[0], p[1], p[2]);
        } else if (w[0] == "vt") {
            const auto t = numbers<2>(w, 1, where);
            obj.texcoords.push_back({t[0], w.size() > 2 ? t[1] : 0.0});
        } else if (w[0] == "vn") {
            const auto v = numbers<3>(w, 3, where);
            obj.normals.emplace_back(v[0], v[1], v[2]);
        } else if (w[0] == "usemtl") {
            if (w.size() < 2) fail(where, "usemtl needs a material name");
            group = use(w[1]);
        } else if (w[0] == "mtllib") {
            for (std::size_t i = 1; i < w.size(); ++i) {
                obj.mtllibs.push_back(w[i]);
                libraries.push_back(confined_reference(file.parent_path(), w[i], root, where, "material library"));
            }
        } else if (w[0] == "f") {
            if (w.size() < 4) fail(where, "a face needs at least 3 corners");
            if (obj.by_material.empty()) group = use("");
            std::vector<ObjCorner> corners;
            for (std::size_t i = 1; i < w.size(); ++i) corners.push_back(corner(w[i], obj, where));
            for (std::size_t i = 1; i + 1 < corners.size(); ++i) obj.by_material[group].second.push_back({corners[0], corners[i], corners[i + 1]});
        }
    }
    for (const fs::path& mtl : libraries)
        for (auto& [name, material] : read_mtl(mtl, root)) obj.materials.emplace(name, material);
    for (const auto& [name, triangles] : obj.by_material)
        if (!name.empty() && !obj.mtllibs.empty() && !obj.materials.count(name))
            fail(file.string(), "material '{}' is used but no material library defines it", printable(name));
    return obj;
}

std::string transformed_obj_text(const fs::path& file, const std::function<Vec3(const Vec3&)>& point,
                                 const std::function<Vec3(const Vec3&)>& direction, const std::function<std::string(const std::string&)>& rename) {
    const std::vector<std::string> lines = lines_of(read_file_bytes(file));
    std::string out;
    for (std::size_t n = 0; n < lines.size(); ++n) {
        const std::string where = fmt::format("{}:{}", file.string(), n + 1);
        const auto w = words(lines[n]);
        if (!w.empty() && (w[0] == "v" || w[0] == "vn")) {
            const auto p = numbers<3>(w, 3, where);
            const Vec3 moved = w[0] == "v" ? point(Vec3(p[0], p[1], p[2])) : direction(Vec3(p[0], p[1], p[2]));
            out += fmt::format("{} {:.9g} {:.9g} {:.9g}", w[0], moved.x(), moved.y(), moved.z());
            for (std::size_t i = 4; i < w.size(); ++i) out.append(1, ' ').append(w[i]);  // a vertex's w or colour stays
            out += '\n';
        } else if (!w.empty() && w[0] == "mtllib") {
            out += "mtllib";
            for (std::size_t i = 1; i < w.size(); ++i) out.append(1, ' ').append(rename(w[i]));
            out += '\n';
        } else {
            out.append(lines[n]).append(1, '\n');
        }
    }
    return out;
}

}  // namespace amhv
