#include "src/body/skin_vulkan.hpp"

#include <algorithm>
#include <cstring>

#include "src/core/error.hpp"
#include "shaders/skin.spv.h"

namespace amhv::gpu {

namespace {

struct SkinParams {
    std::uint32_t base, count, vertex_count, palette_size;
};

}  // namespace

VulkanSkinner::VulkanSkinner(Context& context, SkinnerOptions options)
    : context_(context), options_(options) {}

std::string VulkanSkinner::name() const { return "vulkan:" + context_.selected().name; }

void VulkanSkinner::skin(const SkinVertices& vertices, std::span<const SkinFrame> frames, std::vector<float>& out) {
    const std::size_t n = vertices.count();
    out.resize(3 * n * frames.size());
    plan_ = {};
    if (n == 0 || frames.empty()) return;
    if (!kernel_) kernel_.emplace(context_, skin_spv, std::vector<Binding>{Binding::Texels128, Binding::Texels128, Binding::Storage}, sizeof(SkinParams),
                                  std::vector<std::uint32_t>{kWorkgroup});
    const std::size_t texels = context_.selected().max_texel_buffer_elements;
    std::size_t chunk = texels / 3;
    if (options_.max_chunk_vertices > 0) chunk = std::min<std::size_t>(chunk, options_.max_chunk_vertices);
    if (chunk == 0) fail("skinning", "the device takes no texel buffer");
    for (std::size_t first = 0; first < n; first += chunk) skin_chunk(vertices, first, std::min(chunk, n - first), frames, out);
}

// Vertices first .. first + count - 1 at every frame, in batches of frames.
void VulkanSkinner::skin_chunk(const SkinVertices& vertices, std::size_t first, std::size_t count, std::span<const SkinFrame> frames,
                               std::vector<float>& out) {
    ++plan_.chunks;
    const std::size_t n = vertices.count();
    std::vector<std::int32_t> texels(12 * count);
    for (std::size_t v = 0; v < count; ++v) {
        std::memcpy(&texels[12 * v], &vertices.rest[4 * (first + v)], 16);
        std::memcpy(&texels[12 * v + 4], &vertices.bones[4 * (first + v)], 16);
        std::memcpy(&texels[12 * v + 8], &vertices.weights[4 * (first + v)], 16);
    }
    const std::unique_ptr<Buffer> vertex_buffer = upload_for_kernels(context_, texels.data(), texels.size() * 4);
    const std::size_t frame_bytes = 12 * count, palette_texels = 3 * std::size_t(vertices.palette_size);
    const std::uint64_t room = std::min<std::uint64_t>(options_.max_output_bytes, context_.selected().max_storage_buffer_range);
    std::size_t per_batch = std::max<std::size_t>(1, room / frame_bytes);
    per_batch = std::min({per_batch, std::size_t(context_.selected().max_texel_buffer_elements) / palette_texels, frames.size()});
    if (per_batch == 0) fail("skinning", "a palette of {} matrices passes the device's texel limit", vertices.palette_size);
    std::vector<float> palettes;
    for (std::size_t f0 = 0; f0 < frames.size(); f0 += per_batch) {
        ++plan_.batches;
        const std::size_t batch = std::min(per_batch, frames.size() - f0);
        palettes.clear();
        for (std::size_t f = f0; f < f0 + batch; ++f) palettes.insert(palettes.end(), frames[f].palette.begin(), frames[f].palette.end());
        const std::unique_ptr<Buffer> palette_buffer = upload_for_kernels(context_, palettes.data(), palettes.size() * 4);
        positions_.ensure(context_, batch * frame_bytes);
        const BoundBuffers set = kernel_->bind({vertex_buffer.get(), palette_buffer.get(), &positions_.device()});
        Sequence sequence(context_);
        sequence.dispatch(*kernel_, set, SkinParams{0, 0, std::uint32_t(count), vertices.palette_size}, std::uint32_t(count * batch));
        positions_.copy_to_host(sequence, batch * frame_bytes);
        sequence.barrier_to_host();
        sequence.submit_and_wait();
        const std::span<const float> got = positions_.host<const float>();
        for (std::size_t f = 0; f < batch; ++f)
            std::memcpy(out.data() + 3 * (n * (f0 + f) + first), got.data() + 3 * count * f, frame_bytes);
    }
}

}  // namespace amhv::gpu
