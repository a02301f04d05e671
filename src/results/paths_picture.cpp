#include "src/results/paths_picture.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <numbers>

#include <cairo.h>
#include <fmt/format.h>

#include "src/core/error.hpp"
#include "src/io/files.hpp"
#include "src/results/edit_files.hpp"
#include "src/results/picture.hpp"

namespace amhv {

namespace fs = std::filesystem;

namespace {

using Colour = std::array<std::uint8_t, 3>;
constexpr Colour kInk{30, 30, 30}, kGrid{225, 225, 225}, kAxis{120, 120, 120};
constexpr double kText = 13, kTitle = 16;

// One list of shapes, drawn into SVG text and into a cairo PNG alike.
struct Shape {
    enum class Kind { Line, Circle, Text } kind = Kind::Line;
    std::vector<Eigen::Vector2d> points;  // picture coordinates (pixels, y down)
    Colour colour = kInk;
    double width = 1, radius = 0, opacity = 1, size = kText;
    bool dashed = false;
    TextAnchor anchor = TextAnchor::Start;
    std::string text;
};

Shape line(std::vector<Eigen::Vector2d> points, Colour colour, double width, bool dashed = false, double opacity = 1) {
    Shape s;
    s.points = std::move(points), s.colour = colour, s.width = width, s.dashed = dashed, s.opacity = opacity;
    return s;
}

Shape text(Eigen::Vector2d at, std::string words, Colour colour = kInk, double size = kText, TextAnchor anchor = TextAnchor::Start) {
    Shape s;
    s.kind = Shape::Kind::Text, s.points = {at}, s.text = std::move(words), s.colour = colour, s.size = size, s.anchor = anchor;
    return s;
}

Shape dot(Eigen::Vector2d at, Colour colour, double radius) {
    Shape s;
    s.kind = Shape::Kind::Circle, s.points = {at}, s.colour = colour, s.radius = radius;
    return s;
}

std::string xml_escaped(const std::string& s) {
    std::string out;
    for (char c : s) out += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : std::string(1, c);
    return out;
}

void draw_svg(const fs::path& path, int w, int h, const std::vector<Shape>& shapes) {
    std::ofstream out(path);
    if (!out) fail(path.string(), "cannot write");
    out << fmt::format("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" viewBox=\"0 0 {} {}\">\n", w, h, w, h);
    out << fmt::format("<rect width=\"{}\" height=\"{}\" fill=\"white\"/>\n", w, h);
    for (const Shape& s : shapes) {
        const std::string rgb = fmt::format("rgb({},{},{})", s.colour[0], s.colour[1], s.colour[2]);
        if (s.kind == Shape::Kind::Line) {
            std::string points;
            for (const auto& p : s.points) points += fmt::format("{}{:.2f},{:.2f}", points.empty() ? "" : " ", p.x(), p.y());
            out << fmt::format("<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"{}\" stroke-opacity=\"{}\"{} "
                               "stroke-linecap=\"round\" stroke-linejoin=\"round\"/>\n",
                               points, rgb, s.width, s.opacity, s.dashed ? " stroke-dasharray=\"6 4\"" : "");
        } else if (s.kind == Shape::Kind::Circle) {
            out << fmt::format("<circle cx=\"{:.2f}\" cy=\"{:.2f}\" r=\"{}\" fill=\"{}\"/>\n", s.points[0].x(), s.points[0].y(), s.radius, rgb);
        } else {
            const char* anchor = s.anchor == TextAnchor::Start ? "start" : s.anchor == TextAnchor::Middle ? "middle" : "end";
            out << fmt::format("<text x=\"{:.2f}\" y=\"{:.2f}\" font-family=\"DejaVu Sans, sans-serif\" font-size=\"{}\" text-anchor=\"{}\" "
                               "fill=\"{}\">{}</text>\n",
                               s.points[0].x(), s.points[0].y(), s.size, anchor, rgb, xml_escaped(s.text));
        }
    }
    out << "</svg>\n";
    finish_file(out, path);
}

void draw_png(const fs::path& path, int w, int h, const std::vector<Shape>& shapes) {
    cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_RGB24, w, h);
    cairo_t* cr = cairo_create(surface);
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_paint(cr);
    cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
    cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
    for (const Shape& s : shapes) {
        cairo_set_source_rgba(cr, s.colour[0] / 255.0, s.colour[1] / 255.0, s.colour[2] / 255.0, s.opacity);
        if (s.kind == Shape::Kind::Line) {
            const double dash[2] = {6, 4};
            cairo_set_dash(cr, dash, s.dashed ? 2 : 0, 0);
            cairo_set_line_width(cr, s.width);
            for (std::size_t k = 0; k < s.points.size(); ++k) (k ? cairo_line_to : cairo_move_to)(cr, s.points[k].x(), s.points[k].y());
            cairo_stroke(cr);
        } else if (s.kind == Shape::Kind::Circle) {
            cairo_arc(cr, s.points[0].x(), s.points[0].y(), s.radius, 0, 2 * std::numbers::pi);
            cairo_fill(cr);
        } else {
            draw_text(cr, s.points[0].x(), s.points[0].y(), s.text, s.size, s.anchor);
        }
    }
    finish_png(cr, surface, path);
}

using Pixel = std::function<Eigen::Vector2d(const Eigen::Vector2d&)>;

// One object's captured and edited root paths with facing ticks every 10 output frames, its name at
// the edited path's start, and its key segments thick and numbered, in `colour`.
void add_object_paths(std::vector<Shape>& shapes, const PathsObject& object, Colour colour, const Pixel& pixel) {
    const auto& frames = *object.frames;
    for (int edited = 0; edited < 2; ++edited) {
        Shape path = line({}, colour, edited ? 2 : 1.5, !edited, edited ? 1 : 0.6);
        for (const auto& f : frames) path.points.push_back(pixel(edited ? f.edited_root : f.original_root));
        shapes.push_back(path);
        for (std::size_t k = 0; k < frames.size(); k += 10) {
            const auto& f = frames[k];
            const Eigen::Vector2d root = pixel(edited ? f.edited_root : f.original_root);
            const double facing = edited ? f.edited_facing : f.original_facing;
            shapes.push_back(line({root, root + 14 * Eigen::Vector2d(std::cos(facing), -std::sin(facing))}, colour, 1, false, path.opacity));
        }
    }
    if (!frames.empty()) {
        const Eigen::Vector2d start = pixel(frames.front().edited_root);
        shapes.push_back(dot(start, colour, 3));
        shapes.push_back(text(start + Eigen::Vector2d(-8, -8), object.name, colour, kText, TextAnchor::End));
    }
    for (const auto& [key, first, count] : object.keys) {
        Shape thick = line({}, colour, 6);
        for (int m = first; m < first + count; ++m) thick.points.push_back(pixel(frames[std::size_t(m)].edited_root));
        if (thick.points.size() == 1) thick.points.push_back(thick.points.front());
        shapes.push_back(thick);
        const Eigen::Vector2d at = pixel(frames[std::size_t(first)].edited_root);
        shapes.push_back(dot(at, colour, 4));
        shapes.push_back(text(at + Eigen::Vector2d(7, -7), fmt::format("{}: key {}", object.name, key), colour));
    }
}

// The legend's rows from `top`: a row per performer (its colour, edited solid, captured dashed),
// then how key segments, facings and starts look. Returns the y below it.
double add_legend(std::vector<Shape>& shapes, const std::vector<PathsObject>& objects, double top, double left) {
    shapes.push_back(text({left, top}, "Root paths seen from above (metres; x to the right, y up)", kInk, kTitle));
    double y = top + 24;
    for (std::size_t o = 0; o < objects.size(); ++o, y += 20) {
        const Colour colour = kObjectColours[o % kObjectColours.size()];
        double x = left;
        shapes.push_back(text({x, y + 4}, fmt::format("{} ({})", objects[o].name, kObjectColourNames[o % kObjectColourNames.size()]), colour));
        x += std::max(110.0, text_width(fmt::format("{} ({})", objects[o].name, "purple"), kText) + 16);
        shapes.push_back(line({{x, y}, {x + 36, y}}, colour, 2));
        shapes.push_back(text({x + 44, y + 4}, "edited path"));
        x += 44 + text_width("edited path", kText) + 24;
        shapes.push_back(line({{x, y}, {x + 36, y}}, colour, 1.5, true, 0.6));
        shapes.push_back(text({x + 44, y + 4}, "captured path (at the editor's initial placement)"));
    }
    double x = left;
    shapes.push_back(line({{x, y}, {x + 36, y}}, kAxis, 6));
    shapes.push_back(dot({x, y}, kAxis, 4));
    shapes.push_back(text({x + 44, y + 4}, "key segment N, labelled at its first frame"));
    x += 44 + text_width("key segment N, labelled at its first frame", kText) + 24;
    shapes.push_back(line({{x, y + 6}, {x + 14, y - 6}}, kAxis, 1));
    shapes.push_back(text({x + 22, y + 4}, "facing, every 10 output frames"));
    x += 22 + text_width("facing, every 10 output frames", kText) + 24;
    shapes.push_back(dot({x + 4, y}, kAxis, 3));
    shapes.push_back(text({x + 14, y + 4}, "first output frame"));
    return y + 16;
}

// A tick step of 0.25, 0.5, 1, 2, 5, 10, ... metres that gives at most 12 ticks over `extent`.
double tick_step(double extent) {
    for (double step : {0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 200.0, 500.0})
        if (extent / step <= 12) return step;
    return 1000.0;
}

// Grid lines, tick labels, axis names and the frame around the plot; a 1 m scale bar in its corner.
void add_axes(std::vector<Shape>& shapes, const Eigen::AlignedBox2d& world, const Eigen::AlignedBox2d& plot, double scale, const Pixel& pixel) {
    const double step = tick_step(std::max(world.sizes().x(), world.sizes().y()));
    for (int axis = 0; axis < 2; ++axis)
        for (double v = std::ceil(world.min()[axis] / step) * step; v <= world.max()[axis] + 1e-9; v += step) {
            const double m = std::abs(v) < 1e-9 ? 0.0 : v;
            Eigen::Vector2d a = world.min(), b = world.max();
            a[axis] = b[axis] = m;
            shapes.push_back(line({pixel(a), pixel(b)}, std::abs(m) < 1e-9 ? Colour{190, 190, 190} : kGrid, 1));
            const Eigen::Vector2d at = pixel(a);
            if (axis == 0) shapes.push_back(text({at.x(), plot.max().y() + 18}, fmt::format("{:g}", m), kAxis, 12, TextAnchor::Middle));
            else shapes.push_back(text({plot.min().x() - 8, at.y() + 4}, fmt::format("{:g}", m), kAxis, 12, TextAnchor::End));
        }
    const Eigen::Vector2d c0 = plot.min(), c1 = plot.max();
    shapes.push_back(line({c0, {c1.x(), c0.y()}, c1, {c0.x(), c1.y()}, c0}, kAxis, 1));
    shapes.push_back(text({0.5 * (c0.x() + c1.x()), c1.y() + 38}, "x (m)", kAxis, kText, TextAnchor::Middle));
    shapes.push_back(text({c0.x() - 8, c0.y() - 8}, "y (m)", kAxis, kText, TextAnchor::End));
    const Eigen::Vector2d bar(c1.x() - 16 - scale, c1.y() - 16);
    shapes.push_back(line({bar, bar + Eigen::Vector2d(scale, 0)}, kInk, 3));
    shapes.push_back(line({bar + Eigen::Vector2d(0, -5), bar + Eigen::Vector2d(0, 5)}, kInk, 1.5));
    shapes.push_back(line({bar + Eigen::Vector2d(scale, -5), bar + Eigen::Vector2d(scale, 5)}, kInk, 1.5));
    shapes.push_back(text(bar + Eigen::Vector2d(scale / 2, -9), "1 m", kInk, kText, TextAnchor::Middle));
}

}  // namespace

