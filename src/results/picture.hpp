#pragma once
// What amhv's PNG pictures share: text, and writing the file. Text in the pictures, from one font file (DejaVu Sans, Debian's fonts-dejavu-core) loaded
// through FreeType with hinting off, never through the machine's font matching: the same text
// gives the same pixels wherever the same packages are installed. Without the file, pictures are
// drawn without text and one warning says why.
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>

#include <cairo.h>
#include <Eigen/Core>

namespace amhv {

enum class TextAnchor { Start, Middle, End };

// The font file amhv draws text with (AMHV_FONT overrides it, for tests).
std::string picture_font_path();

// Draws `text` at (x, y) (the baseline's start, middle or end), `size` pixels high, in the
// context's current source colour. Returns false (drawing nothing) without the font.
bool draw_text(cairo_t* cr, double x, double y, const std::string& text, double size, TextAnchor anchor = TextAnchor::Start);

// The width `text` takes at `size` pixels; an estimate (0.6 size a character) without the font, so
// that layouts do not depend on whether it is there.
double text_width(const std::string& text, double size);

// One flat-shaded triangle of a performer's colour; the thin outline closes the hairline gaps
// antialiasing leaves between neighbouring triangles.
void fill_triangle(cairo_t* cr, const std::array<Eigen::Vector2d, 3>& corners, double shade, const std::array<std::uint8_t, 3>& colour);

// Ends the drawing and writes the surface as `path`; throws naming the file when it cannot.
void finish_png(cairo_t* cr, cairo_surface_t* surface, const std::filesystem::path& path);

}  // namespace amhv
