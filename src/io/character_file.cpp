#include "src/io/character_file.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <type_traits>
#include <map>

#include <assimp/DefaultIOSystem.h>
#include <assimp/IOStream.hpp>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <spdlog/spdlog.h>

#include "src/core/contained.hpp"
#include "src/core/error.hpp"
#include "src/io/output_dir.hpp"

namespace fs = std::filesystem;

namespace amhv {

namespace {

// assimp's file access, confined to the character's folder: a buffer, image or texture a file
// names outside it (an absolute path, "..", a link leading out) is not opened.
class ConfinedIOSystem : public Assimp::DefaultIOSystem {
public:
    explicit ConfinedIOSystem(fs::path folder) : folder_(std::move(folder)) {}
    bool Exists(const char* file) const override { return inside(file) && DefaultIOSystem::Exists(file); }
    Assimp::IOStream* Open(const char* file, const char* mode) override {
        if (std::string(mode).find_first_of("wa+") != std::string::npos || !inside(file)) return nullptr;
        return DefaultIOSystem::Open(file, mode);
    }

private:
    bool inside(const char* file) const {
        std::error_code ec;
        const fs::path path = fs::weakly_canonical(fs::absolute(file, ec), ec);
        return !ec && is_within(path, folder_);
    }
    fs::path folder_;
};

Eigen::Affine3d to_affine(const aiMatrix4x4& m) {
    Eigen::Matrix4d e;
    for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) e(r, c) = double(m[r][c]);
    return Eigen::Affine3d(e);
}

bool finite(const Eigen::Affine3d& a) { return a.matrix().allFinite(); }

// The hierarchy, parents first, with each assimp node's index.
void collect_nodes(const aiNode* node, int parent, CharacterFile& out, std::map<const aiNode*, int>& index, const std::string& source) {
    if (out.nodes.size() >= std::size_t(kMaxCharacterJoints))
        fail(source, "has more than {} nodes; amhv reads characters up to that many joints", kMaxCharacterJoints);
    const Eigen::Affine3d rest = to_affine(node->mTransformation);
    if (!finite(rest)) fail(source, "node {} has a transform that is not finite", printable(node->mName.C_Str()));
    index[node] = int(out.nodes.size());
    out.nodes.push_back({node->mName.C_Str(), parent, rest, node->mNumMeshes > 0});
    const int self = int(out.nodes.size()) - 1;
    for (unsigned c = 0; c < node->mNumChildren; ++c) collect_nodes(node->mChildren[c], self, out, index, source);
}

int node_named(const CharacterFile& out, const std::string& name) {
    for (std::size_t n = 0; n < out.nodes.size(); ++n)
        if (out.nodes[n].name == name) return int(n);
    return -1;
}

// Vertex v's first texture coordinates, (0, 0) when the mesh has none or they are not finite.
void add_uv(const aiMesh& mesh, unsigned v, CharacterFile& out) {
    std::array<float, 2> uv{0.0f, 0.0f};
    if (mesh.HasTextureCoords(0)) {
        const aiVector3D& t = mesh.mTextureCoords[0][v];
        if (std::isfinite(t.x) && std::isfinite(t.y)) uv = {float(t.x), float(t.y)};
        out.has_uvs = true;
    }
    out.uvs.push_back(uv);
}

// "image/png" or "image/jpeg" from the bytes' signature, else empty.
std::string image_mime(const unsigned char* bytes, std::size_t size) {
    static constexpr unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (size >= 8 && std::equal(bytes, bytes + 8, kPng)) return "image/png";
    if (size >= 3 && bytes[0] == 0xFF && bytes[1] == 0xD8 && bytes[2] == 0xFF) return "image/jpeg";
    return {};
}

// The texture's bytes: embedded in the file, or a file inside the character's folder (through the
// confined IO system); else a note of why not.
void read_texture(const aiScene& scene, Assimp::IOSystem& io, const fs::path& folder, CharacterMaterial& m) {
    std::vector<unsigned char> bytes;
    if (const aiTexture* embedded = scene.GetEmbeddedTexture(m.texture_name.c_str())) {
        if (embedded->mHeight != 0) {
            m.texture_note = "is embedded as raw texels, not PNG or JPEG";
            return;
        }
        const auto* data = reinterpret_cast<const unsigned char*>(embedded->pcData);
        bytes.assign(data, data + std::min<std::size_t>(embedded->mWidth, kMaxCharacterTextureBytes + 1));
    } else {
        std::unique_ptr<Assimp::IOStream> file(io.Open((folder / m.texture_name).string().c_str(), "rb"));
        if (!file) {
            m.texture_note = "is not a file inside the character's folder";
            return;
        }
        bytes.resize(std::min<std::size_t>(file->FileSize(), kMaxCharacterTextureBytes + 1));
        bytes.resize(file->Read(bytes.data(), 1, bytes.size()));
    }
    if (bytes.size() > kMaxCharacterTextureBytes) m.texture_note = fmt::format("is over {} MiB", kMaxCharacterTextureBytes >> 20);
    else if ((m.texture_mime = image_mime(bytes.data(), bytes.size())).empty()) m.texture_note = "is not a PNG or JPEG image (glTF 2.0 takes those)";
    else m.texture = std::move(bytes);
}

// Every material's base colour and base colour texture.
void read_materials(const aiScene& scene, Assimp::IOSystem& io, const fs::path& folder, CharacterFile& out) {
    for (unsigned i = 0; i < scene.mNumMaterials; ++i) {
        const aiMaterial& material = *scene.mMaterials[i];
        CharacterMaterial m;
        m.name = material.GetName().C_Str();
        aiColor4D colour;
        if (material.Get(AI_MATKEY_BASE_COLOR, colour) == AI_SUCCESS || material.Get(AI_MATKEY_COLOR_DIFFUSE, colour) == AI_SUCCESS) {
            const std::array<double, 4> c{double(colour.r), double(colour.g), double(colour.b), double(colour.a)};
            if (std::all_of(c.begin(), c.end(), [](double x) { return std::isfinite(x) && x >= 0 && x <= 1; })) m.colour = c;
        }
        aiString texture;
        if (material.GetTexture(aiTextureType_BASE_COLOR, 0, &texture) == AI_SUCCESS || material.GetTexture(aiTextureType_DIFFUSE, 0, &texture) == AI_SUCCESS) {
            m.texture_name = texture.C_Str();
            read_texture(scene, io, folder, m);
            if (!m.texture_note.empty())
                spdlog::warn("{}: material {}: texture {} {}; scene.glb gives it its colour alone", out.source, printable(m.name), printable(m.texture_name), m.texture_note);
        }
        out.materials.push_back(std::move(m));
    }
    // A material assimp made up for a file that has none (unnamed or "DefaultMaterial", no texture)
    // is none: the performer's colour shows instead of assimp's white.
    auto stand_in = [&](int m) {
        const CharacterMaterial& material = out.materials[std::size_t(m)];
        return (material.name.empty() || material.name == AI_DEFAULT_MATERIAL_NAME) && material.texture_name.empty();
    };
    for (int& m : out.triangle_material)
        if (m < 0 || m >= int(out.materials.size()) || stand_in(m)) m = -1;
}

// One skinned mesh's vertices, triangles and weights (the four largest, renormalised).
void add_skinned_mesh(const aiMesh& mesh, CharacterFile& out, const std::string& source) {
    const std::uint32_t base = std::uint32_t(out.vertices.size());
    const std::string what = fmt::format("{} mesh {}", source, printable(mesh.mName.C_Str()));
    std::vector<std::vector<std::pair<double, int>>> influences(mesh.mNumVertices);
    for (unsigned b = 0; b < mesh.mNumBones; ++b) {
        const aiBone& bone = *mesh.mBones[b];
        const int node = node_named(out, bone.mName.C_Str());
        if (node < 0) fail(what, "bone {} names no node of the hierarchy", printable(bone.mName.C_Str()));
        const Eigen::Affine3d offset = to_affine(bone.mOffsetMatrix);
        if (!finite(offset)) fail(what, "bone {} has an offset matrix that is not finite", printable(bone.mName.C_Str()));
        out.bones.push_back({node, offset});
        for (unsigned w = 0; w < bone.mNumWeights; ++w) {
            const aiVertexWeight& vw = bone.mWeights[w];
            if (vw.mVertexId >= mesh.mNumVertices) fail(what, "bone {} weighs vertex {}, past the mesh's {}", printable(bone.mName.C_Str()), vw.mVertexId, mesh.mNumVertices);
            if (!std::isfinite(vw.mWeight) || vw.mWeight < 0)
                fail(what, "vertex {} has a weight that is not a finite non-negative number ({})", vw.mVertexId, vw.mWeight);
            if (vw.mWeight > 0) influences[vw.mVertexId].push_back({double(vw.mWeight), int(out.bones.size()) - 1});
        }
    }
    for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
        const aiVector3D& p = mesh.mVertices[v];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) fail(what, "vertex {} is not finite", v);
        auto& in = influences[v];
        // Largest weight first; ties by bone, so that the choice does not depend on the file's order.
        std::sort(in.begin(), in.end(), [](const auto& a, const auto& b) { return a.first != b.first ? a.first > b.first : a.second < b.second; });
        double sum = 0;
        for (std::size_t k = 0; k < std::min<std::size_t>(4, in.size()); ++k) sum += in[k].first;
        if (!(sum > 0)) fail(what, "vertex {} has no weight (its weights sum to 0): every vertex of a skinned mesh must follow a joint", v);
        std::array<int, 4> bones{-1, -1, -1, -1};
        std::array<double, 4> weights{0, 0, 0, 0};
        for (std::size_t k = 0; k < std::min<std::size_t>(4, in.size()); ++k) bones[k] = in[k].second, weights[k] = in[k].first / sum;
        out.vertices.emplace_back(double(p.x), double(p.y), double(p.z));
        add_uv(mesh, v, out);
        out.vertex_bones.push_back(bones);
        out.vertex_weights.push_back(weights);
        out.rigid_node.push_back(-1);
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
        const aiFace& face = mesh.mFaces[f];
        if (face.mNumIndices != 3) continue;  // points and lines left by triangulation
        out.triangles.push_back({base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]});
        out.triangle_material.push_back(int(mesh.mMaterialIndex));
    }
}

