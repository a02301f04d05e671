#include "src/body/skinned_body.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <numbers>
#include <numeric>
#include <set>

#include <tiny_gltf.h>

#include "src/body/skeleton_body.hpp"
#include "src/body/skeleton_roles.hpp"
#include "src/body/surface_caps.hpp"
#include "src/core/error.hpp"
#include "src/io/files.hpp"

namespace amhv {

namespace {

// ---- reading the glTF binary ----

// One accessor's elements as doubles (normalised integers scaled to [0, 1] when `normalise`).
std::vector<double> accessor_values(const tinygltf::Model& m, int index, int components, bool normalise, const std::string& where) {
    if (index < 0 || index >= int(m.accessors.size())) fail(where, "accessor {} does not exist", index);
    const tinygltf::Accessor& a = m.accessors[std::size_t(index)];
    const int have = tinygltf::GetNumComponentsInType(std::uint32_t(a.type));
    if (have != components) fail(where, "accessor {} has {} components, expected {}", index, have, components);
    if (a.bufferView < 0 || a.bufferView >= int(m.bufferViews.size())) fail(where, "accessor {} has no buffer view", index);
    const tinygltf::BufferView& view = m.bufferViews[std::size_t(a.bufferView)];
    const std::vector<unsigned char>& data = m.buffers.at(std::size_t(view.buffer)).data;
    const int size = tinygltf::GetComponentSizeInBytes(std::uint32_t(a.componentType));
    if (size <= 0) fail(where, "accessor {} has an unknown component type", index);
    const std::size_t stride = view.byteStride ? view.byteStride : std::size_t(size * components);
    const std::size_t start = view.byteOffset + a.byteOffset;
    if (a.count > 0 && start + stride * (a.count - 1) + std::size_t(size * components) > std::min(data.size(), view.byteOffset + view.byteLength))
        fail(where, "accessor {} reaches past its buffer", index);
    std::vector<double> out(a.count * std::size_t(components));
    for (std::size_t e = 0; e < a.count; ++e)
        for (int c = 0; c < components; ++c) {
            const unsigned char* p = data.data() + start + e * stride + std::size_t(c * size);
            double v = 0;
            switch (a.componentType) {
                case TINYGLTF_COMPONENT_TYPE_FLOAT: { float f; std::memcpy(&f, p, 4); v = f; break; }
                case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: v = *p / (normalise ? 255.0 : 1.0); break;
                case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: { std::uint16_t s; std::memcpy(&s, p, 2); v = s / (normalise ? 65535.0 : 1.0); break; }
                case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: { std::uint32_t u; std::memcpy(&u, p, 4); v = u; break; }
                default: fail(where, "accessor {} has a component type amhv does not read", index);
            }
            if (!std::isfinite(v)) fail(where, "accessor {} holds a non-finite value", index);
            out[e * std::size_t(components) + std::size_t(c)] = v;
        }
    return out;
}

// glTF is y-up: its (x, y, z) is the scene's (x, -z, y).
Vec3 from_yup(double x, double y, double z) { return {x, -z, y}; }

// Images are never decoded: the body needs the surface alone.
bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) { return true; }

// The welded surface of every triangle primitive of `mesh`, with each welded vertex's skin.
void read_skinned_mesh(const tinygltf::Model& m, const tinygltf::Mesh& mesh, SkinModel& out) {
    std::map<std::array<double, 3>, std::uint32_t> weld;
    for (const tinygltf::Primitive& p : mesh.primitives) {
        if (p.mode != TINYGLTF_MODE_TRIANGLES && p.mode != -1) fail(out.source, "mesh '{}' has a primitive that is not triangles", mesh.name);
        for (const char* name : {"POSITION", "JOINTS_0", "WEIGHTS_0"})
            if (!p.attributes.count(name)) fail(out.source, "mesh '{}' has a primitive without {}", mesh.name, name);
        const auto positions = accessor_values(m, p.attributes.at("POSITION"), 3, false, out.source);
        const auto joints = accessor_values(m, p.attributes.at("JOINTS_0"), 4, false, out.source);
        const auto weights = accessor_values(m, p.attributes.at("WEIGHTS_0"), 4, true, out.source);
        const std::size_t count = positions.size() / 3;
        if (joints.size() != count * 4 || weights.size() != count * 4) fail(out.source, "mesh '{}': skin and positions differ in count", mesh.name);
        std::vector<std::uint32_t> ids(count);
        for (std::size_t v = 0; v < count; ++v) {
            const std::array<double, 3> key{positions[v * 3], positions[v * 3 + 1], positions[v * 3 + 2]};
            auto [at, added] = weld.emplace(key, std::uint32_t(out.vertices.size()));
            ids[v] = at->second;
            if (!added) continue;
            out.vertices.push_back(from_yup(key[0], key[1], key[2]));
            std::array<int, 4> j{};
            std::array<float, 4> w{};
            double sum = 0;
            for (std::size_t c = 0; c < 4; ++c) {
                j[c] = int(joints[v * 4 + c]);
                w[c] = float(weights[v * 4 + c]);
                if (w[c] > 0 && (j[c] < 0 || j[c] >= int(out.joint_names.size())))
                    fail(out.source, "mesh '{}': vertex {} names joint {} of {}", mesh.name, v, j[c], out.joint_names.size());
                sum += w[c];
            }
            if (sum <= 0) fail(out.source, "mesh '{}': vertex {} has no skin weight", mesh.name, v);
            for (float& x : w) x = float(x / sum);
            out.joints.push_back(j);
            out.weights.push_back(w);
        }
        std::vector<double> indices;
        if (p.indices >= 0) indices = accessor_values(m, p.indices, 1, false, out.source);
        else for (std::size_t v = 0; v < count; ++v) indices.push_back(double(v));
        if (indices.size() % 3) fail(out.source, "mesh '{}': an index count that is not a multiple of 3", mesh.name);
        for (std::size_t t = 0; t < indices.size(); t += 3) {
            std::array<std::uint32_t, 3> tri{};
            for (std::size_t c = 0; c < 3; ++c) {
                if (indices[t + c] >= double(count)) fail(out.source, "mesh '{}': index {} out of range", mesh.name, indices[t + c]);
                tri[c] = ids[std::size_t(indices[t + c])];
            }
            if (tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2]) out.triangles.push_back(tri);  // welding may collapse one
        }
    }
}

