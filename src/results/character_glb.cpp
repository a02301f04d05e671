#include "src/results/character_glb.hpp"

#include <map>
#include <set>

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

// The skin attributes (four joints and weights per vertex), the triangles and the mesh around a
// primitive whose POSITION and NORMAL are set; returns the mesh's index.
int skinned_mesh(GlbBuilder& glb, tinygltf::Model& model, tinygltf::Primitive p, const std::uint16_t* joints, const float* weights,
                 const TriangleMesh& surface, const char* name) {
    const std::size_t count = surface.vertices.size();
    p.attributes["JOINTS_0"] = glb.accessor(glb.view(joints, count * 8, TINYGLTF_TARGET_ARRAY_BUFFER), TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                                            TINYGLTF_TYPE_VEC4, count);
    p.attributes["WEIGHTS_0"] = glb.accessor(glb.view(weights, count * 16, TINYGLTF_TARGET_ARRAY_BUFFER), TINYGLTF_COMPONENT_TYPE_FLOAT,
                                             TINYGLTF_TYPE_VEC4, count);
    p.indices = glb.indices(surface);
    p.mode = TINYGLTF_MODE_TRIANGLES;
    tinygltf::Mesh mesh;
    mesh.name = name;
    mesh.primitives.push_back(p);
    model.meshes.push_back(mesh);
    return int(model.meshes.size()) - 1;
}

