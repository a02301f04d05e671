#include "src/results/feasibility_maps.hpp"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfThreading.h>
#include <Imath/half.h>
#include <png.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <memory>

#include <fmt/format.h>

#include "src/core/error.hpp"
#include "src/core/parallel.hpp"

namespace amhv {

namespace {

void write_png(const std::filesystem::path& path, int width, int height, const std::vector<std::uint8_t>& rgb) {
    std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "wb"), &std::fclose);
    if (!file) fail(path.string(), "cannot create the file");
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) fail(path.string(), "libpng could not start");
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        fail(path.string(), "libpng failed to write the image");
    }
    png_init_io(png, file.get());
    png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int row = 0; row < height; ++row)
        png_write_row(png, const_cast<png_bytep>(rgb.data() + std::size_t(row) * width * 3));
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
}

}  // namespace

std::array<std::uint8_t, 3> outcome_colour(PoseOutcome outcome) {
    switch (outcome) {
        case PoseOutcome::FailsContact: return {24, 24, 24};       // no contact: near black
        case PoseOutcome::FailsDictionary: return {200, 40, 40};   // wrong surfaces meet: red
        case PoseOutcome::FailsFidelity: return {230, 150, 30};    // bodies interpenetrate: orange
        case PoseOutcome::FailsVisibility: return {60, 90, 220};   // cannot see each other: blue
        default: return {60, 220, 90};                             // solution: green
    }
}

namespace {

// One angle's pixels, reused by a thread from file to file.
struct FeasibilityPlanes {
    std::vector<half> colour;   // R, G, B planes
    std::vector<float> passed;
};

// The feasibility EXR of angle k: R, G, B (the outcome colours, linear, as HALF: display values)
// and `passed` (FLOAT). Compressed by zlib at level 1: the maps are a few flat regions, so the
// files are about 15% larger than at the default level and written twice as fast (the maps were
// 40% of an `amhv sweep` at 10 mm).
void write_feasibility_exr(const std::filesystem::path& folder, const SweepProblem& problem, const SweepResult& result, int k,
                           FeasibilityPlanes& planes, const std::array<std::array<half, 3>, 5>& linear) {
    const PoseRange& r = result.range;
    const int width = r.width(), height = r.height();
    const std::size_t pixels = std::size_t(width) * std::size_t(height);
    for (int row = 0; row < height; ++row)
        for (int col = 0; col < width; ++col) {
            PoseOutcome outcome = result.best_over_heights(r.i_first + col, r.j_last - row, k);  // top row = largest y
            std::size_t pixel = std::size_t(row) * width + col;
            for (int c = 0; c < 3; ++c) planes.colour[std::size_t(c) * pixels + pixel] = linear[std::size_t(outcome)][std::size_t(c)];
            planes.passed[pixel] = float(int(outcome));
        }
    Imf::Header header(width, height);
    header.compression() = Imf::ZIP_COMPRESSION;
    header.zipCompressionLevel() = 1;
    const char* colours[] = {"R", "G", "B"};
    for (const char* c : colours) header.channels().insert(c, Imf::Channel(Imf::HALF));
    header.channels().insert("passed", Imf::Channel(Imf::FLOAT));
    auto put = [&](const char* key, const std::string& value) { header.insert(key, Imf::StringAttribute(value)); };
    put("amhv:theta_deg", fmt::format("{}", problem.angle_lattice().wrapped_degrees(k)));
    put("amhv:x_m", fmt::format("column c is x = {} + c * {} m (offset of B's root from A's root)", r.i_first * problem.voxel, problem.voxel));
    put("amhv:y_m", fmt::format("row 0 is y = {} m, each row down {} m less", r.j_last * problem.voxel, problem.voxel));
    if (r.depth() > 1)
        put("amhv:z_m", fmt::format("each pixel is the furthest outcome over B raised by {} .. {} m", r.z_first * problem.voxel, r.z_last * problem.voxel));
    put("amhv:passed", "constraints passed in order contact, dictionary, fidelity, visibility; 4 = solution");
    Imf::FrameBuffer buffer;
    for (int c = 0; c < 3; ++c)
        buffer.insert(colours[c], Imf::Slice(Imf::HALF, reinterpret_cast<char*>(planes.colour.data() + std::size_t(c) * pixels), sizeof(half),
                                             sizeof(half) * std::size_t(width)));
    buffer.insert("passed", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(planes.passed.data()), sizeof(float), sizeof(float) * std::size_t(width)));
    auto path = folder / fmt::format("angle_{:03d}.exr", k);
    Imf::OutputFile file(path.c_str(), header);
    file.setFrameBuffer(buffer);
    file.writePixels(height);
}

}  // namespace

int write_feasibility_maps(const std::filesystem::path& folder, const SweepProblem& problem, const SweepResult& result) {
    Imf::setGlobalThreadCount(0);  // byte-identical files
    std::filesystem::create_directories(folder);
    const PoseRange& r = result.range;
    const int width = r.width(), height = r.height();
    if (width <= 0 || height <= 0) return 0;
    // Linear values of the five outcome colours, once.
    std::array<std::array<half, 3>, 5> linear{};
    for (int o = 0; o < 5; ++o) {
        auto rgb = outcome_colour(PoseOutcome(o));
        for (int c = 0; c < 3; ++c) linear[std::size_t(o)][std::size_t(c)] = half(std::pow(rgb[std::size_t(c)] / 255.0f, 2.2f));
    }
    // One file per angle, written on all cores (each file alone is byte-identical to a serial write).
    parallel_for(std::size_t(r.angles), [&](std::size_t k) {
        thread_local FeasibilityPlanes planes;
        planes.colour.resize(std::size_t(3) * width * height);
        planes.passed.resize(std::size_t(width) * height);
        write_feasibility_exr(folder, problem, result, int(k), planes, linear);
    });
    const int files = r.angles;
    // Montage: angles tiled in rows, each tile at most 160 px (nearest sampling), 2 px gaps.
    const int scale_down = std::max(1, (std::max(width, height) + 159) / 160);
    const int tile_w = (width + scale_down - 1) / scale_down, tile_h = (height + scale_down - 1) / scale_down;
    const int columns = std::min(r.angles, int(std::ceil(std::sqrt(double(r.angles)))));
    const int rows = (r.angles + columns - 1) / columns;
    const int image_w = columns * (tile_w + 2) + 2, image_h = rows * (tile_h + 2) + 2;
    std::vector<std::uint8_t> rgb(std::size_t(image_w) * image_h * 3, 255);
    for (int k = 0; k < r.angles; ++k) {
        int ox = 2 + (k % columns) * (tile_w + 2), oy = 2 + (k / columns) * (tile_h + 2);
        for (int ty = 0; ty < tile_h; ++ty)
            for (int tx = 0; tx < tile_w; ++tx) {
                auto colour = outcome_colour(result.best_over_heights(r.i_first + tx * scale_down, r.j_last - ty * scale_down, k));
                std::uint8_t* p = rgb.data() + (std::size_t(oy + ty) * image_w + (ox + tx)) * 3;
                p[0] = colour[0], p[1] = colour[1], p[2] = colour[2];
            }
    }
    write_png(folder / "montage.png", image_w, image_h, rgb);
    return files + 1;
}

}  // namespace amhv
