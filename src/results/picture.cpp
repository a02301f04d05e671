#include "src/results/picture.hpp"

#include <cstdlib>
#include <mutex>

#include <cairo-ft.h>
#include <ft2build.h>
#include FT_FREETYPE_H
#include <spdlog/spdlog.h>

#include "src/core/error.hpp"

namespace amhv {

namespace {

// One FreeType face for the process, opened on first use and kept (cairo holds a reference).
cairo_font_face_t* font_face() {
    static std::once_flag once;
    static cairo_font_face_t* face = nullptr;
    std::call_once(once, [] {
        const std::string path = picture_font_path();
        FT_Library library = nullptr;
        FT_Face ft = nullptr;
        if (FT_Init_FreeType(&library) != 0 || FT_New_Face(library, path.c_str(), 0, &ft) != 0) {
            spdlog::warn("pictures are drawn without text: cannot read the font {} (tools/setup.sh installs fonts-dejavu-core)", path);
            return;
        }
        face = cairo_ft_font_face_create_for_ft_face(ft, FT_LOAD_NO_HINTING);
        // The face outlives every picture; FreeType's library and face stay open with it.
    });
    return face;
}

void use_font(cairo_t* cr, cairo_font_face_t* face, double size) {
    cairo_set_font_face(cr, face);
    cairo_set_font_size(cr, size);
    cairo_font_options_t* options = cairo_font_options_create();
    cairo_font_options_set_hint_style(options, CAIRO_HINT_STYLE_NONE);
    cairo_font_options_set_hint_metrics(options, CAIRO_HINT_METRICS_OFF);
    cairo_font_options_set_antialias(options, CAIRO_ANTIALIAS_GRAY);
    cairo_set_font_options(cr, options);
    cairo_font_options_destroy(options);
}

}  // namespace

std::string picture_font_path() {
    if (const char* env = std::getenv("AMHV_FONT")) return env;
    return "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
}

bool draw_text(cairo_t* cr, double x, double y, const std::string& text, double size, TextAnchor anchor) {
    cairo_font_face_t* face = font_face();
    if (!face || text.empty()) return face != nullptr;
    cairo_save(cr);
    use_font(cr, face, size);
    cairo_text_extents_t extents;
    cairo_text_extents(cr, text.c_str(), &extents);
    const double shift = anchor == TextAnchor::Start ? 0 : anchor == TextAnchor::Middle ? extents.x_advance / 2 : extents.x_advance;
    cairo_move_to(cr, x - shift, y);
    cairo_show_text(cr, text.c_str());
    cairo_restore(cr);
    return true;
}

double text_width(const std::string& text, double size) {
    cairo_font_face_t* face = font_face();
    if (!face) return 0.6 * size * double(text.size());
    cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_A8, 1, 1);
    cairo_t* cr = cairo_create(surface);
    use_font(cr, face, size);
    cairo_text_extents_t extents;
    cairo_text_extents(cr, text.c_str(), &extents);
    cairo_destroy(cr);
    cairo_surface_destroy(surface);
    return extents.x_advance;
}

void fill_triangle(cairo_t* cr, const std::array<Eigen::Vector2d, 3>& corners, double shade, const std::array<std::uint8_t, 3>& colour) {
    cairo_set_source_rgb(cr, shade * colour[0] / 255.0, shade * colour[1] / 255.0, shade * colour[2] / 255.0);
    for (int c = 0; c < 3; ++c) (c ? cairo_line_to : cairo_move_to)(cr, corners[std::size_t(c)].x(), corners[std::size_t(c)].y());
    cairo_close_path(cr);
    cairo_fill_preserve(cr);
    cairo_set_line_width(cr, 0.5);
    cairo_stroke(cr);
}

void finish_png(cairo_t* cr, cairo_surface_t* surface, const std::filesystem::path& path) {
    cairo_destroy(cr);
    const cairo_status_t status = cairo_surface_write_to_png(surface, path.string().c_str());
    cairo_surface_destroy(surface);
    if (status != CAIRO_STATUS_SUCCESS) fail(path.string(), "cannot write the PNG ({})", cairo_status_to_string(status));
}

}  // namespace amhv