// An unskinned mesh rides rigidly on the node that holds it.
void add_rigid_mesh(const aiMesh& mesh, int node, CharacterFile& out, const std::string& source) {
    const std::uint32_t base = std::uint32_t(out.vertices.size());
    for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
        const aiVector3D& p = mesh.mVertices[v];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) fail(source, "mesh {} vertex {} is not finite", printable(mesh.mName.C_Str()), v);
        out.vertices.emplace_back(double(p.x), double(p.y), double(p.z));
        add_uv(mesh, v, out);
        out.vertex_bones.push_back({-1, -1, -1, -1});
        out.vertex_weights.push_back({0, 0, 0, 0});
        out.rigid_node.push_back(node);
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f)
        if (mesh.mFaces[f].mNumIndices == 3) {
            out.triangles.push_back({base + mesh.mFaces[f].mIndices[0], base + mesh.mFaces[f].mIndices[1], base + mesh.mFaces[f].mIndices[2]});
            out.triangle_material.push_back(int(mesh.mMaterialIndex));
        }
}

template <typename Key, typename Value, typename Lerp>
Value sample_keys(const Key* keys, unsigned count, double tick, const Value& rest, const Lerp& lerp) {
    if (count == 0) return rest;
    if (tick <= keys[0].mTime) return keys[0].mValue;
    if (tick >= keys[count - 1].mTime) return keys[count - 1].mValue;
    const Key* next = std::upper_bound(keys, keys + count, tick, [](double t, const Key& k) { return t < k.mTime; });
    const Key* prev = next - 1;
    const double span = next->mTime - prev->mTime;
    return lerp(prev->mValue, next->mValue, span > 0 ? (tick - prev->mTime) / span : 0.0);
}