void read_skin_joints(const tinygltf::Model& m, const tinygltf::Skin& skin, SkinModel& out) {
    const auto inverse_bind = accessor_values(m, skin.inverseBindMatrices, 16, false, out.source);
    if (inverse_bind.size() != skin.joints.size() * 16) fail(out.source, "skin '{}': inverse bind matrices and joints differ in count", skin.name);
    for (std::size_t j = 0; j < skin.joints.size(); ++j) {
        out.joint_names.push_back(m.nodes.at(std::size_t(skin.joints[j])).name);
        Eigen::Matrix4d ibm;
        for (int c = 0; c < 16; ++c) ibm(c % 4, c / 4) = inverse_bind[j * 16 + std::size_t(c)];  // column-major
        const Eigen::Matrix4d bind = ibm.inverse();
        out.joint_rest.push_back(from_yup(bind(0, 3), bind(1, 3), bind(2, 3)));
    }
    // Each joint's parent among the skin's joints (-1 for none), from the node tree.
    std::map<int, int> joint_of_node, parent_node;
    for (std::size_t j = 0; j < skin.joints.size(); ++j) joint_of_node[skin.joints[j]] = int(j);
    for (std::size_t n = 0; n < m.nodes.size(); ++n)
        for (int child : m.nodes[n].children) parent_node[child] = int(n);
    for (int node : skin.joints) {
        int parent = -1;
        for (auto at = parent_node.find(node); at != parent_node.end() && parent < 0; at = parent_node.find(at->second))
            if (auto j = joint_of_node.find(at->second); j != joint_of_node.end()) parent = j->second;
        out.joint_parent.push_back(parent);
    }
}

// ---- closing surfaces ----

}  // namespace


// ---- fitting to a take ----

