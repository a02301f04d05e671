#include "src/scene/interest.hpp"

#include <algorithm>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "src/core/error.hpp"

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

void check_part_names(const Scene& scene, const std::vector<ObjectSource*>& sources) {
    for (const KeySegment& key : scene.segments)
        for (int side = 0; side < 2; ++side) {
            const std::string& name = key.pair[std::size_t(side)];
            const auto at = std::find_if(scene.objects.begin(), scene.objects.end(), [&](const SceneObject& o) { return o.name == name; });
            if (at == scene.objects.end()) continue;
            ObjectSource& source = *sources[std::size_t(at - scene.objects.begin())];
            source.frame_parts(side == 0 ? key.a[0] : key.b[0]);  // a labelled sequence learns its names from its frames
            const std::vector<std::string>& known = source.label_names();
            for (const PartSpec* spec : {side == 0 ? &key.interest_a : &key.interest_b, side == 0 ? &key.fidelity_a : &key.fidelity_b})
                for (const std::string& label : spec->labels)
                    if (std::find(known.begin(), known.end(), label) == known.end())
                        fail(fmt::format("{}:{}", scene.file.string(), key.line), "segments[{}]: object {} has no part '{}'; its parts are {}", key.index,
                             name, printable(label), known.empty() ? std::string("none (it has no labels)") : fmt::format("{}", fmt::join(known, ", ")));
        }
}

}  // namespace amhv