// The animation sampled every 1/fps seconds into each node's local transform.
void sample_animation(const aiAnimation& anim, CharacterFile& out) {
    const double ticks_per_second = anim.mTicksPerSecond > 0 ? anim.mTicksPerSecond : 25.0;  // assimp's default
    const double seconds = anim.mDuration / ticks_per_second;
    if (!std::isfinite(seconds) || seconds < 0) fail(out.source, "animation {} has a duration that is not a finite time", printable(out.animation));
    // Key times are often floats (assimp keeps them so): a duration within a thousandth of a frame
    // of a whole number of frames is that number.
    const double count = std::floor(seconds * out.fps + 1e-3) + 1;
    if (count > kMaxCharacterFrames) fail(out.source, "animation {} is {:.1f} s long: over {} frames at {} fps", printable(out.animation), seconds, kMaxCharacterFrames, out.fps);
    std::vector<const aiNodeAnim*> channel(out.nodes.size(), nullptr);
    for (unsigned c = 0; c < anim.mNumChannels; ++c) {
        const int node = node_named(out, anim.mChannels[c]->mNodeName.C_Str());
        if (node >= 0) channel[std::size_t(node)] = anim.mChannels[c];
    }
    // Each animated node's bind-pose translation, rotation and scale: what a channel without keys of one kind keeps.
    struct Rest {
        aiVector3D scale, position;
        aiQuaternion rotation;
    };
    std::vector<Rest> rest(out.nodes.size());
    for (std::size_t n = 0; n < out.nodes.size(); ++n) {
        if (!channel[n]) continue;
        aiMatrix4x4 m;
        for (int r = 0; r < 4; ++r)
            for (int c = 0; c < 4; ++c) m[r][c] = ai_real(out.nodes[n].rest.matrix()(r, c));
        m.Decompose(rest[n].scale, rest[n].rotation, rest[n].position);
    }
    auto lerp3 = [](const aiVector3D& a, const aiVector3D& b, double t) { return a + (b - a) * ai_real(t); };
    auto slerp = [](const aiQuaternion& a, const aiQuaternion& b, double t) {
        aiQuaternion q;
        aiQuaternion::Interpolate(q, a, b, ai_real(t));
        return q.Normalize();
    };
    out.frames.assign(std::size_t(count), {});
    for (std::size_t f = 0; f < out.frames.size(); ++f) {
        const double tick = double(f) / out.fps * ticks_per_second;
        auto& locals = out.frames[f];
        locals.reserve(out.nodes.size());
        for (std::size_t n = 0; n < out.nodes.size(); ++n) {
            const aiNodeAnim* ch = channel[n];
            if (!ch) {
                locals.push_back(out.nodes[n].rest);
                continue;
            }
            const aiVector3D p = sample_keys(ch->mPositionKeys, ch->mNumPositionKeys, tick, rest[n].position, lerp3);
            const aiQuaternion q = sample_keys(ch->mRotationKeys, ch->mNumRotationKeys, tick, rest[n].rotation, slerp);
            const aiVector3D s = sample_keys(ch->mScalingKeys, ch->mNumScalingKeys, tick, rest[n].scale, lerp3);
            const Eigen::Affine3d local = to_affine(aiMatrix4x4(s, q, p));
            if (!finite(local)) fail(out.source, "animation {} gives node {} a transform that is not finite", printable(out.animation), printable(out.nodes[n].name));
            locals.push_back(local);
        }
    }
}

