#include "src/results/scene_glb.hpp"

#include <array>
#include <cstring>
#include <limits>
#include <map>
#include <tuple>

#include <fmt/format.h>
#include <tiny_gltf.h>

#include "src/body/character_body.hpp"
#include "src/core/error.hpp"
#include "src/results/glb_builder.hpp"
#include "src/io/files.hpp"
#include "src/io/obj_appearance.hpp"
#include "src/results/appearance_files.hpp"
#include "src/results/edit_files.hpp"

namespace amhv {

namespace {

// The performers' colours, as in the PLY frames and the pictures (A orange, B blue, then green,
// purple, yellow, red, cycling), linear.
constexpr std::array<std::array<double, 4>, 6> kBaseColour{
    {{0.79, 0.19, 0.02, 1.0}, {0.02, 0.19, 0.79, 1.0}, {0.045, 0.40, 0.08, 1.0}, {0.30, 0.08, 0.51, 1.0}, {0.72, 0.51, 0.02, 1.0}, {0.58, 0.045, 0.10, 1.0}}};

// One material per performer, first: material o is performer o's colour.
void add_materials(tinygltf::Model& model, const std::vector<GlbObject>& objects) {
    for (std::size_t o = 0; o < objects.size(); ++o) {
        tinygltf::Material m;
        m.name = objects[o].name;
        m.pbrMetallicRoughness.baseColorFactor = {kBaseColour[o % kBaseColour.size()].begin(), kBaseColour[o % kBaseColour.size()].end()};
        m.pbrMetallicRoughness.metallicFactor = 0.0;
        m.pbrMetallicRoughness.roughnessFactor = 0.8;
        model.materials.push_back(m);
    }
}

// glTF's y-up axes: the scene's (x, y, z) as (x, z, -y).
void push_yup(std::vector<float>& out, const Vec3& v) { out.insert(out.end(), {float(v.x()), float(v.z()), float(-v.y())}); }

// The materials and images of OBJ input, each written once: a material per distinct (performer,
// name, colour, texture), an image per texture file (embedded, PNG or JPEG as glTF requires).
class AppearanceMaterials {
public:
    AppearanceMaterials(tinygltf::Model& model, GlbBuilder& glb, const std::vector<GlbObject>& objects) : model_(model), glb_(glb), objects_(objects) {}

    int material(int object, const ObjAppearance& obj, const std::string& name) {
        const auto at = obj.materials.find(name);
        if (at == obj.materials.end()) return object;  // no material: the performer's colour
        const ObjMaterial& m = at->second;
        const auto key = std::make_tuple(object, name, m.colour, m.texture.string());
        if (auto known = materials_.find(key); known != materials_.end()) return known->second;
        tinygltf::Material out;
        out.name = fmt::format("{} {}", objects_[std::size_t(object)].name, name);
        out.pbrMetallicRoughness.baseColorFactor = {m.colour.begin(), m.colour.end()};
        out.pbrMetallicRoughness.metallicFactor = 0.0;
        out.pbrMetallicRoughness.roughnessFactor = 0.8;
        if (m.colour[3] < 1.0) out.alphaMode = "BLEND";
        if (!m.texture.empty()) out.pbrMetallicRoughness.baseColorTexture.index = texture(m.texture);
        model_.materials.push_back(out);
        return materials_[key] = int(model_.materials.size()) - 1;
    }

