#pragma once
// The motion graph (after the splicing document, section 6): nodes are single-action clips from
// recognition; an edge joins the last third of one node to the first third of another where the
// two poses, over a window and after the best turn and shift on the floor, are close enough to
// splice. A query, actions in order, is the cheapest path through it.
#include <limits>
#include <string>
#include <vector>

#include "src/compose/recognise.hpp"
#include "src/compose/splice.hpp"

namespace amhv::compose {

// Two frames splice when the key joints and the hips over +-kBlendSeconds around them differ by
// at most this root mean square (metres) after the floor alignment: spread over the blend, 0.1 m
// adds at most 0.25 m/s to a joint's speed, a tenth of a walking hand's swing.
inline constexpr double kMaxSpliceDistance = 0.1;

struct Edge {
    int from = 0, to = 0;    // nodes
    int exit = 0, entry = 0; // the from node's last frame used, the to node's first
    double cost = 0;         // metres (root mean square after alignment); 0 for a continuation
    bool continuation = false;  // the same take, played on (no splice)
};

struct MotionGraph {
    std::vector<Node> nodes;
    std::vector<Edge> edges;
};

MotionGraph build_graph(const Library& library, const Recognition& recognition);

// One requested action with its duration range (seconds).
struct ActionQuery {
    std::string action;
    double min_s = 0, max_s = std::numeric_limits<double>::infinity();
};
// "walk, shake_hands:1-2.5, walk": names the library's examples know, each optionally with a
// duration range. Throws amhv::Error naming what is wrong.
std::vector<ActionQuery> parse_actions(const std::string& text, const Library& library);

struct ComposedPath {
    std::vector<int> nodes;       // one per requested action
    std::vector<int> edges;       // between them
    std::vector<Clip> clips;      // per action, the frames used
    double cost = 0;
};

// The cheapest path that performs the actions in order. Throws amhv::Error when none can.
ComposedPath cheapest_path(const Library& library, const MotionGraph& graph, const std::vector<ActionQuery>& query);

}  // namespace amhv::compose