struct SkinnedFit {
    // A joint of the take that drives the model: x -> position(f) + D(f) fit (x - anchor), where
    // D(f) turns the joint from its rest pose (every rotation channel 0) to frame f.
    struct Driver {
        int bvh_joint = 0;
        Eigen::Matrix3d fit = Eigen::Matrix3d::Identity();  // bind pose bone onto the rest pose bone, stretched
        Vec3 anchor = Vec3::Zero();                          // the model joint at the take's joint, in the fitted bind pose
        Eigen::Matrix3d rest_rotation = Eigen::Matrix3d::Identity();
    };
    std::vector<Vec3> rest;                          // fitted bind pose of the welded vertices
    std::vector<std::array<int, 4>> drivers;         // per welded vertex: index into `joints`
    std::vector<std::array<float, 4>> weights;
    std::vector<std::vector<std::uint32_t>> derived; // per vertex past the welded ones: the loop it is the mean of
    std::vector<Driver> joints;
    std::vector<SurfacePart> parts;                  // closed parts over the extended vertices (welded, then derived)
    std::vector<std::array<std::uint32_t, 3>> surface;  // the model's triangles between welded vertices (no caps)
    std::vector<std::string> roles;                     // per take joint
    Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();  // the file's axes to the scene's
    SkinnedFitSummary summary;
};

namespace {

// The model's chain joints (Unreal-mannequin names, as Mesh2Motion's) with the role each plays in
// the take (skeleton_roles' vocabulary), parents first. A role the take lacks falls back to the
// chain parent's; every other model joint (root, fingers, leaves) moves with its nearest chain
// ancestor. `stretch`: the bone is scaled to the take's length (not hands, feet, head, pelvis,
// whose mocap "bones" end at markers).
struct ChainJoint {
    const char* model;
    const char* parent;  // chain parent ("" for the pelvis)
    const char* role;
    bool stretch;
};
constexpr ChainJoint kChain[] = {
    {"pelvis", "", "Hips", false},
    {"spine_01", "pelvis", "LowerBack", true},
    {"spine_02", "spine_01", "Spine", true},
    {"spine_03", "spine_02", "Spine1", true},
    {"neck_01", "spine_03", "Neck", true},
    {"head", "neck_01", "Head", false},
    {"clavicle_l", "spine_03", "LeftShoulder", true},
    {"upperarm_l", "clavicle_l", "LeftArm", true},
    {"lowerarm_l", "upperarm_l", "LeftForeArm", true},
    {"hand_l", "lowerarm_l", "LeftHand", false},
    {"clavicle_r", "spine_03", "RightShoulder", true},
    {"upperarm_r", "clavicle_r", "RightArm", true},
    {"lowerarm_r", "upperarm_r", "RightForeArm", true},
    {"hand_r", "lowerarm_r", "RightHand", false},
    {"thigh_l", "pelvis", "LeftUpLeg", true},
    {"calf_l", "thigh_l", "LeftLeg", true},
    {"foot_l", "calf_l", "LeftFoot", false},
    {"ball_l", "foot_l", "LeftToeBase", false},
    {"thigh_r", "pelvis", "RightUpLeg", true},
    {"calf_r", "thigh_r", "RightLeg", true},
    {"foot_r", "calf_r", "RightFoot", false},
    {"ball_r", "foot_r", "RightToeBase", false},
};

// The rotation taking unit direction `from` onto `to` by the smallest angle.
Eigen::Matrix3d turn_onto(const Vec3& from, const Vec3& to) {
    return Eigen::Quaterniond::FromTwoVectors(from, to).toRotationMatrix();
}

struct TakeRest {
    std::vector<Vec3> position;             // per take joint, scene axes and metres
    std::vector<Eigen::Matrix3d> rotation;  // per take joint, scene axes
};

TakeRest take_rest_pose(const BvhMotion& motion, const UnitsAndAxes& units, const Eigen::Matrix3d& axes) {
    BvhMotion rest = motion;
    rest.frame_count = 1;
    rest.values.assign(std::size_t(motion.channel_count), 0.0);
    TakeRest out;
    for (const Eigen::Isometry3d& g : rest.global_transforms(0)) {
        out.position.push_back(to_scene_point(g.translation(), units));
        out.rotation.push_back(axes * g.linear() * axes.transpose());
    }
    return out;
}

// Per model joint: the chain joint it moves with (its own index when it is one).
std::vector<int> chain_owner(const SkinModel& model, const std::map<std::string, int>& chain_of_model,
                             const std::vector<int>& model_parent) {
    std::vector<int> owner(model.joint_names.size(), -1);
    for (std::size_t j = 0; j < owner.size(); ++j)
        for (int at = int(j); at >= 0 && owner[j] < 0; at = model_parent[std::size_t(at)])
            if (auto c = chain_of_model.find(model.joint_names[std::size_t(at)]); c != chain_of_model.end()) owner[j] = c->second;
    return owner;
}

}  // namespace