    // A character's material m (-1: none, the performer's colour): its colour and texture.
    int character_material(int object, const CharacterFile& file, int m) {
        if (m < 0) return object;
        const auto key = std::make_pair(object, m);
        if (auto known = character_materials_.find(key); known != character_materials_.end()) return known->second;
        const CharacterMaterial& in = file.materials[std::size_t(m)];
        tinygltf::Material out;
        out.name = objects_[std::size_t(object)].name + " " + in.name;
        out.pbrMetallicRoughness.baseColorFactor = {in.colour.begin(), in.colour.end()};
        out.pbrMetallicRoughness.metallicFactor = 0.0;
        out.pbrMetallicRoughness.roughnessFactor = 0.8;
        if (!in.texture.empty() && file.has_uvs) {
            tinygltf::Image image;
            image.name = in.texture_name;
            image.mimeType = in.texture_mime;
            image.bufferView = glb_.view(in.texture.data(), in.texture.size(), 0);
            model_.images.push_back(image);
            tinygltf::Texture t;
            t.source = int(model_.images.size()) - 1;
            model_.textures.push_back(t);
            out.pbrMetallicRoughness.baseColorTexture.index = int(model_.textures.size()) - 1;
        }
        model_.materials.push_back(out);
        return character_materials_[key] = int(model_.materials.size()) - 1;
    }

private:
    int texture(const std::filesystem::path& file) {
        if (auto known = textures_.find(file); known != textures_.end()) return known->second;
        const std::string bytes = read_file_bytes(file);
        tinygltf::Image image;
        image.name = file.filename().string();
        if (bytes.rfind("\x89PNG", 0) == 0) image.mimeType = "image/png";
        else if (bytes.rfind("\xFF\xD8\xFF", 0) == 0) image.mimeType = "image/jpeg";
        else fail(file.string(), "scene.glb embeds PNG and JPEG textures only (glTF 2.0); convert it, or pass --no-glb");
        image.bufferView = glb_.view(bytes.data(), bytes.size(), 0);
        model_.images.push_back(image);
        tinygltf::Texture t;
        t.source = int(model_.images.size()) - 1;
        model_.textures.push_back(t);
        return textures_[file] = int(model_.textures.size()) - 1;
    }

