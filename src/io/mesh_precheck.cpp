#include "src/io/mesh_precheck.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "src/core/error.hpp"
#include "src/io/obj_appearance.hpp"

namespace amhv {

namespace fs = std::filesystem;

namespace {

std::string lowercase_extension(const fs::path& path) {
    auto ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return ext;
}


// A word of a text mesh that reads as a finite number.
bool is_finite_number(const std::string& word) {
    char* end = nullptr;
    const double value = std::strtod(word.c_str(), &end);
    return end != word.c_str() && std::isfinite(value);
}

// A face row of a text OFF or PLY file: a count, then that many indices of the file's vertices.
// In OFF (`off`), what follows the corners may only be a colour: OpenMesh reads the file word by
// word, so any other word would be taken for the next face's count.
void check_face_row(const std::string& line, std::uint64_t vertices, std::uint64_t face, const std::string& where, bool off = false) {
    std::istringstream words(line);
    long long n = 0, index = 0;
    // OpenMesh takes the count as unsigned: -3 would ask for billions of corners.
    if (!(words >> n) || n < 3) fail(where, "face {} does not start with its number of corners (3 or more)", face);
    for (long long k = 0; k < n; ++k)
        if (!(words >> index) || index < 0 || std::uint64_t(index) >= vertices)
            fail(where, "face {} names vertex {}, not one of the {} vertices", face, index, vertices);
    if (!off) return;
    int extras = 0;
    for (std::string word; words >> word; ++extras) {
        const double value = std::strtod(word.c_str(), nullptr);
        if (!is_finite_number(word) || value < 0 || value > 255 || extras == 4) extras = 99;
    }
    if (extras != 0 && extras != 3 && extras != 4)
        fail(where, "face {} has words after its corners that are not a colour (3 or 4 numbers from 0 to 255)", face);
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
            // OpenMesh's OFF reader takes no comments: it reads a "#" line as numbers, fails
            // silently and allocates for what it then finds (a fuzz finding).
            if (line.find('#') != std::string::npos)
                fail(fmt::format("{}:{}", source, number), "malformed OFF: a comment (#), which the reader does not take; remove it");
            if (line.find_first_not_of(" \t\r") != std::string::npos) return true;
        }
        return false;
    };
    if (!next_line()) fail(source, "malformed OFF: the file is empty");
    std::istringstream head(line);
    std::string magic;
    head >> magic;
    // OpenMesh's grammar of the first word: [ST][C][N][4][n]OFF, then BINARY for a binary body.
    static const std::regex kOffMagic("(ST)?C?N?(4)?(n)?OFF");
    std::smatch parts;
    if (!std::regex_match(magic, parts, kOffMagic))
        fail(fmt::format("{}:{}", source, number), "malformed OFF: it does not start with OFF (or one of its forms such as COFF, NOFF, STOFF)");
    if (parts[2].matched || parts[3].matched)
        fail(fmt::format("{}:{}", source, number), "{} declares vertices of more than three dimensions; amhv reads 3D meshes", printable(magic));
    if (line.find("BINARY") != std::string::npos)
        fail(fmt::format("{}:{}", source, number),
             "binary OFF is not read (the format leaves its byte order open); save the frame as ASCII OFF, PLY or STL");
    // OpenMesh reads the counts from the line after the first, whatever follows the first word.
    if (std::string rest; head >> rest)
        fail(fmt::format("{}:{}", source, number), "malformed OFF: the vertex and face counts belong on the line after {}", printable(magic));
    // What a vertex row holds after x, y and z: texture coordinates (ST), a colour (C: RGB, or RGBA
    // one more), a normal (N).
    const bool colour = magic.find('C') != std::string::npos;
    const int extra = (parts[1].matched ? 2 : 0) + (colour ? 3 : 0) + (magic.find('N') != std::string::npos ? 3 : 0);
    // The counts line holds exactly the vertex, face and edge counts (OpenMesh reads a missing edge
    // count from the next line, and every row after it shifts).
    long long vertices = -1, faces = -1, edges = -1;
    if (next_line()) {
        std::istringstream counts(line);
        std::string after;
        if (!(counts >> vertices >> faces >> edges) || (counts >> after)) vertices = -1;
    }
    if (vertices < 0 || faces < 0 || edges < 0)
        fail(fmt::format("{}:{}", source, number), "malformed OFF: expected the vertex, face and edge counts (three numbers) on this line");
    if (std::uint64_t(vertices) > size || std::uint64_t(faces) > size || std::uint64_t(vertices) * 6 + std::uint64_t(faces) * 8 > size)
        fail(fmt::format("{}:{}", source, number), "malformed OFF: {} vertices and {} faces do not fit in a file of {} bytes", vertices, faces, size);
    for (long long v = 0; v < vertices; ++v) {
        if (!next_line()) fail(source, "malformed OFF: {} vertices declared, the file ends after {}", vertices, v);
        std::istringstream words(line);
        double x = 0, y = 0, z = 0;
        if (!(words >> x >> y >> z) || !std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
            fail(fmt::format("{}:{}", source, number), "vertex {} does not have three finite coordinates", v);
        // As many more numbers as the form says (OpenMesh reads word by word: one more or less
        // shifts every later vertex and face).
        int more = 0;
        for (std::string word; words >> word; ++more)
            if (!is_finite_number(word)) more = 99;
        if (more != extra && !(colour && more == extra + 1))
            fail(fmt::format("{}:{}", source, number), "vertex {} has {} values after its coordinates where the {} form holds {}", v, more,
                 printable(magic), colour ? fmt::format("{} or {}", extra, extra + 1) : std::to_string(extra));
    }
    for (long long f = 0; f < faces; ++f) {
        if (!next_line()) fail(source, "malformed OFF: {} faces declared, the file ends after {}", faces, f);
        check_face_row(line, std::uint64_t(vertices), std::uint64_t(f), fmt::format("{}:{}", source, number), true);
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
    std::vector<std::vector<std::pair<std::string, std::string>>> types;  // per element: (list count type or "", value type)
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
        h.types.emplace_back();
    } else if (w[0] == "property") {
        const bool list = w.size() == 5 && w[1] == "list" && kTypes.count(w[2]) && kTypes.count(w[3]);
        if (h.elements.empty() || !(list || (w.size() == 3 && kTypes.count(w[1]))))
            fail(where, "malformed PLY header: a property line must follow an element and be 'property TYPE NAME' or 'property list TYPE TYPE NAME'");
        if (list && (w[2] == "float" || w[2] == "float32" || w[2] == "double" || w[2] == "float64"))
            fail(where, "malformed PLY header: the count of list {} is of type {}; a count is an integer", printable(w[4]), printable(w[2]));
        h.properties.back().push_back(list ? "list " + w[4] : w[2]);
        h.types.back().emplace_back(list ? w[2] : std::string(), list ? w[3] : w[1]);
    } else if (w[0] == "end_header" && w.size() == 1) {
        h.ended = true;
    } else {
        fail(where, "malformed PLY header: '{}' is not a header line", printable(w[0]));
    }
}

// The size in bytes of a PLY scalar type, and whether it is a floating-point one.
std::pair<int, bool> ply_type(const std::string& t) {
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return {1, false};
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return {2, false};
    if (t == "int" || t == "uint" || t == "int32" || t == "uint32") return {4, false};
    if (t == "float" || t == "float32") return {4, true};
    return {8, true};  // double, float64 (the header's grammar admits no other)
}

// A binary PLY body read value by value, counting the bytes read (so that what is left of the file
// is known without seeking).
struct PlyCursor {
    std::istream& in;
    std::uint64_t position;  // bytes from the file's start
    std::uint64_t size;      // the file's size
    bool big_endian;