namespace {

int model_joint(const SkinModel& model, const std::string& name) {
    const auto at = std::find(model.joint_names.begin(), model.joint_names.end(), name);
    if (at == model.joint_names.end()) fail(model.source, "the body model has no joint '{}' (a Mesh2Motion human names it)", name);
    return int(at - model.joint_names.begin());
}

int chain_index(const char* model_name) {
    for (std::size_t i = 0; i < std::size(kChain); ++i)
        if (std::strcmp(kChain[i].model, model_name) == 0) return int(i);
    return -1;
}

// Per chain joint, the take joint it follows: its role, else its chain parent's.
std::vector<int> chain_take_joints(const std::vector<std::string>& roles, const std::string& source) {
    std::vector<int> take(std::size(kChain), -1);
    for (std::size_t i = 0; i < std::size(kChain); ++i) {
        const auto at = std::find(roles.begin(), roles.end(), kChain[i].role);
        if (at != roles.end()) take[i] = int(at - roles.begin());
        else if (i > 0) take[i] = take[std::size_t(chain_index(kChain[i].parent))];
        else fail(source, "no joint plays the role {}: the body model cannot be fitted", kChain[i].role);
    }
    return take;
}

// The mean position of a joint's children (model: by the skin's hierarchy; take: its bones that
// have a length), for the direction of a bone whose end the chain does not name (hand, head, toes).
Vec3 mean_child(const std::vector<Vec3>& positions, const std::vector<int>& parent, int joint, bool& found) {
    Vec3 sum = Vec3::Zero();
    int n = 0;
    for (std::size_t j = 0; j < parent.size(); ++j)
        if (parent[j] == joint && (positions[j] - positions[std::size_t(joint)]).norm() > 1e-4) sum += positions[j], ++n;
    found = n > 0;
    return n ? Vec3(sum / n) : positions[std::size_t(joint)];
}

struct FitFrame {
    const SkinModel& model;
    std::vector<Vec3> joints;      // fitted bind-pose model joints
    std::vector<int> take_parent;  // per take joint
    TakeRest take;
    std::vector<int> chain_take;
};

// The fit of the bone that starts at chain joint `i`: the bind pose bone turned onto the take's
// rest pose bone (the smallest turn) and, for limbs and spine, stretched to its length.
Eigen::Matrix3d bone_fit(const FitFrame& f, std::size_t i) {
    const int t = f.chain_take[i];
    std::size_t at = i;
    for (bool walked = true; walked;) {  // down the chain while the take joint stays the same
        walked = false;
        for (std::size_t k = at + 1; k < std::size(kChain); ++k)
            if (std::strcmp(kChain[k].parent, kChain[at].model) == 0) {
                if (f.chain_take[k] != t) {
                    const Vec3 u = f.joints[std::size_t(model_joint(f.model, kChain[k].model))] - f.joints[std::size_t(model_joint(f.model, kChain[i].model))];
                    const Vec3 d = f.take.position[std::size_t(f.chain_take[k])] - f.take.position[std::size_t(t)];
                    if (u.norm() < 1e-4 || d.norm() < 1e-4) return Eigen::Matrix3d::Identity();
                    const double s = kChain[i].stretch ? std::clamp(d.norm() / u.norm(), 0.5, 2.0) : 1.0;
                    const Vec3 axis = u.normalized();
                    return turn_onto(axis, d.normalized()) * (Eigen::Matrix3d::Identity() + (s - 1) * axis * axis.transpose());
                }
                at = k, walked = true;
                break;
            }
    }
    bool model_found = false, take_found = false;
    const int last = model_joint(f.model, kChain[at].model);
    const Vec3 u = mean_child(f.joints, f.model.joint_parent, last, model_found) - f.joints[std::size_t(model_joint(f.model, kChain[i].model))];
    const Vec3 d = mean_child(f.take.position, f.take_parent, t, take_found) - f.take.position[std::size_t(t)];
    if (!model_found || !take_found || u.norm() < 1e-4 || d.norm() < 1e-4) return Eigen::Matrix3d::Identity();
    return turn_onto(u.normalized(), d.normalized());
}

// Scale to the take's height (head over the feet) and turn about z so the hips face alike.
void place_bind_pose(FitFrame& f, std::vector<Vec3>& vertices, double& scale) {
    auto q = [&](const char* name) { return f.model.joint_rest[std::size_t(model_joint(f.model, name))]; };
    auto p = [&](const char* name) { return f.take.position[std::size_t(f.chain_take[std::size_t(chain_index(name))])]; };
    const double model_height = q("head").z() - 0.5 * (q("foot_l").z() + q("foot_r").z());
    const double take_height = p("head").z() - 0.5 * (p("foot_l").z() + p("foot_r").z());
    if (model_height < 0.1 || take_height < 0.1)
        fail(f.model.source, "cannot fit the body: the head is not above the feet in the take's rest pose ({:.3f} m)", take_height);
    scale = take_height / model_height;
    const Vec3 left_model = q("thigh_l") - q("thigh_r"), left_take = p("thigh_l") - p("thigh_r");
    const double turn = std::atan2(left_take.y(), left_take.x()) - std::atan2(left_model.y(), left_model.x());
    const Eigen::Matrix3d rz = Eigen::AngleAxisd(turn, Vec3::UnitZ()).toRotationMatrix();
    const Vec3 from = q("pelvis"), to = p("pelvis");
    auto place = [&](const Vec3& x) { return Vec3(to + scale * rz * (x - from)); };
    f.joints.clear();
    for (const Vec3& x : f.model.joint_rest) f.joints.push_back(place(x));
    vertices.clear();
    for (std::size_t v = 0; v < f.model.welded_vertices(); ++v) vertices.push_back(place(f.model.vertices[v]));
}

}  // namespace

