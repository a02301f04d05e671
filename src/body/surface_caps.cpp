#include "src/body/surface_caps.hpp"

#include <algorithm>
#include <map>
#include <numeric>
#include <set>

#include "src/core/error.hpp"

namespace amhv {

// The boundary of a triangle set as directed edges (a, b) where (a, b) is used more often than
// (b, a), walked into loops; fails when some vertex starts more boundary edges than it ends (the
// boundary is then no union of loops and a cap cannot close it).
std::vector<std::vector<std::uint32_t>> boundary_loops(const std::vector<std::array<std::uint32_t, 3>>& triangles, const std::string& what) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> uses;
    for (const auto& t : triangles)
        for (int c = 0; c < 3; ++c) ++uses[{t[std::size_t(c)], t[std::size_t((c + 1) % 3)]}];
    std::map<std::uint32_t, std::vector<std::uint32_t>> next;
    std::map<std::uint32_t, int> balance;
    for (const auto& [edge, n] : uses) {
        auto reverse = uses.find({edge.second, edge.first});
        for (int k = n - (reverse == uses.end() ? 0 : reverse->second); k > 0; --k) {
            next[edge.first].push_back(edge.second);
            ++balance[edge.first];
            --balance[edge.second];
        }
    }
    for (const auto& [v, b] : balance)
        if (b != 0) fail(what, "the surface cannot be closed: its boundary at vertex {} is not a loop", v);
    std::vector<std::vector<std::uint32_t>> loops;
    for (auto& [start, outs] : next) {
        while (!outs.empty()) {
            std::vector<std::uint32_t> loop{start};
            std::uint32_t at = outs.back();
            outs.pop_back();
            while (at != start) {
                loop.push_back(at);
                auto& from = next[at];
                const std::uint32_t to = from.back();  // balanced: never empty here
                from.pop_back();
                at = to;
            }
            loops.push_back(std::move(loop));
        }
    }
    return loops;
}

// Caps every loop with a fan around a new vertex (its index `first_new` + loop number): each
// boundary edge (a, b) gets the triangle (b, a, centre), so the surface becomes a closed 2-cycle.
void cap_loops(const std::vector<std::vector<std::uint32_t>>& loops, std::uint32_t first_new, std::vector<std::array<std::uint32_t, 3>>& triangles) {
    for (std::size_t l = 0; l < loops.size(); ++l) {
        const auto& loop = loops[l];
        for (std::size_t i = 0; i < loop.size(); ++i) triangles.push_back({loop[(i + 1) % loop.size()], loop[i], first_new + std::uint32_t(l)});
    }
}

// Drops every triangle that repeats a directed edge of an earlier one (a fin: three or more
// triangles on one edge), so that capping leaves each edge between exactly two triangles.
int drop_fins(std::vector<std::array<std::uint32_t, 3>>& triangles) {
    std::set<std::pair<std::uint32_t, std::uint32_t>> used;
    std::vector<std::array<std::uint32_t, 3>> kept;
    for (const auto& t : triangles) {
        const std::array<std::pair<std::uint32_t, std::uint32_t>, 3> edges{{{t[0], t[1]}, {t[1], t[2]}, {t[2], t[0]}}};
        if (used.count(edges[0]) || used.count(edges[1]) || used.count(edges[2])) continue;
        used.insert(edges.begin(), edges.end());
        kept.push_back(t);
    }
    const int dropped = int(triangles.size() - kept.size());
    triangles = std::move(kept);
    return dropped;
}

