#include "src/compose/compose_page.hpp"

#include <array>

#include <fmt/format.h>

namespace amhv::compose {

namespace {

constexpr double kWidth = 900;  // pixels for the longest take or the composed take

// A colour per action (a qualitative palette, Okabe and Ito 2008); unknown is grey.
std::string colour(int action) {
    static constexpr std::array<const char*, 8> palette{"#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00", "#F0E442", "#000000"};
    return action < 0 ? "#d0d0d0" : palette[std::size_t(action) % palette.size()];
}

std::string legend(const Library& library) {
    std::string out = "<p>";
    for (std::size_t a = 0; a < library.actions.size(); ++a)
        out += fmt::format("<span class=\"key\" style=\"background:{}\"></span>{} ", colour(int(a)), html_text(library.actions[a]));
    return out + fmt::format("<span class=\"key\" style=\"background:{}\"></span>unknown</p>\n", colour(-1));
}

// One take's labels as runs of colour, its nodes outlined.
std::string take_strip(const Library& library, const Recognition& recognition, const MotionGraph& graph, std::size_t t, double scale) {
    const LibraryTake& take = library.takes[t];
    const auto& labels = recognition.labels[t].action;
    std::string svg = fmt::format("<h3>{}</h3>\n<svg width=\"{:.0f}\" height=\"34\">", html_text(take.name), double(take.frames()) * scale + 2);
    for (std::size_t start = 0; start < labels.size();) {
        std::size_t end = start;
        while (end + 1 < labels.size() && labels[end + 1] == labels[start]) ++end;
        svg += fmt::format("<rect x=\"{:.2f}\" y=\"2\" width=\"{:.2f}\" height=\"20\" fill=\"{}\"><title>frames {}..{}: {}</title></rect>", double(start) * scale + 1,
                           double(end - start + 1) * scale, colour(labels[start]), take.first + int(start), take.first + int(end),
                           labels[start] < 0 ? std::string("unknown") : html_text(library.actions[std::size_t(labels[start])]));
        start = end + 1;
    }
    for (const Node& n : graph.nodes)
        if (n.take == int(t))
            svg += fmt::format("<rect x=\"{:.2f}\" y=\"1\" width=\"{:.2f}\" height=\"22\" fill=\"none\" stroke=\"#222\"/>", double(n.first - take.first) * scale + 1,
                               double(n.last - n.first + 1) * scale);
    return svg + fmt::format("<text x=\"1\" y=\"33\" font-size=\"10\">frame {}</text></svg>\n", take.first);
}

std::string timeline(const Library& library, const MotionGraph& graph, const Composed& c) {
    const double scale = kWidth / double(c.spliced.motion.frame_count);
    std::string svg = fmt::format("<svg width=\"{:.0f}\" height=\"48\">", kWidth + 2);
    int at = 0;
    for (std::size_t k = 0; k < c.path.clips.size(); ++k) {
        const Clip& clip = c.path.clips[k];
        // The later clip of a splice gives its first frame to the blend's meeting frame.
        const bool spliced = k > 0 && !graph.edges[std::size_t(c.path.edges[k - 1])].continuation;
        const int frames = clip.last - clip.first + 1 - (spliced ? 1 : 0);
        svg += fmt::format("<rect x=\"{:.2f}\" y=\"2\" width=\"{:.2f}\" height=\"24\" fill=\"{}\" stroke=\"#fff\"><title>{}: take {} frames {}..{}</title></rect>",
                           double(at) * scale + 1, double(frames) * scale, colour(library.action_index(c.query[k].action)), html_text(c.query[k].action),
                           html_text(library.takes[std::size_t(clip.take)].name), clip.first, clip.last);
        svg += fmt::format("<text x=\"{:.2f}\" y=\"40\" font-size=\"11\">{} ({})</text>", double(at) * scale + 3, html_text(c.query[k].action),
                           html_text(library.takes[std::size_t(clip.take)].name));
        at += frames;
    }
    for (int s : c.spliced.splices) svg += fmt::format("<line x1=\"{0:.2f}\" x2=\"{0:.2f}\" y1=\"0\" y2=\"28\" stroke=\"#000\" stroke-width=\"2\"/>", double(s) * scale + 1);
    return svg + "</svg>\n";
}

}  // namespace

std::string html_text(const std::string& text) {
    std::string out;
    for (char c : text) {
        switch (c) {
            case '&': out += "&amp;"; break;
            case '<': out += "&lt;"; break;
            case '>': out += "&gt;"; break;
            case '"': out += "&quot;"; break;
            case '\'': out += "&#39;"; break;
            default: out += c;
        }
    }
    return out;
}

std::string compose_page(const Library& library, const Recognition& recognition, const MotionGraph& graph, const std::optional<Composed>& composed) {
    std::string html =
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>amhv compose</title>\n"
        "<style>body{font-family:sans-serif;margin:2em;max-width:960px}.key{display:inline-block;width:1em;height:1em;margin:0 .3em 0 1em;"
        "vertical-align:middle}table{border-collapse:collapse}td,th{padding:.2em .8em;text-align:left}</style></head><body>\n";
    html += fmt::format("<h1>amhv compose</h1>\n<p>{} takes at {} fps; {} nodes, {} edges in the motion graph.</p>\n", library.takes.size(), library.fps,
                        graph.nodes.size(), graph.edges.size());
    html += legend(library);
    if (composed) {
        const Composed& c = *composed;
        html += fmt::format("<h2>The composed take</h2>\n<p>{} frames ({:.2f} s); cost {:.4f} m; splices marked.</p>\n", c.spliced.motion.frame_count,
                            double(c.spliced.motion.frame_count) / library.fps, c.path.cost);
        html += timeline(library, graph, c);
        html += fmt::format("<table><tr><th>largest joint step at the splices</th><td>{:.2f} cm</td></tr><tr><th>largest inside the source clips</th>"
                            "<td>{:.2f} cm</td></tr><tr><th>farthest a planted ankle moves</th><td>{:.2f} cm</td></tr></table>\n",
                            100 * c.quality.splice_step_m, 100 * c.quality.source_step_m, 100 * c.quality.planted_drift_m);
    }
    html += "<h2>Actions recognised per take</h2>\n<p>Nodes of the motion graph outlined; hover for frames.</p>\n";
    int longest = 1;
    for (const LibraryTake& take : library.takes) longest = std::max(longest, take.frames());
    for (std::size_t t = 0; t < library.takes.size(); ++t) html += take_strip(library, recognition, graph, t, kWidth / double(longest));
    return html + "</body></html>\n";
}

}  // namespace amhv::compose
