#include "src/body/character_body.hpp"

#include <algorithm>
#include <cctype>
#include <map>
#include <set>

#include "src/body/skeleton_roles.hpp"
#include "src/body/surface_caps.hpp"
#include "src/core/error.hpp"

namespace amhv {

std::vector<Vec3> skin_character_vertices(const CharacterFile& character, int frame) {
    CpuSkinner reference;
    return skin_frames(reference, skin_vertices(character), character, frame, frame, UnitsAndAxes{}).front();
}

TriangleMesh skin_character(const CharacterFile& character, int frame) { return {skin_character_vertices(character, frame), character.triangles}; }

std::string rig_joint_name(const std::string& name) {
    std::string n = name;
    if (const auto cut = n.find_last_of(":|"); cut != std::string::npos) n = n.substr(cut + 1);
    for (const char* prefix : {"DEF-", "DEF_", "ORG-", "MCH-"})
        if (n.rfind(prefix, 0) == 0) n = n.substr(std::char_traits<char>::length(prefix));
    // Rigify's human spine: spine ... spine.003 the torso, spine.004 and .005 the neck, spine.006 the head.
    if (n == "spine.004" || n == "spine.005") return n == "spine.004" ? "Neck" : "Neck1";
    if (n == "spine.006") return "Head";
    if (n.size() > 2 && (n[n.size() - 2] == '_' || n[n.size() - 2] == '.' || n[n.size() - 2] == ' ')) {
        const char side = char(std::tolower(static_cast<unsigned char>(n.back())));
        if (side == 'l') return "Left" + n.substr(0, n.size() - 2);
        if (side == 'r') return "Right" + n.substr(0, n.size() - 2);
    }
    return n;
}

struct CharacterBody {
    std::shared_ptr<const CharacterFile> file;
    SkinVertices skin;
    std::vector<std::uint32_t> welded;                 // per welded vertex, the file vertex it is
    std::vector<std::vector<std::uint32_t>> derived;   // per vertex past the welded ones: the loop it is the mean of
    std::vector<SurfacePart> parts;
    std::vector<int> joint_node;                       // per rig joint (parents first), its node
    std::vector<std::string> joint_role;
    std::vector<int> joint_parent;
    CharacterMapping mapping;
};

namespace {

// The rig: the nodes the bones follow and their ancestors below the deepest node common to all.
std::vector<int> rig_nodes(const CharacterFile& file) {
    std::vector<std::vector<int>> chains;
    std::set<int> bone_nodes;
    for (const CharacterBone& b : file.bones) bone_nodes.insert(b.node);
    for (int node : bone_nodes) {
        std::vector<int> chain;
        for (int n = node; n >= 0; n = file.nodes[std::size_t(n)].parent) chain.insert(chain.begin(), n);
        chains.push_back(std::move(chain));
    }
    std::size_t common = 0;  // depth of the deepest common ancestor
    while (std::all_of(chains.begin(), chains.end(), [&](const auto& c) { return c.size() > common + 1 && c[common + 1] == chains[0][common + 1]; }))
        ++common;
    std::set<int> keep;
    for (const auto& c : chains) keep.insert(c.begin() + std::ptrdiff_t(common), c.end());
    // Leaves below the bones that hold no mesh (a rig's "HeadTop_End"): the top of the head for the view track.
    for (std::size_t n = 0; n < file.nodes.size(); ++n)
        if (file.nodes[n].parent >= 0 && keep.count(file.nodes[n].parent) && bone_nodes.count(file.nodes[n].parent) && !file.nodes[n].holds_mesh)
            keep.insert(int(n));
    return {keep.begin(), keep.end()};  // node indices are parents first
}

void map_rig(CharacterBody& body, const std::map<std::string, std::string>& joint_roles) {
    const CharacterFile& file = *body.file;
    body.joint_node = rig_nodes(file);
    std::map<int, int> joint_of_node;
    BvhMotion rig;
    rig.source = file.source;
    // A prefix every joint's name shares up to a separator is the rig's namespace ("Armature_",
    // "mixamorig1:"), not part of any joint's name.
    std::string common = file.nodes[std::size_t(body.joint_node.front())].name;
    for (int node : body.joint_node) {
        const std::string& n = file.nodes[std::size_t(node)].name;
        common.resize(std::size_t(std::mismatch(common.begin(), common.end(), n.begin(), n.end()).first - common.begin()));
    }
    const std::size_t cut = common.find_last_of(":|_.-");
    const std::size_t strip = cut == std::string::npos || body.joint_node.size() < 2 ? 0 : cut + 1;
    for (int node : body.joint_node) {
        joint_of_node[node] = int(rig.joints.size());
        BvhJoint joint;
        const std::string& name = file.nodes[std::size_t(node)].name;
        const auto given = joint_roles.find(name);
        joint.name = given != joint_roles.end() ? given->second : rig_joint_name(name.substr(strip));
        const auto parent = joint_of_node.find(file.nodes[std::size_t(node)].parent);
        joint.parent = parent == joint_of_node.end() ? -1 : parent->second;
        rig.joints.push_back(joint);
        body.joint_parent.push_back(joint.parent);
    }
    try {
        body.joint_role = role_names(rig);
    } catch (const Error& e) {
        std::string what = e.what();
        if (what.rfind(file.source + ": ", 0) == 0) what = what.substr(file.source.size() + 2);
        std::string names;
        for (std::size_t j = 0; j < rig.joints.size() && j < 24; ++j) names += (j ? ", " : "") + printable(file.nodes[std::size_t(body.joint_node[j])].name, 30);
        fail(file.source, "{} (its rig's joints: {}{}; amhv maps Mixamo, Unreal mannequin, Rigify DEF- and CMU names; give others in the object's joints = {{ NAME = ROLE }})", what, names,
             rig.joints.size() > 24 ? ", ..." : "");
    }
}

// Each rig joint's part: its role's; a joint off the chains (a twist or helper bone) whose role
// says torso takes its parent's part when that is a limb's.
std::vector<std::string> joint_parts(const CharacterBody& body) {
    static const std::set<std::string> spine{"Hips", "LowerBack", "Spine", "Spine1", "Neck", "Head"};
    std::vector<std::string> parts(body.joint_role.size());
    for (std::size_t j = 0; j < parts.size(); ++j) {
        parts[j] = skinned_body_part(body.joint_role[j]);
        const int parent = body.joint_parent[j];
        if (parts[j] == "torso" && parent >= 0 && !spine.count(body.joint_role[j]) && !body.joint_role[j].starts_with("Neck") &&
            !body.joint_role[j].ends_with("Shoulder") && !body.joint_role[j].ends_with("HipJoint"))
            parts[j] = parts[std::size_t(parent)];
    }
    return parts;
}

// Welds the file's vertices by bind position, closes the surface and cuts it into parts.
void close_and_split(CharacterBody& body) {
    const CharacterFile& file = *body.file;
    const std::vector<std::string> by_joint = joint_parts(body);
    std::map<int, std::string> part_of_node;
    for (std::size_t j = 0; j < by_joint.size(); ++j) part_of_node[body.joint_node[j]] = by_joint[j];
    auto node_part = [&](int node) {
        for (int n = node; n >= 0; n = file.nodes[std::size_t(n)].parent)
            if (auto at = part_of_node.find(n); at != part_of_node.end()) return at->second;
        return std::string("prop");
    };
    std::map<std::array<double, 3>, std::uint32_t> weld;
    std::vector<std::uint32_t> to_welded(file.vertices.size());
    std::vector<std::string> vertex_part;
    for (std::size_t v = 0; v < file.vertices.size(); ++v) {
        const Vec3& p = file.vertices[v];
        auto [at, added] = weld.emplace(std::array<double, 3>{p.x(), p.y(), p.z()}, std::uint32_t(body.welded.size()));
        if (added) {
            body.welded.push_back(std::uint32_t(v));
            const int node = file.rigid_node[v] >= 0 ? file.rigid_node[v] : file.bones[std::size_t(file.vertex_bones[v][0])].node;
            vertex_part.push_back(node_part(node));
        }
        to_welded[v] = at->second;
    }
    std::vector<std::array<std::uint32_t, 3>> triangles;
    for (const auto& t : file.triangles) {
        const std::array<std::uint32_t, 3> w{to_welded[t[0]], to_welded[t[1]], to_welded[t[2]]};
        if (w[0] != w[1] && w[1] != w[2] && w[0] != w[2]) triangles.push_back(w);
    }
    drop_fins(triangles);
    const auto holes = boundary_loops(triangles, file.source);
    cap_loops(holes, std::uint32_t(body.welded.size()), triangles);
    body.derived = holes;
    for (const auto& loop : holes) vertex_part.push_back(vertex_part[loop.front()]);
    body.mapping.capped_holes = int(holes.size());
    body.parts = split_into_parts(triangles, vertex_part, body_part_names(), file.source, body.welded.size(), body.derived, body.mapping.part_caps);
    for (std::size_t j = 0; j < by_joint.size(); ++j) {
        const std::string& name = file.nodes[std::size_t(body.joint_node[j])].name;
        body.mapping.joint_roles.emplace_back(name, body.joint_role[j]);
        body.mapping.joint_parts.emplace_back(name, by_joint[j]);
    }
    for (const SurfacePart& part : body.parts) body.mapping.parts.push_back(part.name);
}

}  // namespace

std::shared_ptr<const CharacterBody> build_character_body(std::shared_ptr<const CharacterFile> file,
                                                          const std::map<std::string, std::string>& joint_roles) {
    auto body = std::make_shared<CharacterBody>();
    body->file = std::move(file);
    body->skin = skin_vertices(*body->file);
    map_rig(*body, joint_roles);
    close_and_split(*body);
    return body;
}

const CharacterMapping& character_mapping(const CharacterBody& body) { return body.mapping; }
const CharacterFile& character_file(const CharacterBody& body) { return *body.file; }
const SkinVertices& character_skin(const CharacterBody& body) { return body.skin; }

std::vector<BodyPart> character_body_parts(const CharacterBody& body, int frame, const UnitsAndAxes& units) {
    CpuSkinner reference;
    return character_body_parts(body, skin_frames(reference, body.skin, *body.file, frame, frame, units).front(), frame);
}

std::vector<BodyPart> character_body_parts(const CharacterBody& body, const std::vector<Vec3>& skinned, int frame) {
    std::vector<Vec3> points(body.welded.size());
    for (std::size_t v = 0; v < body.welded.size(); ++v) points[v] = skinned[body.welded[v]];
    return posed_parts(body.parts, std::move(points), body.derived, body.file->source, frame, "a vertex that is not finite");
}

JointFrames character_joints(const CharacterBody& body) {
    JointFrames joints{body.file->source, body.joint_role, body.joint_parent, body.file->frame_count(), 0, {}};
    joints.globals = [&body](int f) {
        const std::vector<Eigen::Affine3d> all = body.file->globals(f);
        std::vector<Eigen::Affine3d> out;
        out.reserve(body.joint_node.size());
        for (int node : body.joint_node) out.push_back(all[std::size_t(node)]);
        return out;
    };
    return joints;
}

std::vector<TrackSample> character_track(const CharacterBody& body, const UnitsAndAxes& units) { return joints_track(character_joints(body), units); }

}  // namespace amhv
