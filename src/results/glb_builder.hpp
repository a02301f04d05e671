#pragma once
// Building a glTF 2.0 binary with tinygltf: one buffer, a view and an accessor per array, for
// scene.glb and mhv.glb.
#include <array>
#include <cstdint>
#include <limits>
#include <vector>

#include <tiny_gltf.h>

#include "src/core/geometry.hpp"

namespace amhv {

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

    // A vertex attribute of `components` floats per vertex (with bounds for POSITION).
    int attribute(const std::vector<float>& values, int components, bool bounds) {
        const std::size_t count = values.size() / std::size_t(components);
        std::vector<double> lo, hi;
        if (bounds) {
            lo.assign(std::size_t(components), std::numeric_limits<double>::infinity());
            hi.assign(std::size_t(components), -std::numeric_limits<double>::infinity());
            for (std::size_t i = 0; i < values.size(); ++i) {
                lo[i % std::size_t(components)] = std::min(lo[i % std::size_t(components)], double(values[i]));
                hi[i % std::size_t(components)] = std::max(hi[i % std::size_t(components)], double(values[i]));
            }
        }
        return accessor(view(values.data(), values.size() * sizeof(float), TINYGLTF_TARGET_ARRAY_BUFFER), TINYGLTF_COMPONENT_TYPE_FLOAT,
                        components == 2 ? TINYGLTF_TYPE_VEC2 : TINYGLTF_TYPE_VEC3, count, lo, hi);
    }

    int indices32(const std::vector<std::uint32_t>& indices) {
        return accessor(view(indices.data(), indices.size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER), TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                        TINYGLTF_TYPE_SCALAR, indices.size());
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

}  // namespace amhv
