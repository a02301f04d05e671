#pragma once
// What `amhv compose` writes: index.html (compose_page.hpp), labels.json (every frame's action and confidence per take),
// graph.json (nodes and splices), and for a query take.bvh with compose.json (the clips, the splice
// points, their costs and the composed take's checks).
#include <filesystem>
#include <optional>

#include "src/compose/motion_graph.hpp"
#include "src/compose/splice.hpp"

namespace amhv::compose {

// How smooth a spliced take is, in metres: the largest joint step between consecutive frames
// within kBlendSeconds of a splice and within the source clips, and the farthest a planted ankle
// moves from where its planted run starts.
struct SpliceQuality {
    double splice_step_m = 0, source_step_m = 0, planted_drift_m = 0;
};
SpliceQuality splice_quality(const Library& library, const Spliced& spliced, const std::vector<Clip>& clips);

struct Composed {
    std::vector<ActionQuery> query;
    ComposedPath path;
    Spliced spliced;
    SpliceQuality quality;
};

void write_compose_files(const std::filesystem::path& folder, const Library& library, const Recognition& recognition,
                         const MotionGraph& graph, const std::optional<Composed>& composed);

}  // namespace amhv::compose
