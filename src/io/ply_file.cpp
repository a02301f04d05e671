#include "src/io/ply_file.hpp"

#include "src/io/files.hpp"

#include <bit>
#include <fstream>

#include "src/core/error.hpp"

namespace amhv {

void write_ply(const std::filesystem::path& path, const TriangleMesh& mesh, const std::vector<std::array<std::uint8_t, 3>>& colours,
               const std::vector<std::string>& comments) {
    static_assert(std::endian::native == std::endian::little, "the PLY writer assumes a little-endian host");
    const bool coloured = !colours.empty();
    if (coloured && colours.size() != mesh.vertices.size())
        fail(path.string(), "{} colours for {} vertices", colours.size(), mesh.vertices.size());
    std::string header = "ply\nformat binary_little_endian 1.0\n";
    for (const std::string& c : comments) header += fmt::format("comment {}\n", c);
    header += fmt::format("element vertex {}\nproperty float x\nproperty float y\nproperty float z\n", mesh.vertices.size());
    if (coloured) header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    header += fmt::format("element face {}\nproperty list uchar int vertex_indices\nend_header\n", mesh.triangles.size());

    std::vector<char> bytes(header.begin(), header.end());
    auto put = [&bytes](const auto& value) {
        const char* p = reinterpret_cast<const char*>(&value);
        bytes.insert(bytes.end(), p, p + sizeof(value));
    };
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
        for (int c = 0; c < 3; ++c) put(float(mesh.vertices[v][c]));
        if (coloured)
            for (std::uint8_t channel : colours[v]) put(channel);
    }
    for (const auto& t : mesh.triangles) {
        put(std::uint8_t(3));
        for (std::uint32_t i : t) put(std::int32_t(i));
    }
    write_file(path, std::string_view(bytes.data(), bytes.size()));
}

}  // namespace amhv