// One LINEAR sampler of `count` keys at the times of accessor `input`, and its channel.
void add_channel(GlbBuilder& glb, tinygltf::Animation& take, int input, int node, const char* path, const std::vector<float>& values, std::size_t count) {
    tinygltf::AnimationSampler sampler;
    sampler.input = input;
    sampler.output = glb.accessor(glb.view(values.data(), values.size() * 4, 0), TINYGLTF_COMPONENT_TYPE_FLOAT,
                                  std::string(path) == "rotation" ? TINYGLTF_TYPE_VEC4 : TINYGLTF_TYPE_VEC3, count);
    sampler.interpolation = "LINEAR";
    take.samplers.push_back(sampler);
    tinygltf::AnimationChannel channel;
    channel.sampler = int(take.samplers.size()) - 1;
    channel.target_node = node;
    channel.target_path = path;
    take.channels.push_back(channel);
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
    return skinned_mesh(glb, model, p, joints.data(), weights.data(), surface, "body");
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
        add_channel(glb, take, input, first_joint_node + int(j), "translation", translation, times.size());
        add_channel(glb, take, input, first_joint_node + int(j), "rotation", rotation, times.size());
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

namespace {

// One joint per node the skin uses (a bone's node, or the node an unskinned mesh rides on), with
// the node's one bind (offset); vertices re-expressed against it.
struct EditedSkin {
    std::vector<int> joint_node;
    std::vector<Eigen::Affine3d> bind;
    std::vector<Vec3> positions;
    std::vector<std::array<std::uint16_t, 4>> joints;
    std::vector<std::array<float, 4>> weights;
};

std::optional<EditedSkin> edited_skin(const CharacterFile& file) {
    std::map<int, Eigen::Affine3d> bind_of;
    for (const CharacterBone& bone : file.bones) {
        const auto [at, added] = bind_of.emplace(bone.node, bone.offset);
        if (!added && !at->second.isApprox(bone.offset, 1e-9)) return std::nullopt;
    }
    for (int node : file.rigid_node)
        if (node >= 0) bind_of.emplace(node, Eigen::Affine3d::Identity());
    EditedSkin out;
    std::map<int, int> joint_of;
    for (const auto& [node, bind] : bind_of) {
        joint_of[node] = int(out.joint_node.size());
        out.joint_node.push_back(node);
        out.bind.push_back(bind);
    }
    for (std::size_t v = 0; v < file.vertices.size(); ++v) {
        std::map<int, float> merged;
        Vec3 p = file.vertices[v];
        if (file.rigid_node[v] >= 0) {
            merged[joint_of.at(file.rigid_node[v])] = 1.0f;
            p = bind_of.at(file.rigid_node[v]).inverse() * p;  // G bind p' = G p
        } else {
            for (std::size_t k = 0; k < 4; ++k)
                if (file.vertex_bones[v][k] >= 0)
                    merged[joint_of.at(file.bones[std::size_t(file.vertex_bones[v][k])].node)] += float(file.vertex_weights[v][k]);
        }
        std::array<std::uint16_t, 4> j{0, 0, 0, 0};
        std::array<float, 4> w{0, 0, 0, 0};
        std::size_t k = 0;
        for (const auto& [joint, weight] : merged) j[k] = std::uint16_t(joint), w[k++] = weight;
        out.positions.push_back(p);
        out.joints.push_back(j);
        out.weights.push_back(w);
    }
    return out;
}

// Translation, rotation (continuous with `previous`) and scale of an affine map without shear.
void trs(const Eigen::Affine3d& a, Eigen::Quaterniond& previous, std::vector<float>& t, std::vector<float>& r, std::vector<float>& s) {
    Eigen::Matrix3d rotation, scaling;
    a.computeRotationScaling(&rotation, &scaling);
    Eigen::Quaterniond q(rotation);
    if (q.dot(previous) < 0) q.coeffs() = -q.coeffs();
    previous = q;
    t.insert(t.end(), {float(a.translation().x()), float(a.translation().y()), float(a.translation().z())});
    r.insert(r.end(), {float(q.x()), float(q.y()), float(q.z()), float(q.w())});
    s.insert(s.end(), {float(scaling(0, 0)), float(scaling(1, 1)), float(scaling(2, 2))});
}

int raw_mesh(GlbBuilder& glb, tinygltf::Model& model, const CharacterFile& file, const EditedSkin& skin) {
    std::vector<float> positions, normals(skin.positions.size() * 3, 0.0f);
    std::vector<Vec3> sum(skin.positions.size(), Vec3::Zero());
    for (const auto& t : file.triangles) {
        const Vec3 n = (file.vertices[t[1]] - file.vertices[t[0]]).cross(file.vertices[t[2]] - file.vertices[t[0]]);
        for (std::uint32_t v : t) sum[v] += n;
    }
    std::vector<double> lo(3, 1e300), hi(3, -1e300);
    for (std::size_t v = 0; v < skin.positions.size(); ++v) {
        const Vec3 n = sum[v].norm() > 0 ? Vec3(sum[v].normalized()) : Vec3::UnitY();
        for (int c = 0; c < 3; ++c) {
            positions.push_back(float(skin.positions[v][c]));
            normals[v * 3 + std::size_t(c)] = float(n[c]);
            lo[std::size_t(c)] = std::min(lo[std::size_t(c)], double(positions.back()));
            hi[std::size_t(c)] = std::max(hi[std::size_t(c)], double(positions.back()));
        }
    }
    tinygltf::Primitive p;
    p.attributes["POSITION"] = glb.accessor(glb.view(positions.data(), positions.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER), TINYGLTF_COMPONENT_TYPE_FLOAT,
                                            TINYGLTF_TYPE_VEC3, skin.positions.size(), lo, hi);
    p.attributes["NORMAL"] = glb.accessor(glb.view(normals.data(), normals.size() * 4, TINYGLTF_TARGET_ARRAY_BUFFER), TINYGLTF_COMPONENT_TYPE_FLOAT,
                                          TINYGLTF_TYPE_VEC3, skin.positions.size());
    return skinned_mesh(glb, model, p, skin.joints.front().data(), skin.weights.front().data(), TriangleMesh{skin.positions, file.triangles}, "character");
}

// Node 0: the file's units and axes to glTF's, with the floor lift; nodes 1..: the file's.
void edited_nodes(tinygltf::Model& model, const CharacterFile& file, const UnitsAndAxes& units) {
    Eigen::Matrix3d turn = to_gltf() * units.map().matrix();
    double scale = units.metres_per_unit;
    if (turn.determinant() < 0) turn = -turn, scale = -scale;  // a mirrored file: a negative scale
    const Eigen::Quaterniond q(turn);
    const Vec3 lift = to_gltf() * Vec3(0, 0, units.lift);
    tinygltf::Node top;
    top.name = "amhv_scene";
    top.translation = {lift.x(), lift.y(), lift.z()};
    top.rotation = {q.x(), q.y(), q.z(), q.w()};
    top.scale = {scale, scale, scale};
    top.children = {1};
    model.nodes.push_back(top);
    // Names stay unique, and none is "ROOT", the node assimp adds above a glTF scene's several root
    // nodes: animation channels are found by name when the file is read back.
    std::set<std::string> used{"ROOT", "amhv_scene", "character"};
    for (std::size_t n = 0; n < file.nodes.size(); ++n) {
        tinygltf::Node node;
        node.name = file.nodes[n].name;
        for (int copy = 1; used.count(node.name); ++copy) node.name = fmt::format("{}_{}", file.nodes[n].name, copy);
        used.insert(node.name);
        model.nodes.push_back(node);
    }
    for (std::size_t n = 0; n < file.nodes.size(); ++n)
        if (file.nodes[n].parent >= 0) model.nodes[std::size_t(file.nodes[n].parent) + 1].children.push_back(int(n) + 1);
}

void edited_animation(GlbBuilder& glb, tinygltf::Model& model, const CharacterFile& file, const std::vector<int>& sources,
                      const std::vector<Eigen::Isometry3d>& edits, double fps) {
    tinygltf::Animation take;
    take.name = "edited";
    std::vector<float> times;
    for (std::size_t k = 0; k < sources.size(); ++k) times.push_back(float(double(k) / fps));
    const int input = glb.floats(times, TINYGLTF_TYPE_SCALAR, true);
    for (std::size_t n = 0; n < file.nodes.size(); ++n) {
        std::vector<float> t, r, s;
        Eigen::Quaterniond previous = Eigen::Quaterniond::Identity();
        for (std::size_t k = 0; k < sources.size(); ++k) {
            const Eigen::Affine3d& local = file.frames[std::size_t(sources[k])][n];
            trs(n == 0 ? Eigen::Affine3d(edits[k] * local) : local, previous, t, r, s);
        }
        tinygltf::Node& node = model.nodes[n + 1];
        node.translation = {t[0], t[1], t[2]};
        node.rotation = {r[0], r[1], r[2], r[3]};
        node.scale = {s[0], s[1], s[2]};
        add_channel(glb, take, input, int(n) + 1, "translation", t, sources.size());
        add_channel(glb, take, input, int(n) + 1, "rotation", r, sources.size());
        add_channel(glb, take, input, int(n) + 1, "scale", s, sources.size());
    }
    model.animations.push_back(take);
}

}  // namespace

bool write_edited_character_glb(const CharacterFile& file, const UnitsAndAxes& units, const std::vector<int>& sources,
                                const std::vector<Eigen::Isometry3d>& edits, double fps, const std::filesystem::path& path) {
    const std::optional<EditedSkin> skin = edited_skin(file);
    if (!skin || sources.empty() || sources.size() != edits.size()) return false;
    tinygltf::Model model;
    GlbBuilder glb(model);
    edited_nodes(model, file, units);
    tinygltf::Node holder;
    holder.name = "character";
    holder.mesh = raw_mesh(glb, model, file, *skin);
    holder.skin = 0;
    model.nodes.push_back(holder);
    tinygltf::Skin s;
    std::vector<float> binds;
    for (std::size_t j = 0; j < skin->joint_node.size(); ++j) {
        s.joints.push_back(skin->joint_node[j] + 1);
        for (int c = 0; c < 4; ++c)
            for (int r = 0; r < 4; ++r) binds.push_back(float(skin->bind[j].matrix()(r, c)));
    }
    s.inverseBindMatrices = glb.accessor(glb.view(binds.data(), binds.size() * 4, 0), TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_MAT4, skin->joint_node.size());
    model.skins.push_back(s);
    edited_animation(glb, model, file, sources, edits, fps);
    tinygltf::Scene scene;
    scene.nodes = {0, int(model.nodes.size()) - 1};
    model.scenes.push_back(scene);
    model.defaultScene = 0;
    model.asset.version = "2.0";
    model.asset.generator = "amhv";
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToFile(&model, path.string(), true, true, false, true)) fail(path.string(), "cannot write the edited character");
    return true;
}

}  // namespace amhv