std::shared_ptr<const SkinnedFit> fit_skin_model(const SkinModel& model, const BvhMotion& motion, const UnitsAndAxes& units) {
    auto fit = std::make_shared<SkinnedFit>();
    for (int c = 0; c < 3; ++c) fit->axes.col(c) = to_scene_direction(Vec3::Unit(c), units);
    const std::vector<std::string> roles = role_names(motion);
    fit->roles = roles;
    for (const auto& t : model.triangles)
        if (t[0] < model.welded_vertices() && t[1] < model.welded_vertices() && t[2] < model.welded_vertices()) fit->surface.push_back(t);
    FitFrame f{model, {}, {}, take_rest_pose(motion, units, fit->axes), chain_take_joints(roles, motion.source)};
    for (const BvhJoint& j : motion.joints) f.take_parent.push_back(j.parent);
    place_bind_pose(f, fit->rest, fit->summary.scale);

    // One driver per take joint the chain follows, anchored at the first chain joint that follows it.
    std::vector<int> driver_of_chain(std::size(kChain));
    std::map<int, int> driver_of_take;
    for (std::size_t i = 0; i < std::size(kChain); ++i) {
        const int t = f.chain_take[i];
        auto [at, added] = driver_of_take.emplace(t, int(fit->joints.size()));
        if (added)
            fit->joints.push_back({t, bone_fit(f, i), f.joints[std::size_t(model_joint(model, kChain[i].model))], f.take.rotation[std::size_t(t)]});
        driver_of_chain[i] = at->second;
    }
    std::map<std::string, int> chain_of_model;
    for (std::size_t i = 0; i < std::size(kChain); ++i) chain_of_model[kChain[i].model] = int(i);
    const std::vector<int> owner = chain_owner(model, chain_of_model, model.joint_parent);
    std::vector<int> driver_of_model(owner.size());
    for (std::size_t j = 0; j < owner.size(); ++j) {
        driver_of_model[j] = driver_of_chain[std::size_t(std::max(owner[j], 0))];  // the root moves with the pelvis
        fit->summary.joint_roles.push_back(roles[std::size_t(fit->joints[std::size_t(driver_of_model[j])].bvh_joint)]);
    }

    std::vector<std::string> vertex_part(model.vertices.size());
    for (std::size_t v = 0; v < model.welded_vertices(); ++v) {
        std::array<int, 4> d{};
        for (std::size_t c = 0; c < 4; ++c) d[c] = driver_of_model[std::size_t(model.joints[v][c])];
        fit->drivers.push_back(d);
        fit->weights.push_back(model.weights[v]);
        // The part of the driver that moves the vertex most (model joints one driver moves, such
        // as twist bones, summed; ties to the driver met first).
        std::map<int, float> per_driver;
        for (std::size_t c = 0; c < 4; ++c) per_driver[d[c]] += model.weights[v][c];
        int strongest = d[0];
        for (std::size_t c = 0; c < 4; ++c)
            if (per_driver[d[c]] > per_driver[strongest]) strongest = d[c];
        vertex_part[v] = skinned_body_part(roles[std::size_t(fit->joints[std::size_t(strongest)].bvh_joint)]);
    }
    fit->derived = model.derived;
    for (std::size_t k = 0; k < model.derived.size(); ++k) vertex_part[model.welded_vertices() + k] = vertex_part[model.derived[k].front()];
    fit->parts = split_into_parts(model.triangles, vertex_part, body_part_names(), model.source, fit->rest.size(), fit->derived, fit->summary.part_caps);
    fit->summary.capped_holes = model.capped_holes;
    return fit;
}

