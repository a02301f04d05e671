#include "src/pipeline/propose_stage.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include <fmt/format.h>

#include "src/body/character_body.hpp"
#include "src/core/clock.hpp"
#include "src/compose/compose_page.hpp"
#include "src/core/error.hpp"
#include "src/edit/natural.hpp"
#include "src/sweep/solution_group.hpp"

namespace amhv::pipeline {

namespace {

// The scored frames of a key segment built by build_segment, as natural_frames() takes them from
// an edit (no frames around it: no crowding).
NaturalFrames segment_frames(const KeySegment& key, const NormalisedPair& frames) {
    NaturalFrames out;
    for (int m = 0; m < frames.length; ++m) {
        out.key_a.push_back(key.a[0] + frames.frames_a[std::size_t(m)]);
        out.key_b.push_back(key.b[0] + frames.frames_b[std::size_t(m)]);
    }
    sample_key_frames(out);
    return out;
}

// One key segment swept at the sampling of `scene` on the backends, and its best member by
// natural score.
ProposalSweep sweep_candidate(const Scene& scene, const KeySegment& key, ObjectSource& a, ObjectSource& b, Backends& backends) {
    const SegmentBuild build = build_segment(scene, key, a, b, backends.voxeliser);
    const SweepResult result = backends.sweeper.sweep(build.problem);
    ProposalSweep out;
    out.voxel = scene.sampling.voxel;
    out.angle_step_deg = scene.sampling.angle_step_deg;
    out.poses = build.problem.range.size();
    out.rejected = result.rejected;
    const KeySweep sweep = key_sweep(key, build.problem, result, solution_group(result));
    out.members = sweep.group.size();
    if (sweep.group.empty()) return out;
    const NaturalScorer scorer(key, sweep, segment_frames(key, build.frames), a, b, backends.voxeliser, scene.sampling.angles());
    const std::vector<double> costs = scorer.costs(sweep.group);
    const std::uint64_t best = std::uint64_t(std::min_element(costs.begin(), costs.end()) - costs.begin());
    out.score = costs[best];
    out.terms = scorer.terms(sweep.group.at(best));
    out.best = sweep.describe(sweep.group.at(best));
    return out;
}

// Those swept again at the scene's sampling first (scores at two samplings do not compare), then
// those with members, then by the best member's score (lower first), then the larger group; ties
// keep the candidates' order.
void rank(std::vector<Proposal>& proposals) {
    std::stable_sort(proposals.begin(), proposals.end(), [](const Proposal& x, const Proposal& y) {
        if (x.refined.has_value() != y.refined.has_value()) return x.refined.has_value();
        const ProposalSweep &p = x.decided(), &q = y.decided();
        if ((p.members > 0) != (q.members > 0)) return p.members > 0;
        if (p.score != q.score) return p.score < q.score;
        return p.members > q.members;
    });
}

// One take's frames as a strip, its contact moments marked (slaps red, holds blue).
std::string moments_strip(const std::string& name, int first, int last, const std::vector<propose::ContactEvent>& events) {
    const double width = 900, scale = width / std::max(1, last - first + 1);
    std::string svg = fmt::format("<h3>{}: frames {}-{}</h3>\n<svg width=\"{:.0f}\" height=\"{}\"><rect x=\"0\" y=\"0\" width=\"{:.0f}\" "
                                  "height=\"{}\" fill=\"#eee\"/>",
                                  compose::html_text(name), first, last, width, 12 * 4 + 4, width, 12 * 4 + 4);
    for (const propose::ContactEvent& e : events) {
        const int row = (e.variant == 'a' ? 2 : 0) + int(e.hand);
        svg += fmt::format("<rect x=\"{:.1f}\" y=\"{}\" width=\"{:.1f}\" height=\"10\" fill=\"{}\"><title>{}</title></rect>", (e.first - first) * scale,
                           2 + 12 * row, std::max(1.0, (e.last - e.first + 1) * scale), e.variant == 'a' ? "#0072B2" : "#D55E00",
                           compose::html_text(e.why));
    }
    return svg + "</svg>\n";
}

std::string part_list(const PartSpec& p) {
    std::string out;
    for (const std::string& l : p.labels) out += fmt::format("{}\"{}\"", out.empty() ? "" : ", ", l);
    return out;
}

// Where a labelled hand meets its forearm, standing in for the wrist joint a skeleton's hand cues
// follow: the area-weighted centroid of the hand's triangles, each weighted by exp(-(e / kWristBand)^2),
// e its centroid's distance to the forearm's centroid beyond the nearest triangle's (the hand's cap
// at the wrist; the weights change continuously as the hand turns, so the point does not jump from
// vertex to vertex). Without a forearm, the hand's centroid.
constexpr double kWristBand = 0.01;  // metres
std::optional<Vec3> wrist(const TriangleMesh& hand, const TriangleMesh* forearm) {
    const std::optional<Vec3> towards = forearm ? surface_centroid(*forearm) : std::nullopt;
    if (!towards || hand.triangles.empty()) return surface_centroid(hand);
    double nearest = std::numeric_limits<double>::infinity();
    for (const auto& t : hand.triangles) nearest = std::min(nearest, ((hand.vertices[t[0]] + hand.vertices[t[1]] + hand.vertices[t[2]]) / 3.0 - *towards).norm());
    const std::optional<Vec3> cap = weighted_surface_centroid(hand, [&](const Vec3& centre) {
        const double e = ((centre - *towards).norm() - nearest) / kWristBand;
        return std::exp(-e * e);
    });
    return cap ? cap : surface_centroid(hand);
}

// The hips and hands of a labelled mesh sequence, per frame: the area-weighted surface centroid
// of its torso (standing in for the hips: both carry the body over the floor) and each hand's
// wrist (docs/method.md section 13).
propose::HandTrack part_track(ObjectSource& o) {
    const SceneObject& spec = o.spec();
    const std::string& file = spec.labels.empty() ? spec.meshes : spec.labels;
    if (spec.labels.empty())
        fail(file, "object {} is a mesh sequence without part labels: amhv propose follows its torso and hands, so give it `labels` "
             "(one part name per vertex, docs/scenes.md)", spec.name);
    propose::HandTrack t;
    t.fps = spec.fps;
    t.first = spec.frame_first;
    for (int f = spec.frame_first; f <= spec.frame_last; ++f) {
        const std::vector<BodyPart>& parts = o.frame_parts(f);
        auto mesh = [&](const std::string& name) -> const TriangleMesh* {
            const auto part = std::find_if(parts.begin(), parts.end(), [&](const BodyPart& p) { return p.name == name; });
            return part == parts.end() || part->mesh.vertices.empty() ? nullptr : &part->mesh;
        };
        auto need = [&](const std::string& name) -> const TriangleMesh& {
            const TriangleMesh* m = mesh(name);
            if (!m) fail(file, "object {}: frame {} has no vertex labelled {} (amhv propose follows a mesh sequence's torso and hands)", spec.name, f, name);
            return *m;
        };
        t.hips.push_back(*surface_centroid(need("torso")));
        for (const propose::Hand hand : {propose::Hand::Left, propose::Hand::Right}) {
            const std::string side = hand == propose::Hand::Left ? "left_" : "right_";
            t.hand[int(hand)].push_back(*wrist(need(side + "hand"), mesh(side + "forearm")));
        }
    }
    return t;
}

// The hips and hands of a BVH take, of a character's rig or of a labelled mesh sequence, over the
// object's frames.
propose::HandTrack hand_track_of(ObjectSource& o) {
    const SceneObject& spec = o.spec();
    if (o.motion()) return propose::hand_track(*o.motion(), spec.units, spec.frame_first, spec.frame_last, spec.bvh);
    if (o.character())
        return propose::hand_track(character_joints(*o.character()), spec.units, character_file(*o.character()).fps, spec.frame_first,
                                   spec.frame_last);
    return part_track(o);
}

}  // namespace

ProposeResult propose_scene(const Scene& scene, Backends& backends) {
    const auto start = std::chrono::steady_clock::now();
    ObjectSource a(scene.a, backends.skinner), b(scene.b, backends.skinner);
    const propose::HandTrack track_a = hand_track_of(a), track_b = hand_track_of(b);
    ProposeResult out;
    out.events_a = propose::contact_events(track_a);
    out.events_b = propose::contact_events(track_b);
    const std::vector<propose::Candidate> candidates = propose::candidates(track_a, out.events_a, track_b, out.events_b);
    out.candidates = int(candidates.size());
    // The coarse sampling: kCoarseAngleDeg divides 360, and so does a coarser step of the scene's.
    Scene coarse = scene;
    coarse.sampling.voxel = std::max(scene.sampling.voxel, propose::kCoarseVoxel);
    coarse.sampling.angle_step_deg = std::max(scene.sampling.angle_step_deg, propose::kCoarseAngleDeg);
    for (std::size_t c = 0; c < candidates.size(); ++c) {
        Proposal p{candidates[c], propose::candidate_segment(candidates[c], int(c) + 1), {}, std::nullopt};
        p.segment.pair = {scene.a.name, scene.b.name};
        p.coarse = sweep_candidate(coarse, p.segment, a, b, backends);
        if (p.coarse.members > 0) out.proposals.push_back(std::move(p));
    }
    rank(out.proposals);
    const bool finer = coarse.sampling.voxel != scene.sampling.voxel || coarse.sampling.angle_step_deg != scene.sampling.angle_step_deg;
    for (std::size_t n = 0; finer && n < std::min(out.proposals.size(), std::size_t(propose::kRefined)); ++n)
        out.proposals[n].refined = sweep_candidate(scene, out.proposals[n].segment, a, b, backends);
    rank(out.proposals);
    std::erase_if(out.proposals, [](const Proposal& p) { return p.decided().members == 0; });
    out.seconds = seconds_since(start);
    return out;
}

Scene with_proposal(const Scene& scene, const Proposal& proposal) {
    Scene out = scene;
    out.segments = {proposal.segment};
    out.segments.front().index = 1;
    return out;
}

void require_proposals(const Scene& scene, const ProposeResult& result) {
    if (!result.proposals.empty()) return;
    const std::size_t a = result.events_a.size(), b = result.events_b.size();
    fail(scene.file.string(), "no proposal: A shows {} contact moment{}, B {}; {} pair{} of them swept, and in none does a pose of B within the "
         "sweep's range meet A", a, a == 1 ? "" : "s", b, result.candidates, result.candidates == 1 ? "" : "s");
}

results::Json proposals_json(const Scene& scene, const ProposeResult& result) {
    auto event_json = [](const propose::ContactEvent& e) {
        return results::Json{{"type", e.variant == 'a' ? "0&0a" : "0&0b"}, {"hand", propose::hand_part(e.hand)}, {"frames", {e.first, e.last}},
                             {"moment", e.moment}, {"strength", e.strength}, {"why", e.why}};
    };
    auto sweep_json = [](const ProposalSweep& s) {
        return results::Json{{"voxel", s.voxel}, {"angle_step_deg", s.angle_step_deg}, {"poses", s.poses}, {"members", s.members},
                             {"rejected", {{"contact", s.rejected[0]}, {"dictionary", s.rejected[1]}, {"fidelity", s.rejected[2]}, {"visibility", s.rejected[3]}}},
                             {"natural", results::natural_terms_json(s.terms)}, {"best", results::solution_json(s.best)}};
    };
    results::Json out{{"scene", scene.file.string()}, {"candidates", result.candidates}, {"seconds", result.seconds}};
    for (const auto& [name, events] : {std::pair{"A", &result.events_a}, {"B", &result.events_b}}) {
        out["events"][name] = results::Json::array();
        for (const auto& e : *events) out["events"][name].push_back(event_json(e));
    }
    out["proposals"] = results::Json::array();
    for (std::size_t n = 0; n < result.proposals.size(); ++n) {
        const Proposal& p = result.proposals[n];
        const propose::Candidate& c = p.candidate;
        results::Json j{{"rank", n + 1}, {"type", p.segment.type.name()}, {"a", {c.a[0], c.a[1]}}, {"b", {c.b[0], c.b[1]}},
                        {"shift_frames", c.shift()}, {"parts", {{"A", propose::hand_part(c.hand_a)}, {"B", propose::hand_part(c.hand_b)}}},
                        {"coupling_m", c.coupling_m < 0 ? results::Json(nullptr) : results::Json(c.coupling_m)}, {"coarse", sweep_json(p.coarse)},
                        {"refined", p.refined ? sweep_json(*p.refined) : results::Json(nullptr)}, {"why", c.why}};
        out["proposals"].push_back(std::move(j));
    }
    return out;
}

std::string proposals_toml(const Scene& scene, const ProposeResult& result) {
    std::ostringstream s;
    s << fmt::format("# Key segments proposed by `amhv propose` for {} ({} pairs of contact moments swept, {} with a member),\n", scene.file.string(),
                     result.candidates, result.proposals.size());
    s << "# best first. Paste the [[segments]] blocks you want into the scene (docs/method.md section 13).\n";
    for (std::size_t n = 0; n < result.proposals.size(); ++n) {
        const Proposal& p = result.proposals[n];
        const ProposalSweep& d = p.decided();
        const KeySegment& k = p.segment;
        s << fmt::format("\n# {}. {} on {} / {}: B's frame {} meets A's {} (shift {:+d}); {} members at {} m / {} deg, natural score {:.2f} at x {:.2f}, "
                         "y {:.2f}, theta {:.0f} deg\n",
                         n + 1, k.type.name(), propose::hand_part(p.candidate.hand_a), propose::hand_part(p.candidate.hand_b), k.b[0], k.a[0],
                         p.candidate.shift(), d.members, d.voxel, d.angle_step_deg, d.score, d.best.x, d.best.y, d.best.theta_deg);
        s << "# " << p.candidate.why << '\n';
        s << "[[segments]]\n";
        s << fmt::format("a = [{}, {}]\nb = [{}, {}]\ntype = \"{}\"\n", k.a[0], k.a[1], k.b[0], k.b[1], k.type.name());
        s << fmt::format("interest = {{ A = {{ parts = [{}] }}, B = {{ parts = [{}] }} }}\n", part_list(k.interest_a), part_list(k.interest_b));
        s << fmt::format("fidelity = {{ A = {{ parts_except = [{}] }}, B = {{ parts_except = [{}] }} }}\n", part_list(k.fidelity_a), part_list(k.fidelity_b));
        s << fmt::format("visibility = {{ enabled = true, half_angle_deg = {:.1f} }}\n", k.visibility.half_angle_deg);
    }
    return s.str();
}

std::string proposals_page(const Scene& scene, const ProposeResult& result, const std::string& best_note) {
    std::string page = fmt::format(
        "<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>amhv propose: {0}</title>\n<style>body{{font-family:sans-serif;margin:1em}}"
        "table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:2px 6px;font-size:13px;vertical-align:top}}pre{{margin:0;font-size:11px}}"
        "iframe{{width:100%;height:620px;border:1px solid #ccc}}</style></head><body>\n<h1>Key segments proposed for {0}</h1>\n"
        "<p>Contact moments per take (rows: left slap, right slap, left hold, right hold; hover for the cue). {1} pairs swept, {2} with a member, "
        "best first (docs/method.md section 13).</p>\n",
        compose::html_text(scene.file.filename().string()), result.candidates, result.proposals.size());
    auto title = [](const char* side, const std::string& name) { return name == side ? name : fmt::format("{} ({})", side, name); };
    page += moments_strip(title("A", scene.a.name), scene.a.frame_first, scene.a.frame_last, result.events_a);
    page += moments_strip(title("B", scene.b.name), scene.b.frame_first, scene.b.frame_last, result.events_b);
    page += "<h2>Proposals</h2>\n<table><tr><th>#</th><th>type</th><th>hands (A / B)</th><th>A frames</th><th>B frames</th><th>shift</th>"
            "<th>members</th><th>natural score</th><th>why</th></tr>\n";
    for (std::size_t n = 0; n < result.proposals.size(); ++n) {
        const Proposal& p = result.proposals[n];
        const ProposalSweep& d = p.decided();
        page += fmt::format("<tr><td>{}</td><td>{}</td><td>{} / {}</td><td>{}-{}</td><td>{}-{}</td><td>{:+d}</td><td>{} at {} m / {}&deg;</td><td>{:.2f}</td>"
                            "<td>{}</td></tr>\n",
                            n + 1, compose::html_text(p.segment.type.name()), propose::hand_part(p.candidate.hand_a), propose::hand_part(p.candidate.hand_b),
                            p.segment.a[0], p.segment.a[1], p.segment.b[0], p.segment.b[1], p.candidate.shift(), d.members, d.voxel, d.angle_step_deg,
                            d.score, compose::html_text(p.candidate.why));
    }
    page += "</table>\n<p><code>proposals.toml</code> holds each as a <code>[[segments]]</code> block to paste into the scene.</p>\n";
    page += "<h2>The best proposal, edited</h2>\n";
    page += best_note.empty() ? "<iframe src=\"best/index.html\" title=\"the best proposal, edited\"></iframe>\n"
                              : fmt::format("<p>{}</p>\n", compose::html_text(best_note));
    return page + "</body></html>\n";
}

}  // namespace amhv::pipeline
