#include "src/cli/backend.hpp"

#include "src/body/skin_vulkan.hpp"
#include "src/core/error.hpp"
#include "src/sweep/sweep_vulkan.hpp"
#include "src/voxelise/voxelise_vulkan.hpp"
#include "host/reference/sweep_reference.hpp"
#include "host/reference/voxelise_reference.hpp"

namespace amhv::cli {

void add_backend_options(CLI::App& command, std::string& backend, int& device) {
    command.add_option("--backend", backend, "vulkan or cpu (the plain reference)")->capture_default_str();
    command.add_option("--device", device, "Vulkan device index (see `amhv devices`)");
}

Backend::Backend(const std::string& name, int device) : name_(name) {
    if (name == "vulkan") {
        gpu::ContextOptions options;
        if (device >= 0) options.device_index = std::uint32_t(device);
        context_ = std::make_unique<gpu::Context>(options);
        const auto& selected = context_->selected();
        device_ = fmt::format("{} ({}, {})", selected.name, selected.type, selected.driver);
    } else if (name != "cpu") {
        throw Error(fmt::format("--backend: '{}' is not vulkan or cpu", name));
    }
}

Voxeliser& Backend::voxeliser() {
    if (!voxeliser_) {
        if (context_) voxeliser_ = std::make_unique<gpu::VulkanVoxeliser>(*context_);
        else voxeliser_ = std::make_unique<ReferenceVoxeliser>();
    }
    return *voxeliser_;
}

Sweeper& Backend::sweeper() {
    if (!sweeper_) {
        if (context_) sweeper_ = std::make_unique<gpu::VulkanSweeper>(*context_);
        else sweeper_ = std::make_unique<ReferenceSweeper>();
    }
    return *sweeper_;
}

Skinner& Backend::skinner() {
    if (!skinner_) {
        if (context_) skinner_ = std::make_unique<gpu::VulkanSkinner>(*context_);
        else skinner_ = std::make_unique<CpuSkinner>();
    }
    return *skinner_;
}

pipeline::Backends Backend::backends() { return {voxeliser(), sweeper(), name_, device_, &skinner()}; }

}  // namespace amhv::cli