    // One value of type `t`, as a double (every PLY integer fits one exactly). False at the end.
    bool read(const std::string& t, double& value) {
        const auto [bytes, floating] = ply_type(t);
        std::array<unsigned char, 8> b{};
        if (!in.read(reinterpret_cast<char*>(b.data()), bytes)) return false;
        position += std::uint64_t(bytes);
        std::uint64_t u = 0;  // the value's bits, in the file's byte order
        for (int k = 0; k < bytes; ++k) u |= std::uint64_t(b[std::size_t(big_endian ? bytes - 1 - k : k)]) << (8 * k);
        const bool is_signed = t == "char" || t == "short" || t == "int" || t == "int8" || t == "int16" || t == "int32";
        const std::uint64_t sign = std::uint64_t(1) << (8 * bytes - 1);
        if (floating && bytes == 4) value = std::bit_cast<float>(std::uint32_t(u));
        else if (floating) value = std::bit_cast<double>(u);
        else value = is_signed && (u & sign) ? double(std::int64_t(u) - std::int64_t(sign << 1)) : double(u);
        return true;
    }
};

// A binary PLY body walked row by row as OpenMesh will read it: every list's length within what is
// left of the file, every face's vertex index one of the vertices, every vertex coordinate finite.
// Each row takes at least one byte, so the walk is bounded by the file's size whatever the header says.
void walk_binary_ply(PlyCursor cursor, const std::string& source, const PlyHeader& header, std::uint64_t vertices) {
    for (std::size_t e = 0; e < header.elements.size(); ++e) {
        const auto& [name, count] = header.elements[e];
        const auto& names = header.properties[e];
        const auto& types = header.types[e];
        if (names.empty() && count > 0) fail(source, "malformed PLY: element {} has {} rows but no properties", printable(name), count);
        for (std::uint64_t row = 0; row < count; ++row) {
            for (std::size_t p = 0; p < names.size(); ++p) {
                double value = 0;
                const bool list = !types[p].first.empty();
                if (!cursor.read(list ? types[p].first : types[p].second, value))
                    fail(source, "malformed PLY: the file ends in row {} of element {} ({} declared)", row, printable(name), count);
                if (!list) {
                    if (name == "vertex" && (names[p] == "x" || names[p] == "y" || names[p] == "z") && !std::isfinite(value))
                        fail(source, "vertex {} has a non-finite coordinate {}", row, names[p]);
                    continue;
                }
                const auto value_bytes = double(ply_type(types[p].second).first);
                if (!(value >= 0) || value != std::floor(value) || value * value_bytes > double(cursor.size - cursor.position))
                    fail(source, "malformed PLY: row {} of element {} has a list of {} values, past the end of the file", row, printable(name), value);
                const bool indices = name == "face" && (names[p] == "list vertex_indices" || names[p] == "list vertex_index");
                for (std::uint64_t k = 0; k < std::uint64_t(value); ++k) {
                    double index = 0;
                    cursor.read(types[p].second, index);
                    if (indices && !(index >= 0 && index < double(vertices)))
                        fail(source, "face {} names vertex {}, not one of the {} vertices", row, index, vertices);
                }
            }
        }
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
        in.clear();
        in.seekg(std::streamoff(header_bytes));
        walk_binary_ply(PlyCursor{in, header_bytes, size, format == "binary_big_endian"}, source, header, vertices);
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

}  // namespace

// Structural checks OpenMesh does not make before it allocates: a header that promises more data
// than the file holds would make it allocate without bound or read garbage. Text formats are
// scanned for non-finite coordinates, which OpenMesh would otherwise silently drop.
void precheck_mesh_file(const fs::path& path, const fs::path& files_root) {
    const std::string source = path.string();
    // The file may go between the caller's check and here: one clear line, not a filesystem_error.
    std::error_code error;
    const auto size = fs::file_size(path, error);
    if (error) fail(source, "cannot read the file: {}", error.message());
    std::ifstream in(path, std::ios::binary);
    if (!in) fail(source, "cannot open file (permission denied?)");
    const std::string ext = lowercase_extension(path);
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


}  // namespace amhv