// The rate of an animation's keys when every channel keys it at one even spacing (a baked take),
// else none.
std::optional<double> key_rate(const aiAnimation& anim) {
    const double ticks_per_second = anim.mTicksPerSecond > 0 ? anim.mTicksPerSecond : 25.0;
    double step = 0;
    for (unsigned c = 0; c < anim.mNumChannels; ++c) {
        const aiNodeAnim& ch = *anim.mChannels[c];
        auto check = [&](const auto* keys, unsigned count) {
            for (unsigned k = 1; k < count; ++k) {
                const double d = keys[k].mTime - keys[k - 1].mTime;
                if (step == 0) step = d;
                if (!(d > 0) || std::abs(d - step) > 1e-3 * step) return false;
            }
            return true;
        };
        if (!check(ch.mPositionKeys, ch.mNumPositionKeys) || !check(ch.mRotationKeys, ch.mNumRotationKeys)) return std::nullopt;
    }
    if (!(step > 0)) return std::nullopt;
    const double rate = std::round(ticks_per_second / step * 1000.0) / 1000.0;
    if (!std::isfinite(rate) || rate <= 0 || rate > 1000) return std::nullopt;
    return rate;
}

const aiAnimation& choose_animation(const aiScene& scene, const std::optional<std::string>& wanted, CharacterFile& out) {
    for (unsigned a = 0; a < scene.mNumAnimations; ++a) out.animations.push_back(scene.mAnimations[a]->mName.C_Str());
    if (out.animations.empty()) fail(out.source, "holds no animation: a character performer needs one (bake the take into the file)");
    std::string list;
    for (const auto& name : out.animations) list += (list.empty() ? "" : ", ") + printable(name);
    if (!wanted) {
        if (out.animations.size() > 1) fail(out.source, "holds {} animations ({}): name one with animation = \"...\"", out.animations.size(), list);
        out.animation = out.animations.front();
        return *scene.mAnimations[0];
    }
    for (unsigned a = 0; a < scene.mNumAnimations; ++a)
        if (out.animations[a] == *wanted) {
            out.animation = *wanted;
            return *scene.mAnimations[a];
        }
    fail(out.source, "has no animation named {} (it has: {})", printable(*wanted), list);
}

}  // namespace