// Gives each fan of triangles around a vertex its own copy of the vertex (appended to `sources`,
// which maps each local vertex to the vertex it copies), so that a vertex two caps or two wedges
// of a part only touch becomes two: mesh libraries (OpenMesh) then read the part back as it is.
// Each directed edge is paired with a reverse one; triangles paired across an edge at a vertex are
// one fan there. A closed surface stays closed. Fails when an edge is left between more than two
// triangles.
void split_fans(std::vector<std::array<std::uint32_t, 3>>& triangles, std::vector<std::uint32_t>& sources, const std::string& what) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::size_t>> corners_of;  // directed edge -> corners where it starts
    for (std::size_t t = 0; t < triangles.size(); ++t)
        for (std::size_t c = 0; c < 3; ++c) corners_of[{triangles[t][c], triangles[t][(c + 1) % 3]}].push_back(t * 3 + c);
    std::vector<std::size_t> parent(triangles.size() * 3);
    std::iota(parent.begin(), parent.end(), std::size_t(0));
    auto root = [&](std::size_t x) {
        while (parent[x] != x) x = parent[x] = parent[parent[x]];
        return x;
    };
    auto next = [](std::size_t corner) { return corner / 3 * 3 + (corner % 3 + 1) % 3; };
    for (const auto& [edge, starts] : corners_of) {
        if (edge.first > edge.second) continue;
        const auto reverse = corners_of.find({edge.second, edge.first});
        if (reverse == corners_of.end() || reverse->second.size() != starts.size() || starts.size() > 1)
            fail(what, "edge {}-{} is not between exactly two triangles", edge.first, edge.second);
        const std::size_t f = starts[0], g = reverse->second[0];  // f: a -> b, g: b -> a
        parent[root(f)] = root(next(g));                          // both corners at a
        parent[root(next(f))] = root(g);                          // both corners at b
    }
    std::map<std::pair<std::uint32_t, std::size_t>, std::uint32_t> copy_of;  // (vertex, fan) -> local vertex
    std::map<std::uint32_t, bool> seen;
    for (std::size_t corner = 0; corner < parent.size(); ++corner) {
        std::uint32_t& v = triangles[corner / 3][corner % 3];
        auto [at, added] = copy_of.emplace(std::make_pair(v, root(corner)), v);
        if (added && seen[v]) {  // a further fan of v: a copy
            at->second = std::uint32_t(sources.size());
            sources.push_back(sources[v]);
        }
        seen[v] = true;
        v = at->second;
    }
}

Vec3 mean_of(const std::vector<Vec3>& points, const std::vector<std::uint32_t>& ids) {
    Vec3 sum = Vec3::Zero();
    for (std::uint32_t i : ids) sum += points[i];
    return sum / double(ids.size());
}

std::vector<SurfacePart> split_into_parts(const std::vector<std::array<std::uint32_t, 3>>& triangles, const std::vector<std::string>& vertex_part,
                                          const std::vector<std::string>& order_first, const std::string& source, std::size_t vertex_count,
                                          std::vector<std::vector<std::uint32_t>>& derived, int& caps) {
    std::map<std::string, std::vector<std::array<std::uint32_t, 3>>> by_part;
    for (const auto& t : triangles) {
        const std::string& a = vertex_part[t[0]];
        by_part[a == vertex_part[t[1]] || a == vertex_part[t[2]] ? a : vertex_part[t[1]] == vertex_part[t[2]] ? vertex_part[t[1]] : a].push_back(t);
    }
    std::vector<std::string> order = order_first;
    for (const auto& [name, unused] : by_part)
        if (std::find(order.begin(), order.end(), name) == order.end()) order.push_back(name);
    std::vector<SurfacePart> parts;
    for (const std::string& name : order) {
        auto at = by_part.find(name);
        if (at == by_part.end()) continue;
        std::vector<std::array<std::uint32_t, 3>> own = at->second;
        const auto cuts = boundary_loops(own, source + " part " + name);
        cap_loops(cuts, std::uint32_t(vertex_count + derived.size()), own);
        for (const auto& loop : cuts) derived.push_back(loop);
        caps += int(cuts.size());
        SurfacePart part{name, {}, {}};
        std::map<std::uint32_t, std::uint32_t> local;
        for (auto& t : own)
            for (auto& v : t) {
                auto [it, added] = local.emplace(v, std::uint32_t(part.vertices.size()));
                if (added) part.vertices.push_back(v);
                v = it->second;
            }
        split_fans(own, part.vertices, source + " part " + name);
        part.triangles = std::move(own);
        parts.push_back(std::move(part));
    }
    return parts;
}

std::vector<BodyPart> posed_parts(const std::vector<SurfacePart>& parts, std::vector<Vec3> points, const std::vector<std::vector<std::uint32_t>>& derived,
                                  const std::string& source, int frame, const char* what) {
    const std::size_t surface = points.size();
    points.resize(surface + derived.size());
    for (std::size_t k = 0; k < derived.size(); ++k) points[surface + k] = mean_of(points, derived[k]);
    for (const Vec3& p : points)
        if (!p.allFinite()) fail(source, "frame {} gives {}", frame, what);
    std::vector<BodyPart> out;
    for (const SurfacePart& part : parts) {
        BodyPart posed{part.name, {}};
        posed.mesh.vertices.reserve(part.vertices.size());
        for (std::uint32_t v : part.vertices) posed.mesh.vertices.push_back(points[v]);
        posed.mesh.triangles = part.triangles;
        out.push_back(std::move(posed));
    }
    return out;
}

}  // namespace amhv
