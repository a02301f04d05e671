#include "src/scene/interest.hpp"

#include <algorithm>

namespace amhv {

TriangleMesh part_surface(ObjectSource& source, const PartSpec& spec, int number) {
    TriangleMesh out;
    if (spec.kind == PartSpec::Kind::WholeMinusInterest) return out;
    if (spec.kind == PartSpec::Kind::Meshes) return source.part_frame(spec.meshes, number).mesh;
    for (const BodyPart& part : source.frame_parts(number)) {
        const bool listed = std::find(spec.labels.begin(), spec.labels.end(), part.name) != spec.labels.end();
        if (spec.kind == PartSpec::Kind::Parts && !listed) continue;
        if (spec.kind == PartSpec::Kind::PartsExcept && listed) continue;
        if (spec.kind != PartSpec::Kind::Box) {
            out.append(part.mesh);
            continue;
        }
        TriangleMesh inside;
        inside.vertices = part.mesh.vertices;
        for (const auto& t : part.mesh.triangles) {
            const Vec3 centroid = (part.mesh.vertices[t[0]] + part.mesh.vertices[t[1]] + part.mesh.vertices[t[2]]) / 3.0;
            if ((centroid.array() >= spec.box.min.array()).all() && (centroid.array() <= spec.box.max.array()).all()) inside.triangles.push_back(t);
        }
        if (!inside.triangles.empty()) out.append(inside);
    }
    return out;
}

std::vector<bool> part_triangles(ObjectSource& source, const PartSpec& spec, int number) {
    std::vector<bool> out;
    for (const BodyPart& part : source.frame_parts(number)) {
        const bool listed = std::find(spec.labels.begin(), spec.labels.end(), part.name) != spec.labels.end();
        for (const auto& t : part.mesh.triangles) {
            bool in = false;
            switch (spec.kind) {
                case PartSpec::Kind::Whole: in = true; break;
                case PartSpec::Kind::Parts: in = listed; break;
                case PartSpec::Kind::PartsExcept: in = !listed; break;
                case PartSpec::Kind::Box: {
                    const Vec3 c = (part.mesh.vertices[t[0]] + part.mesh.vertices[t[1]] + part.mesh.vertices[t[2]]) / 3.0;
                    in = (c.array() >= spec.box.min.array()).all() && (c.array() <= spec.box.max.array()).all();
                    break;
                }
                default: break;
            }
            out.push_back(in);
        }
    }
    return out;
}

}  // namespace amhv
