#include "src/io/character_file.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include <assimp/DefaultIOSystem.h>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

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
        out.vertex_bones.push_back(bones);
        out.vertex_weights.push_back(weights);
        out.rigid_node.push_back(-1);
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
        const aiFace& face = mesh.mFaces[f];
        if (face.mNumIndices != 3) continue;  // points and lines left by triangulation
        out.triangles.push_back({base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]});
    }
}

// An unskinned mesh rides rigidly on the node that holds it.
void add_rigid_mesh(const aiMesh& mesh, int node, CharacterFile& out, const std::string& source) {
    const std::uint32_t base = std::uint32_t(out.vertices.size());
    for (unsigned v = 0; v < mesh.mNumVertices; ++v) {
        const aiVector3D& p = mesh.mVertices[v];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) fail(source, "mesh {} vertex {} is not finite", printable(mesh.mName.C_Str()), v);
        out.vertices.emplace_back(double(p.x), double(p.y), double(p.z));
        out.vertex_bones.push_back({-1, -1, -1, -1});
        out.vertex_weights.push_back({0, 0, 0, 0});
        out.rigid_node.push_back(node);
    }
    for (unsigned f = 0; f < mesh.mNumFaces; ++f)
        if (mesh.mFaces[f].mNumIndices == 3)
            out.triangles.push_back({base + mesh.mFaces[f].mIndices[0], base + mesh.mFaces[f].mIndices[1], base + mesh.mFaces[f].mIndices[2]});
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
    const double count = std::floor(seconds * out.fps + 1e-9) + 1;
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

CharacterFile read_character(const fs::path& path, const std::optional<std::string>& animation, std::optional<double> fps) {
    CharacterFile out;
    out.source = path.string();
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) fail(out.source, "is not a file");
    if (fps && (!std::isfinite(*fps) || *fps <= 0 || *fps > 1000)) fail(out.source, "fps = {} is not a rate between 0 and 1000", *fps);
    Assimp::Importer importer;
    importer.SetIOHandler(new ConfinedIOSystem(fs::weakly_canonical(fs::absolute(path)).parent_path()));  // the importer owns it
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
    const aiAnimation& chosen = choose_animation(*scene, animation, out);
    out.fps = fps ? *fps : key_rate(chosen).value_or(30.0);
    sample_animation(chosen, out);
    return out;
}

}  // namespace amhv
