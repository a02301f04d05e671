// Compiled with -ffp-contract=off (CMakeLists.txt): no multiply and add fused into one rounding,
// as skin.comp's `precise` forbids on the device.
#include "src/body/skinning.hpp"

#include <algorithm>

#include "src/core/error.hpp"
#include "src/core/parallel.hpp"

namespace amhv {

namespace {

// The nodes an unskinned mesh rides on, in node order: the palette's entries after the bones.
std::vector<int> riding_nodes(const CharacterFile& character) {
    std::vector<bool> rides(character.nodes.size(), false);
    for (int node : character.rigid_node)
        if (node >= 0) rides[std::size_t(node)] = true;
    std::vector<int> out;
    for (std::size_t node = 0; node < rides.size(); ++node)
        if (rides[node]) out.push_back(int(node));
    return out;
}

}  // namespace

SkinVertices skin_vertices(const CharacterFile& character) {
    SkinVertices out;
    const std::size_t n = character.vertices.size();
    out.rest.resize(4 * n);
    out.bones.assign(4 * n, 0);
    out.weights.assign(4 * n, 0.0f);
    // Palette: the bones, then each node an unskinned mesh rides on, in node order.
    std::vector<std::int32_t> rigid_entry(character.nodes.size(), -1);
    std::int32_t entries = std::int32_t(character.bones.size());
    for (int node : riding_nodes(character)) rigid_entry[std::size_t(node)] = entries++;
    out.palette_size = std::uint32_t(std::max(entries, 1));
    for (std::size_t v = 0; v < n; ++v) {
        for (int a = 0; a < 3; ++a) out.rest[4 * v + std::size_t(a)] = float(character.vertices[v][a]);
        out.rest[4 * v + 3] = 0.0f;
        if (character.rigid_node[v] >= 0) {
            out.bones[4 * v] = rigid_entry[std::size_t(character.rigid_node[v])];
            out.weights[4 * v] = 1.0f;
            continue;
        }
        for (std::size_t k = 0; k < 4; ++k)
            if (character.vertex_bones[v][k] >= 0) {
                out.bones[4 * v + k] = character.vertex_bones[v][k];
                out.weights[4 * v + k] = float(character.vertex_weights[v][k]);
            }
    }
    return out;
}

SkinFrame skin_frame(const CharacterFile& character, int frame, const UnitsAndAxes& units) {
    if (frame < 0 || frame >= character.frame_count())
        fail(character.source, "has no frame {} (animation {}: frames 0..{})", frame, printable(character.animation), character.frame_count() - 1);
    Eigen::Affine3d to_scene = Eigen::Affine3d::Identity();
    to_scene.linear() = units.map().matrix() * units.metres_per_unit;
    to_scene.translation() = Vec3(0, 0, units.lift);
    const std::vector<Eigen::Affine3d> globals = character.globals(frame);
    std::vector<Eigen::Affine3d> matrices;
    for (const CharacterBone& bone : character.bones) matrices.push_back(to_scene * globals[std::size_t(bone.node)] * bone.offset);
    for (int node : riding_nodes(character)) matrices.push_back(to_scene * globals[std::size_t(node)]);
    if (matrices.empty()) matrices.push_back(to_scene);
    SkinFrame out;
    for (const Eigen::Affine3d& m : matrices) out.anchor += m.translation();
    out.anchor /= double(matrices.size());
    out.palette.reserve(12 * matrices.size());
    for (const Eigen::Affine3d& m : matrices)
        for (int r = 0; r < 3; ++r) {
            for (int c = 0; c < 3; ++c) out.palette.push_back(float(m.linear()(r, c)));
            out.palette.push_back(float(m.translation()[r] - out.anchor[r]));
        }
    return out;
}

void skin_reference(const SkinVertices& vertices, std::span<const float> palette, std::size_t first, std::size_t count, float* out) {
    for (std::size_t v = first; v < first + count; ++v) {
        const float x = vertices.rest[4 * v], y = vertices.rest[4 * v + 1], z = vertices.rest[4 * v + 2];
        float p[3] = {0, 0, 0};
        for (std::size_t k = 0; k < 4; ++k) {
            const float* m = palette.data() + 12 * std::size_t(vertices.bones[4 * v + k]);
            const float w = vertices.weights[4 * v + k];
            for (int r = 0; r < 3; ++r) {
                const float q = ((m[4 * r] * x + m[4 * r + 1] * y) + m[4 * r + 2] * z) + m[4 * r + 3];
                p[r] = k == 0 ? w * q : p[r] + w * q;
            }
        }
        for (int r = 0; r < 3; ++r) out[3 * (v - first) + std::size_t(r)] = p[r];
    }
}

void CpuSkinner::skin(const SkinVertices& vertices, std::span<const SkinFrame> frames, std::vector<float>& out) {
    const std::size_t n = vertices.count();
    constexpr std::size_t kBlock = 4096;
    const std::size_t blocks = (n + kBlock - 1) / kBlock;
    out.resize(3 * n * frames.size());
    parallel_for(blocks * frames.size(), [&](std::size_t item) {
        const std::size_t f = item / blocks, first = item % blocks * kBlock;
        skin_reference(vertices, frames[f].palette, first, std::min(kBlock, n - first), out.data() + 3 * (n * f + first));
    });
}

std::vector<Vec3> skinned_points(std::span<const float> skinned, std::size_t vertices, std::size_t f, const SkinFrame& frame) {
    std::vector<Vec3> out(vertices);
    const float* p = skinned.data() + 3 * vertices * f;
    for (std::size_t v = 0; v < vertices; ++v) out[v] = Vec3(double(p[3 * v]), double(p[3 * v + 1]), double(p[3 * v + 2])) + frame.anchor;
    return out;
}

std::vector<std::vector<Vec3>> skin_frames(Skinner& skinner, const SkinVertices& vertices, const CharacterFile& character, int first, int last,
                                           const UnitsAndAxes& units) {
    std::vector<SkinFrame> frames;
    for (int f = first; f <= last; ++f) frames.push_back(skin_frame(character, f, units));
    std::vector<float> skinned;
    skinner.skin(vertices, frames, skinned);
    std::vector<std::vector<Vec3>> out;
    for (std::size_t k = 0; k < frames.size(); ++k) out.push_back(skinned_points(skinned, vertices.count(), k, frames[k]));
    return out;
}

}  // namespace amhv
