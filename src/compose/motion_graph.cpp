#include "src/compose/motion_graph.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include <fmt/format.h>

#include "src/compose/features.hpp"
#include "src/core/error.hpp"
#include "src/core/parallel.hpp"

namespace amhv::compose {

namespace {

// Key joints and hips of every frame of a take, file units.
std::vector<std::vector<Vec3>> key_positions(const BvhMotion& m, const KeyJoints& key) {
    const std::vector<int> joints = key.with_hips();
    std::vector<std::vector<Vec3>> out(std::size_t(m.frame_count));
    for (int f = m.first_frame; f < m.frame_count; ++f) {
        const auto global = m.global_transforms(f);
        for (int j : joints) out[std::size_t(f)].push_back(global[std::size_t(j)].translation());
    }
    return out;
}

// Root mean square distance (metres) between the windows around frames a (take s) and b (take r),
// after the floor move that aligns them best.
double splice_distance(const std::vector<std::vector<Vec3>>& s, const LibraryTake& ts, int a, const std::vector<std::vector<Vec3>>& r,
                       const LibraryTake& tr, int b, int half, int up, double metres) {
    std::vector<Vec3> p, q;
    for (int o = -half; o <= half; ++o) {
        const auto& ps = s[std::size_t(std::clamp(a + o, ts.first, ts.last))];
        const auto& qs = r[std::size_t(std::clamp(b + o, tr.first, tr.last))];
        p.insert(p.end(), ps.begin(), ps.end());
        q.insert(q.end(), qs.begin(), qs.end());
    }
    const FloorMove move = align_on_floor(p, q, up);
    double sum = 0;
    for (std::size_t i = 0; i < p.size(); ++i) sum += (p[i] - move.apply(q[i], up)).squaredNorm();
    return std::sqrt(sum / double(p.size())) * metres;
}

}  // namespace

MotionGraph build_graph(const Library& library, const Recognition& recognition) {
    MotionGraph graph;
    graph.nodes = recognition.nodes;
    const KeyJoints key = key_joints(library.roles, library.file.string());
    std::vector<std::vector<std::vector<Vec3>>> positions(library.takes.size());
    parallel_for(library.takes.size(), [&](std::size_t t) { positions[t] = key_positions(library.takes[t].motion, key); });
    const int half = std::max(1, int(std::lround(kBlendSeconds * library.fps)));
    const int up = up_index(library.units);
    const std::size_t n = graph.nodes.size();
    std::vector<std::vector<Edge>> found(n * n);
    parallel_for(n * n, [&](std::size_t pair) {
        const Node& from = graph.nodes[pair / n];
        const Node& to = graph.nodes[pair % n];
        if (pair / n == pair % n) return;
        if (from.take == to.take && to.first > from.last) {
            const bool next = std::none_of(graph.nodes.begin(), graph.nodes.end(), [&](const Node& o) {
                return o.take == from.take && o.first > from.last && o.first < to.first;
            });
            if (next) {
                found[pair].push_back({int(pair / n), int(pair % n), to.first - 1, to.first, 0.0, true});
                return;
            }
        }
        Edge best{int(pair / n), int(pair % n), 0, 0, kMaxSpliceDistance, false};
        bool any = false;
        const int out_from = from.last - (from.last - from.first + 1) / 3, in_to = to.first + (to.last - to.first + 1) / 3;
        for (int a = out_from; a <= from.last; ++a)
            for (int b = to.first; b <= in_to; ++b) {
                const double d = splice_distance(positions[std::size_t(from.take)], library.takes[std::size_t(from.take)], a,
                                                 positions[std::size_t(to.take)], library.takes[std::size_t(to.take)], b, half, up,
                                                 library.units.metres_per_unit);
                if (d <= best.cost) best.exit = a, best.entry = b, best.cost = d, any = true;
            }
        if (any) found[pair].push_back(best);
    });
    for (auto& e : found) graph.edges.insert(graph.edges.end(), e.begin(), e.end());
    return graph;
}

std::vector<ActionQuery> parse_actions(const std::string& text, const Library& library) {
    std::vector<ActionQuery> out;
    std::stringstream in(text);
    std::string item;
    while (std::getline(in, item, ',')) {
        const auto trim = [](std::string s) {
            s.erase(0, s.find_first_not_of(" \t"));
            s.erase(s.find_last_not_of(" \t") + 1);
            return s;
        };
        item = trim(item);
        ActionQuery q;
        const auto colon = item.find(':');
        q.action = trim(item.substr(0, colon));
        if (library.action_index(q.action) < 0)
            fail("--actions", "'{}' has no example in the library (its actions: {})", q.action, fmt::join(library.actions, ", "));
        if (colon != std::string::npos) {
            const std::string range = item.substr(colon + 1);
            char dash = 0;
            std::istringstream r(range);
            if (!(r >> q.min_s >> dash >> q.max_s) || dash != '-' || !(r >> std::ws).eof() || !(q.min_s >= 0) || !(q.max_s >= q.min_s) || !std::isfinite(q.max_s))
                fail("--actions", "'{}': a duration is MIN-MAX in seconds, as walk:1-2.5", item);
        }
        out.push_back(q);
    }
    if (out.empty()) fail("--actions", "give at least one action");
    return out;
}

ComposedPath cheapest_path(const Library& library, const MotionGraph& graph, const std::vector<ActionQuery>& query) {
    // A clip gives kBlendSeconds of frames to each splice it takes part in.
    const int w = std::max(1, int(std::lround(kBlendSeconds * library.fps)));
    const auto frames = [&](double seconds) { return seconds * library.fps; };
    // The most frames an action may take (durations are finite or unbounded).
    const auto longest = [&](const ActionQuery& q) { return std::isfinite(q.max_s) ? int(std::floor(frames(q.max_s) + 1e-9)) : 1 << 30; };
    struct State {
        double cost = 0;
        int node = 0, entry = 0;
        bool spliced_in = false;
        ComposedPath path;
    };
    std::vector<State> layer;
    for (std::size_t i = 0; i < graph.nodes.size(); ++i)
        if (graph.nodes[i].action == library.action_index(query[0].action)) layer.push_back({0.0, int(i), graph.nodes[i].first, false, {}});
    for (std::size_t k = 1; k < query.size() && !layer.empty(); ++k) {
        std::map<std::pair<int, int>, State> next;  // by node and entry: the cheapest
        for (const State& s : layer)
            for (std::size_t e = 0; e < graph.edges.size(); ++e) {
                const Edge& edge = graph.edges[e];
                if (edge.from != s.node || graph.nodes[std::size_t(edge.to)].action != library.action_index(query[k].action)) continue;
                int entry = s.entry;
                if (k == 1) entry = std::max(entry, edge.exit - longest(query[0]) + 1);
                const int length = edge.exit - entry + 1;
                const int min_clip = 1 + (s.spliced_in ? w : 0) + (edge.continuation ? 0 : w);
                if (length < min_clip || length < frames(query[k - 1].min_s) || length > frames(query[k - 1].max_s) + 1e-9) continue;
                State t{s.cost + edge.cost, edge.to, edge.entry, !edge.continuation, s.path};
                t.path.nodes.push_back(s.node);
                t.path.edges.push_back(int(e));
                t.path.clips.push_back({graph.nodes[std::size_t(s.node)].take, entry, edge.exit});
                auto [it, added] = next.try_emplace({t.node, t.entry}, t);
                if (!added && t.cost < it->second.cost) it->second = t;
            }
        layer.clear();
        for (auto& [at, state] : next) layer.push_back(std::move(state));
    }
    const State* best = nullptr;
    ComposedPath chosen;
    for (const State& s : layer) {
        const Node& node = graph.nodes[std::size_t(s.node)];
        int entry = s.entry;
        if (query.size() == 1) entry = std::max(entry, node.last - longest(query[0]) + 1);
        const int exit = int(std::min<long>(node.last, long(entry) + longest(query.back()) - 1));
        const int length = exit - entry + 1;
        if (length < 1 + (s.spliced_in ? w : 0) || length < frames(query.back().min_s)) continue;
        if (best && s.cost >= best->cost) continue;
        best = &s;
        chosen = s.path;
        chosen.nodes.push_back(s.node);
        chosen.clips.push_back({node.take, entry, exit});
        chosen.cost = s.cost;
    }
    if (!best) fail("--actions", "no path through the motion graph performs these actions in order (its nodes and splices: graph.json)");
    return chosen;
}

}  // namespace amhv::compose