std::vector<BodyPart> skinned_body_parts(const SkinnedFit& fit, const BvhMotion& motion, int frame, const UnitsAndAxes& units) {
    const auto global = motion.global_transforms(frame);
    std::vector<Eigen::Matrix3d> linear(fit.joints.size());
    std::vector<Vec3> shift(fit.joints.size());
    for (std::size_t d = 0; d < fit.joints.size(); ++d) {
        const SkinnedFit::Driver& j = fit.joints[d];
        const Eigen::Isometry3d& g = global[std::size_t(j.bvh_joint)];
        linear[d] = fit.axes * g.linear() * fit.axes.transpose() * j.rest_rotation.transpose() * j.fit;
        shift[d] = to_scene_point(g.translation(), units) - linear[d] * j.anchor;
    }
    std::vector<Vec3> points(fit.rest.size(), Vec3::Zero());
    for (std::size_t v = 0; v < fit.rest.size(); ++v)
        for (std::size_t c = 0; c < 4; ++c) {
            if (fit.weights[v][c] == 0) continue;
            const std::size_t d = std::size_t(fit.drivers[v][c]);
            points[v] += double(fit.weights[v][c]) * (linear[d] * fit.rest[v] + shift[d]);
        }
    return posed_parts(fit.parts, std::move(points), fit.derived, motion.source, frame, "a non-finite joint position");
}

