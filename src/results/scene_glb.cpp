#include "src/results/scene_glb.hpp"

#include <array>
#include <cstring>
#include <limits>

#include <fmt/format.h>
#include <tiny_gltf.h>

#include "src/core/error.hpp"
#include "src/results/edit_files.hpp"

namespace amhv {

namespace {

// The performers' colours, as in the PLY frames and the pictures (A orange, B blue), linear.
constexpr std::array<std::array<double, 4>, 2> kBaseColour{{{0.79, 0.19, 0.02, 1.0}, {0.02, 0.19, 0.79, 1.0}}};

// Builds the model's one buffer, its views and accessors as data is added.
class GlbBuilder {
public:
    explicit GlbBuilder(tinygltf::Model& model) : model_(model) { model_.buffers.resize(1); }

    // A bufferView over `bytes` (4-byte aligned in the buffer); `target` 0 for none.
    int view(const void* bytes, std::size_t size, int target) {
        auto& data = model_.buffers[0].data;
        while (data.size() % 4) data.push_back(0);
        tinygltf::BufferView v;
        v.buffer = 0;
        v.byteOffset = data.size();
        v.byteLength = size;
        v.target = target;
        const auto* from = static_cast<const unsigned char*>(bytes);
        data.insert(data.end(), from, from + size);
        model_.bufferViews.push_back(v);
        return int(model_.bufferViews.size()) - 1;
    }

    int accessor(int view, int component, int type, std::size_t count, std::vector<double> min = {}, std::vector<double> max = {}) {
        tinygltf::Accessor a;
        a.bufferView = view;
        a.componentType = component;
        a.type = type;
        a.count = count;
        a.minValues = std::move(min);
        a.maxValues = std::move(max);
        model_.accessors.push_back(a);
        return int(model_.accessors.size()) - 1;
    }

    // y-up positions with their bounds, and area-weighted vertex normals.
    std::array<int, 2> vertices(const TriangleMesh& mesh) {
        std::vector<float> positions(mesh.vertices.size() * 3), normals(mesh.vertices.size() * 3, 0.0f);
        std::vector<double> lo(3, std::numeric_limits<double>::infinity()), hi(3, -std::numeric_limits<double>::infinity());
        std::vector<Vec3> sum(mesh.vertices.size(), Vec3::Zero());
        for (const auto& t : mesh.triangles) {
            const Vec3 n = (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
            for (int c = 0; c < 3; ++c) sum[t[std::size_t(c)]] += n;
        }
        for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
            const Vec3& p = mesh.vertices[v];
            const float yup[3] = {float(p.x()), float(p.z()), float(-p.y())};
            const Vec3 n = sum[v].norm() > 0 ? Vec3(sum[v].normalized()) : Vec3::UnitZ();
            const float nyup[3] = {float(n.x()), float(n.z()), float(-n.y())};
            for (int c = 0; c < 3; ++c) {
                positions[v * 3 + std::size_t(c)] = yup[c];
                normals[v * 3 + std::size_t(c)] = nyup[c];
                lo[std::size_t(c)] = std::min(lo[std::size_t(c)], double(yup[c]));
                hi[std::size_t(c)] = std::max(hi[std::size_t(c)], double(yup[c]));
            }
        }
        const std::size_t bytes = positions.size() * sizeof(float);
        const int p = accessor(view(positions.data(), bytes, TINYGLTF_TARGET_ARRAY_BUFFER), TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3,
                               mesh.vertices.size(), lo, hi);
        const int n = accessor(view(normals.data(), bytes, TINYGLTF_TARGET_ARRAY_BUFFER), TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3,
                               mesh.vertices.size());
        return {p, n};
    }

    // The triangles as 16-bit indices where they fit, else 32-bit.
    int indices(const TriangleMesh& mesh) {
        const std::size_t count = mesh.triangles.size() * 3;
        if (mesh.vertices.size() <= 65535) {
            std::vector<std::uint16_t> small(count);
            for (std::size_t i = 0; i < count; ++i) small[i] = std::uint16_t(mesh.triangles[i / 3][i % 3]);
            return accessor(view(small.data(), count * 2, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER), TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                            TINYGLTF_TYPE_SCALAR, count);
        }
        return accessor(view(mesh.triangles.data(), count * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER), TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                        TINYGLTF_TYPE_SCALAR, count);
    }

