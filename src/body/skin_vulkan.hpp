#pragma once
// Linear blend skinning on Vulkan compute (shaders/skin.comp): the vertices go up once per call as
// texels, each batch of frames' palettes after them, and one dispatch per batch skins every
// (vertex, frame) pair; the positions come back to the host, equal bit for bit to skin_reference's.
// A batch holds as many frames as keep its positions within max_output_bytes (and the device's
// storage range); a character whose vertices pass the device's texel limit goes in vertex chunks.
#include <cstdint>
#include <memory>
#include <optional>

#include "src/body/skinning.hpp"
#include "src/gpu/compute.hpp"

namespace amhv::gpu {

struct SkinnerOptions {
    std::uint64_t max_output_bytes = std::uint64_t(64) << 20;  // tests set it small to force batches
    std::uint32_t max_chunk_vertices = 0;                      // 0: the device's texel limit; tests set it small
};

class VulkanSkinner final : public Skinner {
public:
    explicit VulkanSkinner(Context& context, SkinnerOptions options = {});
    std::string name() const override;
    void skin(const SkinVertices& vertices, std::span<const SkinFrame> frames, std::vector<float>& out) override;

    static constexpr int kWorkgroup = 64;
    // How the last call split the work, for tests.
    struct Plan {
        int chunks = 0, batches = 0;
    };
    const Plan& last_plan() const { return plan_; }

private:
    void skin_chunk(const SkinVertices& vertices, std::size_t first, std::size_t count, std::span<const SkinFrame> frames, std::vector<float>& out);
    Context& context_;
    SkinnerOptions options_;
    std::optional<Kernel> kernel_;  // built at the first call: most scenes have no character
    MirroredBuffer positions_;
    Plan plan_;
};

}  // namespace amhv::gpu