AnimatedSkin skinned_body_animation(const SkinnedFit& fit, const BvhMotion& motion, const FrameRange& range, const UnitsAndAxes& units) {
    AnimatedSkin out;
    out.vertices = fit.rest;
    out.triangles = fit.surface;
    out.joints = fit.drivers;
    out.weights = fit.weights;
    out.fps = motion.fps();
    std::map<int, int> driver_of_take;
    for (std::size_t d = 0; d < fit.joints.size(); ++d) driver_of_take[fit.joints[d].bvh_joint] = int(d);
    // Drivers in the take's order (parents first), each under the driver of its nearest driven ancestor.
    std::vector<int> order;
    for (const auto& [take_joint, d] : driver_of_take) order.push_back(d);
    std::vector<int> new_index(fit.joints.size());
    for (std::size_t k = 0; k < order.size(); ++k) new_index[std::size_t(order[k])] = int(k);
    for (int d : order) {
        const SkinnedFit::Driver& j = fit.joints[std::size_t(d)];
        int parent = -1;
        for (int a = motion.joints[std::size_t(j.bvh_joint)].parent; a >= 0 && parent < 0; a = motion.joints[std::size_t(a)].parent)
            if (auto at = driver_of_take.find(a); at != driver_of_take.end()) parent = new_index[std::size_t(at->second)];
        out.joint_names.push_back(fit.roles[std::size_t(j.bvh_joint)]);
        out.joint_parent.push_back(parent);
        Eigen::Affine3d bind = Eigen::Affine3d::Identity();
        bind.linear() = j.fit;
        bind.translation() = -(j.fit * j.anchor);
        out.inverse_bind.push_back(bind);
    }
    // The take's end sites below driven joints (the top of the head: the view track's eye) as
    // joints of their own that no vertex follows.
    std::vector<std::pair<int, int>> ends;  // take end site, its joint's index
    for (std::size_t k = 0; k < motion.joints.size(); ++k) {
        const BvhJoint& e = motion.joints[k];
        const auto at = e.end_site && e.parent >= 0 ? driver_of_take.find(e.parent) : driver_of_take.end();
        if (at == driver_of_take.end()) continue;
        ends.emplace_back(int(k), int(out.joint_names.size()));
        out.joint_names.push_back(fit.roles[k]);
        out.joint_parent.push_back(new_index[std::size_t(at->second)]);
        out.inverse_bind.push_back(Eigen::Affine3d::Identity());
    }
    // glTF wants each joint once per vertex: weights of model joints that one driver moves are summed.
    for (std::size_t v = 0; v < out.joints.size(); ++v) {
        std::map<int, float> merged;
        for (std::size_t k = 0; k < 4; ++k)
            if (out.weights[v][k] > 0) merged[new_index[std::size_t(out.joints[v][k])]] += out.weights[v][k];
        std::vector<std::pair<float, int>> ranked;
        for (const auto& [joint, weight] : merged) ranked.emplace_back(weight, joint);
        std::stable_sort(ranked.begin(), ranked.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
        out.joints[v] = {0, 0, 0, 0};
        out.weights[v] = {0, 0, 0, 0};
        for (std::size_t k = 0; k < ranked.size(); ++k) out.joints[v][k] = ranked[k].second, out.weights[v][k] = ranked[k].first;
    }
    for (int frame = range.first; frame <= range.last; ++frame) {
        const auto global = motion.global_transforms(frame);
        std::vector<Eigen::Isometry3d> pose;
        for (int d : order) {
            const SkinnedFit::Driver& j = fit.joints[std::size_t(d)];
            const Eigen::Isometry3d& g = global[std::size_t(j.bvh_joint)];
            Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
            t.linear() = fit.axes * g.linear() * fit.axes.transpose() * j.rest_rotation.transpose();
            t.translation() = to_scene_point(g.translation(), units);
            pose.push_back(t);
        }
        for (const auto& [k, index] : ends) {
            Eigen::Isometry3d t = pose[std::size_t(out.joint_parent[std::size_t(index)])];
            t.translation() = to_scene_point(global[std::size_t(k)].translation(), units);
            pose.push_back(t);
        }
        out.global.push_back(std::move(pose));
    }
    return out;
}

SkinnedFitSummary summarise(const SkinnedFit& fit) { return fit.summary; }

BodyKind parse_body_kind(const std::string& text, const std::string& what) {
    if (text == "capsules") return BodyKind::Capsules;
    if (text == "skinned") return BodyKind::Skinned;
    fail(what, "'{}' is not a body: use \"capsules\" or \"skinned\"", printable(text));
}

std::string to_string(BodyKind kind) { return kind == BodyKind::Skinned ? "skinned" : "capsules"; }

std::filesystem::path shipped_body_model() { return shipped_data_dir() / "bodies" / "human-male.glb"; }

SkinModel load_skin_model(const std::filesystem::path& path) {
    SkinModel out;
    out.source = path.string();
    if (!std::filesystem::is_regular_file(path)) fail(out.source, "the body model is missing (set AMHV_DATA_DIR to the folder holding bodies/)");
    tinygltf::Model m;
    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(&skip_image, nullptr);
    std::string err, warn;
    if (!loader.LoadBinaryFromFile(&m, &err, &warn, out.source)) fail(out.source, "not a readable glTF binary: {}", printable(err, 120));
    const tinygltf::Node* skinned = nullptr;
    for (const tinygltf::Node& n : m.nodes)
        if (n.mesh >= 0 && n.skin >= 0 && !skinned) skinned = &n;
    if (!skinned || skinned->mesh >= int(m.meshes.size()) || skinned->skin >= int(m.skins.size())) fail(out.source, "holds no skinned mesh");
    read_skin_joints(m, m.skins[std::size_t(skinned->skin)], out);
    read_skinned_mesh(m, m.meshes[std::size_t(skinned->mesh)], out);
    if (out.triangles.empty()) fail(out.source, "the skinned mesh has no triangles");
    drop_fins(out.triangles);
    // Close the surface: one fan per hole, around the hole's mean point.
    const auto holes = boundary_loops(out.triangles, out.source);
    cap_loops(holes, std::uint32_t(out.vertices.size()), out.triangles);
    for (const auto& loop : holes) {
        out.vertices.push_back(mean_of(out.vertices, loop));
        out.derived.push_back(loop);
    }
    out.capped_holes = int(holes.size());
    TriangleMesh check{out.vertices, out.triangles};
    if (!check.is_closed()) fail(out.source, "the surface is still open after capping its holes");
    return out;
}

}  // namespace amhv