    // A float accessor for animation data (times or scales).
    int floats(const std::vector<float>& values, int type, bool bounds) {
        const int components = type == TINYGLTF_TYPE_VEC3 ? 3 : 1;
        std::vector<double> lo, hi;
        if (bounds) lo = {double(values.front())}, hi = {double(values.back())};
        return accessor(view(values.data(), values.size() * sizeof(float), 0), TINYGLTF_COMPONENT_TYPE_FLOAT, type,
                        values.size() / std::size_t(components), lo, hi);
    }

private:
    tinygltf::Model& model_;
};

void add_materials(tinygltf::Model& model) {
    for (int o = 0; o < 2; ++o) {
        tinygltf::Material m;
        m.name = o == 0 ? "A" : "B";
        m.pbrMetallicRoughness.baseColorFactor = {kBaseColour[std::size_t(o)].begin(), kBaseColour[std::size_t(o)].end()};
        m.pbrMetallicRoughness.metallicFactor = 0.0;
        m.pbrMetallicRoughness.roughnessFactor = 0.8;
        model.materials.push_back(m);
    }
}

// Frame k's nodes are shown from t_k to t_(k+1): scale 0, then 1 at t_k, then 0 at t_(k+1), held
// between keys (STEP). The two performers' nodes of one frame share the sampler.
int frame_sampler(GlbBuilder& glb, tinygltf::Animation& play, int k, int frames, double fps) {
    std::vector<float> times, scales;
    auto key = [&](double t, float s) {
        times.push_back(float(t));
        scales.insert(scales.end(), {s, s, s});
    };
    if (k > 0) key(0.0, 0.0f);
    key(k / fps, 1.0f);
    if (k + 1 < frames) key((k + 1) / fps, 0.0f);
    tinygltf::AnimationSampler sampler;
    sampler.input = glb.floats(times, TINYGLTF_TYPE_SCALAR, true);
    sampler.output = glb.floats(scales, TINYGLTF_TYPE_VEC3, false);
    sampler.interpolation = "STEP";
    play.samplers.push_back(sampler);
    return int(play.samplers.size()) - 1;
}

}  // namespace

SceneGlbReport write_scene_glb(const std::filesystem::path& path, const EditResult& edit, ObjectSource& a, ObjectSource& b, double fps) {
    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = std::string("amhv ") + AMHV_VERSION;
    add_materials(model);
    GlbBuilder glb(model);
    tinygltf::Animation play;
    play.name = "play";
    tinygltf::Node root;
    root.name = "amhv edited scene";
    SceneGlbReport report;
    ObjectSource* sources[2] = {&a, &b};
    std::array<std::vector<std::array<std::uint32_t, 3>>, 2> last_triangles;
    std::array<int, 2> last_indices{-1, -1};
    const int frames = edit.timeline.length();
    for (int k = 0; k < frames; ++k) {
        const int sampler = frame_sampler(glb, play, k, frames, fps);
        for (int o = 0; o < 2; ++o) {
            const TriangleMesh mesh = placed_mesh(edit, k, o, *sources[o]);
            if (mesh.triangles.empty()) continue;
            if (last_indices[std::size_t(o)] < 0 || mesh.triangles != last_triangles[std::size_t(o)]) {
                last_indices[std::size_t(o)] = glb.indices(mesh);
                last_triangles[std::size_t(o)] = mesh.triangles;
                ++report.index_accessors;
            }
            const auto [positions, normals] = glb.vertices(mesh);
            tinygltf::Primitive primitive;
            primitive.attributes = {{"POSITION", positions}, {"NORMAL", normals}};
            primitive.indices = last_indices[std::size_t(o)];
            primitive.material = o;
            primitive.mode = TINYGLTF_MODE_TRIANGLES;
            const int source = edit.frames[std::size_t(o)][std::size_t(k)].source;
            tinygltf::Mesh m;
            m.name = fmt::format("{} frame {:04d} src {:04d}", "AB"[o], k, source);
            m.primitives.push_back(primitive);
            model.meshes.push_back(m);
            tinygltf::Node node;
            node.name = m.name;
            node.mesh = int(model.meshes.size()) - 1;
            if (k > 0) node.scale = {0.0, 0.0, 0.0};  // a still viewer shows frame 0
            model.nodes.push_back(node);
            root.children.push_back(int(model.nodes.size()) - 1);
            tinygltf::AnimationChannel channel;
            channel.sampler = sampler;
            channel.target_node = int(model.nodes.size()) - 1;
            channel.target_path = "scale";
            play.channels.push_back(channel);
            ++report.nodes;
        }
    }
    model.nodes.push_back(root);
    model.animations.push_back(play);
    tinygltf::Scene scene;
    scene.name = "amhv";
    scene.nodes = {int(model.nodes.size()) - 1};
    model.scenes.push_back(scene);
    model.defaultScene = 0;
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToFile(&model, path.string(), /*embedImages=*/true, /*embedBuffers=*/true, /*prettyPrint=*/false, /*writeBinary=*/true))
        fail(path.string(), "cannot write the glTF scene");
    report.bytes = std::filesystem::file_size(path);
    return report;
}

}  // namespace amhv
