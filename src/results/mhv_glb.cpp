#include "src/results/mhv_glb.hpp"

#include <fmt/format.h>

#include "src/core/error.hpp"
#include "src/io/exr_slices.hpp"
#include "src/results/glb_builder.hpp"

namespace amhv {

namespace {

constexpr std::array<std::array<int, 3>, 6> kNormals{{{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}}};

bool occupied(const Amhv& volume, int x, int y, int z) {
    const auto& d = volume.grid().dims;
    if (x < 0 || y < 0 || z < 0 || x >= d[0] || y >= d[1] || z >= d[2]) return false;
    return volume.t_end(volume.grid().index(x, y, z)) >= 0;
}

// Calls face(x, y, z, side) for every face between an occupied voxel and an empty one (or the
// grid's edge), in the grid's order.
template <typename Face>
void for_each_surface_face(const Amhv& volume, Face&& face) {
    const auto& d = volume.grid().dims;
    for (int z = 0; z < d[2]; ++z)
        for (int y = 0; y < d[1]; ++y)
            for (int x = 0; x < d[0]; ++x) {
                if (!occupied(volume, x, y, z)) continue;
                for (int s = 0; s < 6; ++s)
                    if (!occupied(volume, x + kNormals[std::size_t(s)][0], y + kNormals[std::size_t(s)][1], z + kNormals[std::size_t(s)][2]))
                        face(x, y, z, s);
            }
}

// The four corners of side `s` of voxel (x, y, z), counter-clockwise seen from outside.
std::array<Vec3, 4> face_corners(const VoxelGrid& grid, int x, int y, int z, int s) {
    const int axis = s / 2;
    const bool positive = s % 2;
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    Vec3 base = grid.origin + grid.voxel * Vec3(x, y, z);
    if (positive) base[axis] += grid.voxel;
    Vec3 du = Vec3::Zero(), dv = Vec3::Zero();
    du[u] = grid.voxel;
    dv[v] = grid.voxel;
    if (positive) return {base, base + du, base + du + dv, base + dv};
    return {base, base + dv, base + du + dv, base + du};
}

}  // namespace

MhvGlbReport write_mhv_glb(const Amhv& volume, const std::filesystem::path& path) {
    MhvGlbReport report;
    for_each_surface_face(volume, [&](int, int, int, int) { ++report.faces; });
    if (report.faces > kMaxMhvGlbFaces)
        fail(path.string(), "the volume's surface has {} voxel faces, more than mhv.glb takes ({}); use a larger --voxel", report.faces,
             kMaxMhvGlbFaces);
    std::vector<float> positions, colours;
    std::vector<std::uint32_t> indices;
    positions.reserve(report.faces * 12);
    colours.reserve(report.faces * 12);
    indices.reserve(report.faces * 6);
    const double last = std::max(1, volume.frames() - 1);
    for_each_surface_face(volume, [&](int x, int y, int z, int s) {
        const auto rgb = time_colour(volume.t_end(volume.grid().index(x, y, z)) / last);
        const auto first = std::uint32_t(positions.size() / 3);
        for (const Vec3& c : face_corners(volume.grid(), x, y, z, s)) {
            positions.insert(positions.end(), {float(c.x()), float(c.z()), float(-c.y())});  // y-up
            colours.insert(colours.end(), rgb.begin(), rgb.end());
        }
        indices.insert(indices.end(), {first, first + 1, first + 2, first, first + 2, first + 3});
    });
    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = std::string("amhv ") + AMHV_VERSION;
    GlbBuilder glb(model);
    tinygltf::Material material;
    material.name = "t_end";
    material.pbrMetallicRoughness.metallicFactor = 0.0;
    material.pbrMetallicRoughness.roughnessFactor = 1.0;
    material.doubleSided = true;
    model.materials.push_back(material);
    tinygltf::Mesh mesh;
    mesh.name = "aMHV surface, coloured by t_end";
    if (!indices.empty()) {
        tinygltf::Primitive p;
        p.attributes = {{"POSITION", glb.attribute(positions, 3, true)}, {"COLOR_0", glb.attribute(colours, 3, false)}};
        p.indices = glb.indices32(indices);
        p.material = 0;
        p.mode = TINYGLTF_MODE_TRIANGLES;
        mesh.primitives.push_back(p);
    }
    tinygltf::Node node;
    node.name = "aMHV";
    if (!mesh.primitives.empty()) {
        model.meshes.push_back(mesh);
        node.mesh = 0;
    }
    model.nodes.push_back(node);
    tinygltf::Scene scene;
    scene.name = "amhv mhv";
    scene.nodes = {0};
    model.scenes.push_back(scene);
    model.defaultScene = 0;
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToFile(&model, path.string(), true, true, false, true)) fail(path.string(), "cannot write the glTF volume");
    report.bytes = std::filesystem::file_size(path);
    return report;
}

}  // namespace amhv