void write_paths_picture(const fs::path& svg, const fs::path& png, const std::vector<PathsObject>& objects) {
    Eigen::AlignedBox2d world;
    for (const PathsObject& object : objects)
        for (const ObjectFrameEdit& f : *object.frames) {
            world.extend(f.original_root);
            world.extend(f.edited_root);
        }
    if (world.isEmpty()) world.extend(Eigen::Vector2d::Zero());
    world.min() -= Eigen::Vector2d::Constant(0.6);
    world.max() += Eigen::Vector2d::Constant(0.6);
    // The scale bar's metre must fit the plot.
    world.max().x() = std::max(world.max().x(), world.min().x() + 1.5);
    world.max().y() = std::max(world.max().y(), world.min().y() + 1.0);
    constexpr int kWidth = 1000, kMaxPlotHeight = 1300;
    constexpr double kLeft = 64, kRight = 24, kBottom = 52;
    std::vector<Shape> shapes;
    const double legend_bottom = add_legend(shapes, objects, 26, 20);
    const double top = legend_bottom + 28;
    const double s = std::min((kWidth - kLeft - kRight) / world.sizes().x(), kMaxPlotHeight / world.sizes().y());
    const Eigen::AlignedBox2d plot(Eigen::Vector2d(kLeft, top), Eigen::Vector2d(kLeft + world.sizes().x() * s, top + world.sizes().y() * s));
    const int height = int(std::ceil(plot.max().y() + kBottom));
    const Pixel pixel = [&](const Eigen::Vector2d& p) {
        return Eigen::Vector2d(kLeft + (p.x() - world.min().x()) * s, plot.max().y() - (p.y() - world.min().y()) * s);
    };
    std::vector<Shape> drawing;
    add_axes(drawing, world, plot, s, pixel);
    for (std::size_t o = 0; o < objects.size(); ++o) add_object_paths(drawing, objects[o], kObjectColours[o % kObjectColours.size()], pixel);
    drawing.insert(drawing.end(), shapes.begin(), shapes.end());
    draw_svg(svg, kWidth, height, drawing);
    draw_png(png, kWidth, height, drawing);
}

}  // namespace amhv