std::vector<Eigen::Affine3d> CharacterFile::globals(int frame) const {
    const auto& locals = frames[std::size_t(frame)];
    std::vector<Eigen::Affine3d> out(nodes.size());
    for (std::size_t n = 0; n < nodes.size(); ++n) out[n] = nodes[n].parent < 0 ? locals[n] : out[std::size_t(nodes[n].parent)] * locals[n];
    return out;
}

namespace {

// The character in this process (read_character runs it in a child).
CharacterFile read_character_here(const fs::path& path, const std::optional<std::string>& animation, std::optional<double> fps) {
    CharacterFile out;
    out.source = path.string();
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) fail(out.source, "is not a file");
    if (fps && (!std::isfinite(*fps) || *fps <= 0 || *fps > 1000)) fail(out.source, "fps = {} is not a rate between 0 and 1000", *fps);
    Assimp::Importer importer;
    const fs::path folder = fs::weakly_canonical(fs::absolute(path)).parent_path();
    importer.SetIOHandler(new ConfinedIOSystem(folder));  // the importer owns it
    importer.SetPropertyInteger(AI_CONFIG_PP_LBW_MAX_WEIGHTS, 4);
    const aiScene* scene = importer.ReadFile(path.string(), aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_ValidateDataStructure);
    if (!scene || !scene->mRootNode)
        fail(out.source, "cannot be read as a character: not a glTF, FBX or Collada file that assimp reads whole, or a file it names is "
                         "missing or outside its folder");
    std::map<const aiNode*, int> index;
    collect_nodes(scene->mRootNode, -1, out, index, out.source);
    bool skinned = false;
    std::vector<std::pair<const aiNode*, unsigned>> holders;  // node, mesh
    for (const auto& [node, i] : index)
        for (unsigned m = 0; m < node->mNumMeshes; ++m) holders.push_back({node, node->mMeshes[m]});
    std::sort(holders.begin(), holders.end(), [&](const auto& a, const auto& b) { return std::pair(index.at(a.first), a.second) < std::pair(index.at(b.first), b.second); });
    for (const auto& [node, m] : holders) {
        if (m >= scene->mNumMeshes) fail(out.source, "node {} names mesh {}, past the file's {}", printable(node->mName.C_Str()), m, scene->mNumMeshes);
        const aiMesh& mesh = *scene->mMeshes[m];
        if (out.vertices.size() + mesh.mNumVertices > kMaxCharacterVertices) fail(out.source, "has more than {} vertices", kMaxCharacterVertices);
        if (mesh.mNumBones > 0) add_skinned_mesh(mesh, out, out.source), skinned = true;
        else add_rigid_mesh(mesh, index.at(node), out, out.source);
    }
    if (!skinned) fail(out.source, "holds no skinned mesh (no mesh has bones): a character performer is a mesh skinned to a skeleton");
    if (out.triangles.empty()) fail(out.source, "holds no triangles");
    read_materials(*scene, *importer.GetIOHandler(), folder, out);
    const aiAnimation& chosen = choose_animation(*scene, animation, out);
    out.fps = fps ? *fps : key_rate(chosen).value_or(30.0);
    sample_animation(chosen, out);
    return out;
}

// The child's answer as bytes: every field in order, vectors and strings with their length first.
class Packer {
public:
    void raw(const void* data, std::size_t bytes) {
        if (bytes > 0) out_.append(static_cast<const char*>(data), bytes);  // an empty vector's data() may be null
    }
    template <typename T>
    void pod(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        raw(&v, sizeof v);
    }
    void text(const std::string& s) {
        pod(std::uint64_t(s.size()));
        raw(s.data(), s.size());
    }
    template <typename T>
    void pods(const std::vector<T>& v) {
        pod(std::uint64_t(v.size()));
        raw(v.data(), v.size() * sizeof(T));
    }
    void affine(const Eigen::Affine3d& a) { raw(a.matrix().data(), 16 * sizeof(double)); }
    std::string take() { return std::move(out_); }

private:
    std::string out_;
};