    tinygltf::Model& model_;
    GlbBuilder& glb_;
    const std::vector<GlbObject>& objects_;
    std::map<std::tuple<int, std::string, std::array<double, 4>, std::string>, int> materials_;
    std::map<std::filesystem::path, int> textures_;
    std::map<std::pair<int, int>, int> character_materials_;
};

// The scene position of a source frame's file coordinates at output frame k.
Vec3 placed_point(const ObjectFrameEdit& e, const UnitsAndAxes& units, const Vec3& p) {
    const Vec3 s = to_scene_point(p, units);
    const Eigen::Vector2d xy = Eigen::Rotation2Dd(e.yaw) * Eigen::Vector2d(s.x(), s.y()) + e.translation;
    return {xy.x(), xy.y(), s.z() + e.lift};
}

// One primitive per material of an OBJ frame: corners with the same (v, vt, vn) share a glTF
// vertex; the file's normals turned with the performer (area-weighted ones where a corner has
// none); texture coordinates with v flipped (OBJ's origin is bottom left, glTF's top left).
std::vector<tinygltf::Primitive> textured_primitives(GlbBuilder& glb, AppearanceMaterials& materials, const ObjAppearance& obj, int object,
                                                     const ObjectFrameEdit& e, const UnitsAndAxes& units) {
    std::vector<Vec3> placed, area_normal(obj.positions.size(), Vec3::Zero());
    for (const Vec3& p : obj.positions) placed.push_back(placed_point(e, units, p));
    for (const auto& [name, triangles] : obj.by_material)
        for (const auto& t : triangles) {
            const Vec3 n = (placed[std::size_t(t[1].v)] - placed[std::size_t(t[0].v)]).cross(placed[std::size_t(t[2].v)] - placed[std::size_t(t[0].v)]);
            for (const ObjCorner& c : t) area_normal[std::size_t(c.v)] += n;
        }
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(e.yaw, Vec3::UnitZ()).toRotationMatrix();
    const bool flip = units.map().reflects();
    std::vector<tinygltf::Primitive> out;
    for (const auto& [name, triangles] : obj.by_material) {
        std::map<std::tuple<int, int, int>, std::uint32_t> vertex_of;
        std::vector<float> positions, normals, uvs;
        std::vector<std::uint32_t> indices;
        for (const auto& t : triangles)
            for (const ObjCorner& c : {t[0], t[flip ? 2 : 1], t[flip ? 1 : 2]}) {  // a reflected file's triangles turn round
                auto [at, added] = vertex_of.emplace(std::make_tuple(c.v, c.vt, c.vn), std::uint32_t(vertex_of.size()));
                indices.push_back(at->second);
                if (!added) continue;
                push_yup(positions, placed[std::size_t(c.v)]);
                Vec3 n = c.vn >= 0 ? Vec3(turn * to_scene_direction(obj.normals[std::size_t(c.vn)], units)) : area_normal[std::size_t(c.v)];
                push_yup(normals, n.norm() > 0 ? Vec3(n.normalized()) : Vec3::UnitZ());
                const std::array<double, 2> uv = c.vt >= 0 ? obj.texcoords[std::size_t(c.vt)] : std::array<double, 2>{0.0, 0.0};
                uvs.insert(uvs.end(), {float(uv[0]), float(1.0 - uv[1])});
            }
        tinygltf::Primitive p;
        p.attributes = {{"POSITION", glb.attribute(positions, 3, true)}, {"NORMAL", glb.attribute(normals, 3, false)}};
        if (!obj.texcoords.empty()) p.attributes["TEXCOORD_0"] = glb.attribute(uvs, 2, false);
        p.indices = glb.indices32(indices);
        p.material = materials.material(object, obj, name);
        p.mode = TINYGLTF_MODE_TRIANGLES;
        out.push_back(p);
    }
    return out;
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

// One frame node of one performer: its mesh (OBJ appearance kept), shown on output frame k only.
// The performer's last triangle list is shared while its triangles stay the same.
struct PerformerTrack {
    std::vector<std::array<std::uint32_t, 3>> last_triangles;
    int last_indices = -1;
    bool textured = false;
    const CharacterFile* character = nullptr;
    // A character's primitives' shared parts, written at its first frame: per material its
    // triangles' indices, the texture coordinates (-1: none), the material.
    std::vector<std::pair<int, int>> character_indices;  // (indices accessor, material)
    int character_uvs = -1;
};

// A character's frame: one primitive per material of the file's surface, sharing the frame's
// positions and normals; texture coordinates and each material's triangles written once for all
// frames (v flipped: assimp's origin is bottom left, glTF's top left).
void add_character_primitives(GlbBuilder& glb, AppearanceMaterials& materials, const TriangleMesh& mesh, int o, PerformerTrack& track,
                              tinygltf::Mesh& m, SceneGlbReport& report) {
    const CharacterFile& file = *track.character;
    if (track.character_indices.empty()) {
        std::map<int, std::vector<std::uint32_t>> by_material;
        for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
            std::vector<std::uint32_t>& indices = by_material[file.triangle_material[t]];
            indices.insert(indices.end(), mesh.triangles[t].begin(), mesh.triangles[t].end());
        }
        for (const auto& [material, indices] : by_material) {
            track.character_indices.push_back({glb.indices32(indices), materials.character_material(o, file, material)});
            ++report.index_accessors;
        }
        if (file.has_uvs) {
            std::vector<float> uvs;
            for (const auto& uv : file.uvs) uvs.insert(uvs.end(), {uv[0], 1.0f - uv[1]});
            track.character_uvs = glb.attribute(uvs, 2, false);
        }
    }
    const auto [positions, normals] = glb.vertices(mesh);
    for (const auto& [indices, material] : track.character_indices) {
        tinygltf::Primitive primitive;
        primitive.attributes = {{"POSITION", positions}, {"NORMAL", normals}};
        if (track.character_uvs >= 0) primitive.attributes["TEXCOORD_0"] = track.character_uvs;
        primitive.indices = indices;
        primitive.material = material;
        primitive.mode = TINYGLTF_MODE_TRIANGLES;
        m.primitives.push_back(primitive);
    }
}

bool add_frame_mesh(GlbBuilder& glb, AppearanceMaterials& materials, const GlbObject& object, const TriangleMesh& mesh, int o, int k,
                    PerformerTrack& track, tinygltf::Mesh& m, SceneGlbReport& report) {
    const ObjectFrameEdit& e = (*object.frames)[std::size_t(k)];
    m.name = fmt::format("{} frame {:04d} src {:04d}", object.name, k, e.source);
    if (track.textured) {
        const ObjAppearance obj = read_obj_appearance(source_frame_file(*object.source, e.source), object.source->spec().files_root);
        m.primitives = textured_primitives(glb, materials, obj, o, e, object.source->spec().units);
        report.index_accessors += int(m.primitives.size());
        return !m.primitives.empty();
    }
    if (mesh.triangles.empty()) return false;
    if (track.character) {
        add_character_primitives(glb, materials, mesh, o, track, m, report);
        return true;
    }
    if (track.last_indices < 0 || mesh.triangles != track.last_triangles) {
        track.last_indices = glb.indices(mesh);
        track.last_triangles = mesh.triangles;
        ++report.index_accessors;
    }
    const auto [positions, normals] = glb.vertices(mesh);
    tinygltf::Primitive primitive;
    primitive.attributes = {{"POSITION", positions}, {"NORMAL", normals}};
    primitive.indices = track.last_indices;
    primitive.material = o;
    primitive.mode = TINYGLTF_MODE_TRIANGLES;
    m.primitives.push_back(primitive);
    return true;
}

}  // namespace

SceneGlbReport write_scene_glb(const std::filesystem::path& path, const std::vector<GlbObject>& objects, double fps) {
    return write_scene_glb(path, objects, gather_glb_meshes(objects), fps);
}

GlbMeshes gather_glb_meshes(const std::vector<GlbObject>& objects) {
    const std::size_t frames = objects.empty() ? 0 : objects.front().frames->size();
    GlbMeshes meshes(frames, std::vector<TriangleMesh>(objects.size()));
    for (std::size_t o = 0; o < objects.size(); ++o) {
        if (has_obj_appearance(*objects[o].source)) continue;
        for (std::size_t k = 0; k < frames; ++k) {
            const ObjectFrameEdit& e = (*objects[o].frames)[k];
            if (!objects[o].source->character()) {
                meshes[k][o] = placed_mesh(e, *objects[o].source);
                continue;
            }
            meshes[k][o] = moved_into_scene(objects[o].source->character_surface(e.source), e.yaw, e.translation, e.lift);
            if (objects[o].source->spec().units.map().reflects())  // a reflected file's triangles turn round
                for (auto& t : meshes[k][o].triangles) std::swap(t[1], t[2]);
        }
    }
    return meshes;
}

SceneGlbReport write_scene_glb(const std::filesystem::path& path, const std::vector<GlbObject>& objects, const GlbMeshes& meshes, double fps) {
    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = std::string("amhv ") + AMHV_VERSION;
    add_materials(model, objects);
    GlbBuilder glb(model);
    tinygltf::Animation play;
    play.name = "play";
    tinygltf::Node root;
    root.name = "amhv edited scene";
    SceneGlbReport report;
    std::vector<PerformerTrack> tracks(objects.size());
    for (std::size_t o = 0; o < objects.size(); ++o) {
        tracks[o].textured = has_obj_appearance(*objects[o].source);
        if (const CharacterBody* character = objects[o].source->character()) tracks[o].character = &character_file(*character);
    }
    AppearanceMaterials materials(model, glb, objects);
    const int frames = objects.empty() ? 0 : int(objects.front().frames->size());
    for (int k = 0; k < frames; ++k) {
        const int sampler = frame_sampler(glb, play, k, frames, fps);
        for (std::size_t o = 0; o < objects.size(); ++o) {
            tinygltf::Mesh m;
            if (!add_frame_mesh(glb, materials, objects[o], meshes.at(std::size_t(k)).at(o), int(o), k, tracks[o], m, report)) continue;
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
