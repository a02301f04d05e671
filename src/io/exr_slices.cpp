#include "src/io/exr_slices.hpp"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfMultiPartOutputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfOutputPart.h>
#include <OpenEXR/ImfPartType.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfThreading.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "src/core/budget.hpp"
#include "src/core/error.hpp"

namespace amhv {

namespace {

constexpr const char* kChannels[] = {"R", "G", "B", "t_start", "t_end", "frames", "label"};
constexpr int kChannelCount = 7;

struct SliceImage {
    int width = 0, height = 0;
    std::vector<float> data;  // channel-major: kChannelCount planes of width*height
    float* plane(int c) { return data.data() + std::size_t(c) * std::size_t(width) * std::size_t(height); }
};

// Image axes per slicing axis: the image's right and up directions (rows go top to bottom).
struct SliceAxes {
    int across, up, normal;
};
SliceAxes axes_for(char axis) {
    switch (axis) {
        case 'x': return {1, 2, 0};
        case 'y': return {0, 2, 1};
        default: return {0, 1, 2};
    }
}

SliceImage render_slice(const Amhv& volume, const SliceAxes& axes, int index) {
    const auto& grid = volume.grid();
    SliceImage image;
    image.width = grid.dims[std::size_t(axes.across)];
    image.height = grid.dims[std::size_t(axes.up)];
    image.data.assign(std::size_t(kChannelCount) * image.width * image.height, 0.0f);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const double last = std::max(1, volume.frames() - 1);
    for (int row = 0; row < image.height; ++row)
        for (int col = 0; col < image.width; ++col) {
            int xyz[3];
            xyz[axes.across] = col;
            xyz[axes.up] = image.height - 1 - row;
            xyz[axes.normal] = index;
            std::size_t v = grid.index(xyz[0], xyz[1], xyz[2]);
            std::size_t pixel = std::size_t(row) * image.width + col;
            int start = volume.t_start(v);
            if (start < 0) {
                image.plane(3)[pixel] = image.plane(4)[pixel] = image.plane(6)[pixel] = nan;
                continue;
            }
            int end = volume.t_end(v);
            auto rgb = time_colour(end / last);
            for (int c = 0; c < 3; ++c) image.plane(c)[pixel] = rgb[std::size_t(c)];
            image.plane(3)[pixel] = float(start);
            image.plane(4)[pixel] = float(end);
            image.plane(5)[pixel] = float(volume.frame_count(v));
            image.plane(6)[pixel] = float(volume.label(v));
        }
    return image;
}

Imf::Header make_header(const Amhv& volume, const SliceImage& image, char axis, int index) {
    const auto& grid = volume.grid();
    Imf::Header header(image.width, image.height);
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const char* name : kChannels) header.channels().insert(name, Imf::Channel(Imf::FLOAT));
    auto put = [&](const char* key, const std::string& value) { header.insert(key, Imf::StringAttribute(value)); };
    put("amhv:voxel_size_m", fmt::format("{}", grid.voxel));
    put("amhv:origin_m", fmt::format("{} {} {}", grid.origin.x(), grid.origin.y(), grid.origin.z()));
    put("amhv:grid_dims", fmt::format("{} {} {}", grid.dims[0], grid.dims[1], grid.dims[2]));
    put("amhv:axes", "capture frame, metres, right-handed, z up; voxel (i,j,k) centre = origin + (i+0.5, j+0.5, k+0.5) * voxel_size");
    auto ax = axes_for(axis);
    put("amhv:slice", fmt::format("{} = {} (centre {} m)", axis, index, grid.origin[ax.normal] + (index + 0.5) * grid.voxel));
    put("amhv:image_axes", fmt::format("columns: +{}, rows: -{} (top row is the largest {})", "xyz"[ax.across], "xyz"[ax.up], "xyz"[ax.up]));
    put("amhv:frames", fmt::format("{}", volume.frames()));
    put("amhv:empty_voxels", "t_start, t_end and label are NaN, frames is 0, RGB is black");
    put("amhv:label", "+1 ending surface (t_end = T_end), -1 starting surface (t_start = 0), 0 lateral; +1 wins when both");
    return header;
}

Imf::FrameBuffer make_frame_buffer(SliceImage& image) {
    Imf::FrameBuffer buffer;
    for (int c = 0; c < kChannelCount; ++c)
        buffer.insert(kChannels[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(image.plane(c)), sizeof(float),
                                               sizeof(float) * std::size_t(image.width)));
    return buffer;
}

}  // namespace

std::array<float, 3> time_colour(double t) {
    t = std::clamp(t, 0.0, 1.0);
    auto ramp = [](double x) { return float(std::clamp(1.5 - std::abs(x), 0.0, 1.0)); };
    return {ramp(4 * t - 3), ramp(4 * t - 2), ramp(4 * t - 1)};
}

int write_exr_slices(const Amhv& volume, const std::filesystem::path& folder, const ExrSliceOptions& options) {
    if (options.axis != 'x' && options.axis != 'y' && options.axis != 'z') throw Error(fmt::format("--axis: '{}' is not x, y or z", options.axis));
    Imf::setGlobalThreadCount(0);  // byte-identical files: no worker threads
    std::filesystem::create_directories(folder);
    SliceAxes axes = axes_for(options.axis);
    const int slices = volume.grid().dims[std::size_t(axes.normal)];
    // Disk before any slice: the uncompressed floats over ZIP's usual 4x on these mostly empty images.
    const std::uint64_t raw = std::uint64_t(volume.voxel_count()) * std::size(kChannels) * sizeof(float);
    budget::require_disk(folder, raw / 4, fmt::format("{} EXR slices", slices), "free some disk, use a larger --voxel or pass --no-exr");
    try {
        if (options.multipart) {
            std::vector<Imf::Header> headers;
            for (int i = 0; i < slices; ++i) {
                SliceImage probe{volume.grid().dims[std::size_t(axes.across)], volume.grid().dims[std::size_t(axes.up)], {}};
                Imf::Header header = make_header(volume, probe, options.axis, i);
                header.setName(fmt::format("{}_{:04d}", options.axis, i));
                header.setType(Imf::SCANLINEIMAGE);
                headers.push_back(header);
            }
            auto path = folder / fmt::format("slices_{}.exr", options.axis);
            Imf::MultiPartOutputFile file(path.c_str(), headers.data(), int(headers.size()));
            for (int i = 0; i < slices; ++i) {
                SliceImage image = render_slice(volume, axes, i);
                Imf::OutputPart part(file, i);
                part.setFrameBuffer(make_frame_buffer(image));
                part.writePixels(image.height);
            }
        } else {
            for (int i = 0; i < slices; ++i) {
                SliceImage image = render_slice(volume, axes, i);
                auto path = folder / fmt::format("{}_{:04d}.exr", options.axis, i);
                Imf::OutputFile file(path.c_str(), make_header(volume, image, options.axis, i));
                file.setFrameBuffer(make_frame_buffer(image));
                file.writePixels(image.height);
            }
        }
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        fail(folder.string(), "writing EXR slices failed: {}", e.what());
    }
    return slices;
}

}  // namespace amhv
