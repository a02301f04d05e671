#include "src/compose/compose_files.hpp"

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "src/compose/compose_page.hpp"
#include "src/compose/features.hpp"
#include "src/io/files.hpp"

namespace amhv::compose {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// Every joint's position per frame, metres.
std::vector<std::vector<Vec3>> positions(const BvhMotion& m, double metres, int first, int last) {
    std::vector<std::vector<Vec3>> out;
    for (int f = first; f <= last; ++f) {
        std::vector<Vec3> frame;
        for (const auto& g : m.global_transforms(f)) frame.push_back(g.translation() * metres);
        out.push_back(std::move(frame));
    }
    return out;
}

double largest_step(const std::vector<std::vector<Vec3>>& p, std::size_t from, std::size_t to) {
    double out = 0;
    for (std::size_t f = std::max<std::size_t>(from, 1); f <= to && f < p.size(); ++f)
        for (std::size_t j = 0; j < p[f].size(); ++j) out = std::max(out, (p[f][j] - p[f - 1][j]).norm());
    return out;
}

json labels_json(const Library& library, const Recognition& recognition) {
    json takes = json::array();
    for (std::size_t t = 0; t < library.takes.size(); ++t) {
        const TakeLabels& l = recognition.labels[t];
        json actions = json::array(), confidence = json::array();
        for (std::size_t f = 0; f < l.action.size(); ++f) {
            actions.push_back(l.action[f] < 0 ? std::string("unknown") : library.actions[std::size_t(l.action[f])]);
            confidence.push_back(std::round(l.confidence[f] * 1e4) / 1e4);
        }
        takes.push_back({{"name", library.takes[t].name}, {"first", library.takes[t].first}, {"last", library.takes[t].last},
                         {"action", actions}, {"confidence", confidence}});
    }
    return {{"fps", library.fps}, {"actions", library.actions}, {"takes", takes}};
}

json graph_json(const Library& library, const MotionGraph& graph) {
    json nodes = json::array(), edges = json::array();
    for (const Node& n : graph.nodes)
        nodes.push_back({{"take", library.takes[std::size_t(n.take)].name}, {"frames", {n.first, n.last}},
                         {"action", library.actions[std::size_t(n.action)]}, {"vote", std::round(n.vote * 1e4) / 1e4}});
    for (const Edge& e : graph.edges)
        edges.push_back({{"from", e.from}, {"to", e.to}, {"exit", e.exit}, {"entry", e.entry}, {"cost_m", std::round(e.cost * 1e5) / 1e5},
                         {"continuation", e.continuation}});
    return {{"max_splice_distance_m", kMaxSpliceDistance}, {"nodes", nodes}, {"edges", edges}};
}

json compose_json(const Library& library, const MotionGraph& graph, const Composed& c) {
    json clips = json::array(), splices = json::array(), query = json::array();
    for (const ActionQuery& q : c.query) query.push_back({{"action", q.action}, {"min_s", q.min_s}, {"max_s", std::isfinite(q.max_s) ? json(q.max_s) : json(nullptr)}});
    for (std::size_t k = 0; k < c.path.clips.size(); ++k) {
        const Clip& clip = c.path.clips[k];
        clips.push_back({{"action", c.query[k].action}, {"take", library.takes[std::size_t(clip.take)].name}, {"frames", {clip.first, clip.last}},
                         {"node", c.path.nodes[k]}});
    }
    for (std::size_t k = 0; k < c.path.edges.size(); ++k) {
        const Edge& e = graph.edges[std::size_t(c.path.edges[k])];
        splices.push_back({{"after_action", k}, {"cost_m", std::round(e.cost * 1e5) / 1e5}, {"continuation", e.continuation}});
    }
    json frames = json::array();
    for (int f : c.spliced.splices) frames.push_back(f);
    return {{"fps", library.fps}, {"frames", c.spliced.motion.frame_count}, {"cost_m", std::round(c.path.cost * 1e5) / 1e5},
            {"query", query}, {"clips", clips}, {"splices", splices}, {"splice_frames", frames},
            {"checks", {{"largest_step_at_splices_m", std::round(c.quality.splice_step_m * 1e5) / 1e5},
                        {"largest_step_in_sources_m", std::round(c.quality.source_step_m * 1e5) / 1e5},
                        {"planted_drift_m", std::round(c.quality.planted_drift_m * 1e5) / 1e5}}}};
}

}  // namespace

SpliceQuality splice_quality(const Library& library, const Spliced& spliced, const std::vector<Clip>& clips) {
    const double metres = library.units.metres_per_unit;
    SpliceQuality q;
    for (const Clip& clip : clips) {
        const auto p = positions(library.takes[std::size_t(clip.take)].motion, metres, clip.first, clip.last);
        q.source_step_m = std::max(q.source_step_m, largest_step(p, 1, p.size() - 1));
    }
    const BvhMotion& m = spliced.motion;
    const auto p = positions(m, metres, 0, m.frame_count - 1);
    const int w = std::max(1, int(std::lround(kBlendSeconds * library.fps)));
    for (int s : spliced.splices)
        q.splice_step_m = std::max(q.splice_step_m, largest_step(p, std::size_t(std::max(1, s - w)), std::size_t(std::min(m.frame_count - 1, s + w))));
    const KeyJoints key = key_joints(library.roles, library.file.string());
    for (std::size_t side = 0; side < 2; ++side)
        for (std::size_t f = 0, start = 0; f < spliced.planted.size(); ++f) {
            if (!spliced.planted[f][side]) continue;
            if (f == 0 || !spliced.planted[f - 1][side]) start = f;
            const std::size_t ankle = std::size_t(key.foot[side]);
            q.planted_drift_m = std::max(q.planted_drift_m, (p[f][ankle] - p[start][ankle]).norm());
        }
    return q;
}

void write_compose_files(const fs::path& folder, const Library& library, const Recognition& recognition, const MotionGraph& graph,
                         const std::optional<Composed>& composed) {
    write_file(folder / "labels.json", labels_json(library, recognition).dump(1) + '\n');
    write_file(folder / "graph.json", graph_json(library, graph).dump(1) + '\n');
    write_file(folder / "index.html", compose_page(library, recognition, graph, composed));
    if (!composed) return;
    write_file(folder / "compose.json", compose_json(library, graph, *composed).dump(2) + '\n');
    write_file(folder / "take.bvh", bvh_text(composed->spliced.motion));
}

}  // namespace amhv::compose
