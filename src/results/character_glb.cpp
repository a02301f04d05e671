#include "src/results/character_glb.hpp"

#include "src/core/error.hpp"
#include "src/results/glb_builder.hpp"

namespace amhv {

namespace {

// Scene axes (z up) to glTF's (y up): (x, y, z) -> (x, z, -y), a rotation.
const Eigen::Matrix3d& to_gltf() {
    static const Eigen::Matrix3d c = (Eigen::Matrix3d() << 1, 0, 0, 0, 0, 1, 0, -1, 0).finished();
    return c;
}

template <typename Transform>
Transform in_gltf(const Transform& t) {
    Transform out = t;
    out.linear() = to_gltf() * t.linear() * to_gltf().transpose();
    out.translation() = to_gltf() * t.translation();
    return out;
}

// Every joint's local transform at a frame (glTF axes): its parent's global inverse times its own.
std::vector<Eigen::Isometry3d> locals(const AnimatedSkin& skin, const std::vector<Eigen::Isometry3d>& global) {
    std::vector<Eigen::Isometry3d> out;
    for (std::size_t j = 0; j < global.size(); ++j) {
        const Eigen::Isometry3d g = in_gltf(global[j]);
        out.push_back(skin.joint_parent[j] < 0 ? g : in_gltf(global[std::size_t(skin.joint_parent[j])]).inverse() * g);
    }
    return out;
}

int mesh_primitive(GlbBuilder& glb, tinygltf::Model& model, const AnimatedSkin& skin) {
    TriangleMesh surface{skin.vertices, skin.triangles};
    tinygltf::Primitive p;
    const auto [position, normal] = glb.vertices(surface);
    p.attributes["POSITION"] = position;
    p.attributes["NORMAL"] = normal;
    std::vector<std::uint16_t> joints;
    std::vector<float> weights;
    for (std::size_t v = 0; v < skin.vertices.size(); ++v)
        for (int k = 0; k < 4; ++k) {
            joints.push_back(std::uint16_t(skin.weights[v][std::size_t(k)] > 0 ? skin.joints[v][std::size_t(k)] : 0));
            weights.push_back(skin.weights[v][std::size_t(k)]);
        }
    p.attributes["JOINTS_0"] = glb.accessor(glb.view(joints.data(), joints.size() * 2, TINYGLTF_TARGET_ARRAY_BUFFER), TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                                            TINYGLTF_TYPE_VEC4, skin.vertices.size());
    p.attributes["WEIGHTS_0"] = glb.accessor(glb.view(weights.data(), weights.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER), TINYGLTF_COMPONENT_TYPE_FLOAT,
                                             TINYGLTF_TYPE_VEC4, skin.vertices.size());
    p.indices = glb.indices(surface);
    p.mode = TINYGLTF_MODE_TRIANGLES;
    tinygltf::Mesh mesh;
    mesh.name = "body";
    mesh.primitives.push_back(p);
    model.meshes.push_back(mesh);
    return int(model.meshes.size()) - 1;
}

// One sampler per joint and path: a key per frame.
void add_animation(GlbBuilder& glb, tinygltf::Model& model, const AnimatedSkin& skin, int first_joint_node) {
    tinygltf::Animation take;
    take.name = "take";
    std::vector<float> times;
    for (std::size_t f = 0; f < skin.global.size(); ++f) times.push_back(float(double(f) / skin.fps));
    const int input = glb.floats(times, TINYGLTF_TYPE_SCALAR, true);
    std::vector<std::vector<Eigen::Isometry3d>> local;
    for (const auto& g : skin.global) local.push_back(locals(skin, g));
    for (std::size_t j = 0; j < skin.joint_names.size(); ++j) {
        std::vector<float> translation, rotation;
        Eigen::Quaterniond previous = Eigen::Quaterniond::Identity();
        for (const auto& frame : local) {
            const Eigen::Vector3d t = frame[j].translation();
            Eigen::Quaterniond q(frame[j].linear());
            if (q.dot(previous) < 0) q.coeffs() = -q.coeffs();  // the nearer of q and -q, for viewers that interpolate
            previous = q;
            translation.insert(translation.end(), {float(t.x()), float(t.y()), float(t.z())});
            rotation.insert(rotation.end(), {float(q.x()), float(q.y()), float(q.z()), float(q.w())});
        }
        for (const auto* path : {"translation", "rotation"}) {
            const bool is_t = std::string(path) == "translation";
            const std::vector<float>& values = is_t ? translation : rotation;
            tinygltf::AnimationSampler sampler;
            sampler.input = input;
            sampler.output = glb.accessor(glb.view(values.data(), values.size() * 4, 0), TINYGLTF_COMPONENT_TYPE_FLOAT, is_t ? TINYGLTF_TYPE_VEC3 : TINYGLTF_TYPE_VEC4,
                                          times.size());
            sampler.interpolation = "LINEAR";
            take.samplers.push_back(sampler);
            tinygltf::AnimationChannel channel;
            channel.sampler = int(take.samplers.size()) - 1;
            channel.target_node = first_joint_node + int(j);
            channel.target_path = path;
            take.channels.push_back(channel);
        }
    }
    model.animations.push_back(take);
}

}  // namespace

void write_character_glb(const AnimatedSkin& skin, const std::filesystem::path& path) {
    if (skin.global.empty() || skin.joint_names.empty()) fail(path.string(), "a character needs joints and at least one frame");
    tinygltf::Model model;
    GlbBuilder glb(model);
    const int mesh = mesh_primitive(glb, model, skin);
    // Node 0 holds the skinned mesh (its own transform is ignored by skinning); joints follow.
    tinygltf::Node holder;
    holder.name = "body";
    holder.mesh = mesh;
    holder.skin = 0;
    model.nodes.push_back(holder);
    const int first_joint = 1;
    const std::vector<Eigen::Isometry3d> rest = locals(skin, skin.global.front());
    tinygltf::Scene scene;
    scene.nodes.push_back(0);
    tinygltf::Skin s;
    std::vector<float> binds;
    for (std::size_t j = 0; j < skin.joint_names.size(); ++j) {
        tinygltf::Node node;
        node.name = skin.joint_names[j];
        const Eigen::Vector3d t = rest[j].translation();
        const Eigen::Quaterniond q(rest[j].linear());
        node.translation = {t.x(), t.y(), t.z()};
        node.rotation = {q.x(), q.y(), q.z(), q.w()};
        model.nodes.push_back(node);
        if (skin.joint_parent[j] < 0) scene.nodes.push_back(first_joint + int(j));
        else model.nodes[std::size_t(first_joint + skin.joint_parent[j])].children.push_back(first_joint + int(j));
        s.joints.push_back(first_joint + int(j));
        const Eigen::Matrix4d m = in_gltf(skin.inverse_bind[j]).matrix();
        for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 4; ++r) binds.push_back(float(m(r, c)));  // column-major
    }
    s.skeleton = first_joint;
    s.inverseBindMatrices = glb.accessor(glb.view(binds.data(), binds.size() * 4, 0), TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_MAT4,
                                         skin.joint_names.size());
    model.skins.push_back(s);
    add_animation(glb, model, skin, first_joint);
    model.scenes.push_back(scene);
    model.defaultScene = 0;
    model.asset.version = "2.0";
    model.asset.generator = "amhv";
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToFile(&model, path.string(), true, true, false, true)) fail(path.string(), "cannot write the character");
}

}  // namespace amhv