class Unpacker {
public:
    Unpacker(const std::string& in, const std::string& source) : in_(in), source_(source) {}
    void raw(void* data, std::size_t bytes) {
        if (bytes == 0) return;  // an empty vector's data() may be null
        if (bytes > in_.size() - at_) fail(source_, "internal: its reader's answer is cut short");
        std::memcpy(data, in_.data() + at_, bytes);
        at_ += bytes;
    }
    template <typename T>
    T pod() {
        T v;
        raw(&v, sizeof v);
        return v;
    }
    std::size_t count(std::size_t item) {
        const auto n = pod<std::uint64_t>();
        if (item > 0 && n > (in_.size() - at_) / item) fail(source_, "internal: its reader's answer is cut short");
        return std::size_t(n);
    }
    std::string text() {
        std::string s(count(1), '\0');
        raw(s.data(), s.size());
        return s;
    }
    template <typename T>
    std::vector<T> pods() {
        std::vector<T> v(count(sizeof(T)));
        raw(v.data(), v.size() * sizeof(T));
        return v;
    }
    Eigen::Affine3d affine() {
        Eigen::Affine3d a;
        raw(a.matrix().data(), 16 * sizeof(double));
        return a;
    }

private:
    const std::string& in_;
    const std::string& source_;
    std::size_t at_ = 0;
};

std::string pack(const CharacterFile& c) {
    Packer p;
    p.pod(std::uint64_t(c.nodes.size()));
    for (const CharacterNode& n : c.nodes) p.text(n.name), p.pod(n.parent), p.affine(n.rest), p.pod(n.holds_mesh);
    p.pod(std::uint64_t(c.bones.size()));
    for (const CharacterBone& b : c.bones) p.pod(b.node), p.affine(b.offset);
    std::vector<double> xyz;
    for (const Vec3& v : c.vertices) xyz.insert(xyz.end(), {v.x(), v.y(), v.z()});
    p.pods(xyz), p.pods(c.triangles), p.pods(c.vertex_bones), p.pods(c.vertex_weights), p.pods(c.rigid_node), p.pods(c.uvs), p.pod(c.has_uvs);
    p.pod(std::uint64_t(c.materials.size()));
    for (const CharacterMaterial& m : c.materials)
        p.text(m.name), p.pod(m.colour), p.text(m.texture_name), p.text(m.texture_mime), p.pods(m.texture), p.text(m.texture_note);
    p.pods(c.triangle_material);
    p.pod(std::uint64_t(c.animations.size()));
    for (const std::string& a : c.animations) p.text(a);
    p.text(c.animation), p.pod(c.fps), p.pod(std::uint64_t(c.frames.size()));
    for (const auto& frame : c.frames)
        for (const Eigen::Affine3d& a : frame) p.affine(a);
    return p.take();
}

CharacterFile unpack(const std::string& bytes, const std::string& source) {
    Unpacker u(bytes, source);
    CharacterFile c;
    c.source = source;
    c.nodes.resize(u.count(1));
    for (CharacterNode& n : c.nodes) n.name = u.text(), n.parent = u.pod<int>(), n.rest = u.affine(), n.holds_mesh = u.pod<bool>();
    c.bones.resize(u.count(1));
    for (CharacterBone& b : c.bones) b.node = u.pod<int>(), b.offset = u.affine();
    const std::vector<double> xyz = u.pods<double>();
    for (std::size_t i = 0; i + 2 < xyz.size(); i += 3) c.vertices.emplace_back(xyz[i], xyz[i + 1], xyz[i + 2]);
    c.triangles = u.pods<std::array<std::uint32_t, 3>>();
    c.vertex_bones = u.pods<std::array<int, 4>>();
    c.vertex_weights = u.pods<std::array<double, 4>>();
    c.rigid_node = u.pods<int>();
    c.uvs = u.pods<std::array<float, 2>>();
    c.has_uvs = u.pod<bool>();
    c.materials.resize(u.count(1));
    for (CharacterMaterial& m : c.materials) {
        m.name = u.text(), m.colour = u.pod<std::array<double, 4>>(), m.texture_name = u.text(), m.texture_mime = u.text();
        m.texture = u.pods<unsigned char>(), m.texture_note = u.text();
    }
    c.triangle_material = u.pods<int>();
    c.animations.resize(u.count(1));
    for (std::string& a : c.animations) a = u.text();
    c.animation = u.text(), c.fps = u.pod<double>();
    c.frames.resize(u.count(16 * sizeof(double) * c.nodes.size()));
    for (auto& frame : c.frames) {
        frame.resize(c.nodes.size());
        for (Eigen::Affine3d& a : frame) a = u.affine();
    }
    return c;
}

}  // namespace

// assimp's parsers are not hardened against crafted files: they run in a child process
// (run_contained), so that a crash or a hang there is one line naming the file, not amhv's end.
CharacterFile read_character(const fs::path& path, const std::optional<std::string>& animation, std::optional<double> fps) {
    const std::string source = path.string();
    return unpack(run_contained(source, [&] { return pack(read_character_here(path, animation, fps)); }), source);
}

}  // namespace amhv
