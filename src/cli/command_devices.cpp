#include <iostream>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "src/cli/commands.hpp"
#include "src/gpu/context.hpp"

namespace amhv::cli {

void add_devices_command(CLI::App& app) {
    auto* command = app.add_subcommand("devices", "List the Vulkan devices and mark the one amhv would use");
    auto device = std::make_shared<int>(-1);
    command->add_option("--device", *device, "Mark device N as the one to use instead of the preferred one");
    command->callback([device] {
        gpu::ContextOptions options;
        if (*device >= 0) options.device_index = std::uint32_t(*device);
        gpu::Context context(options);
        for (const auto& d : context.devices()) {
            bool used = d.index == context.selected().index;
            std::cout << fmt::format("{} [{}] {} ({})\n", used ? "*" : " ", d.index, d.name, d.type);
            std::cout << fmt::format("      driver: {}, Vulkan {}\n", d.driver, d.api_version);
            std::cout << fmt::format("      max storage buffer range: {} MiB, max texel buffer: {} M texels, max allocation: {} MiB, "
                                     "device-local memory: {} MiB\n",
                                     d.max_storage_buffer_range >> 20, d.max_texel_buffer_elements >> 20, d.max_allocation_size >> 20,
                                     d.device_local_bytes >> 20);
            std::cout << fmt::format("      max workgroup size: {} x {} x {} ({} invocations), shared memory: {} KiB, subgroup size: {}\n",
                                     d.max_workgroup_size[0], d.max_workgroup_size[1], d.max_workgroup_size[2],
                                     d.max_workgroup_invocations, d.shared_memory_bytes / 1024, d.subgroup_size);
            if (!d.usable()) std::cout << fmt::format("      not usable: {}\n", fmt::join(d.problems, "; "));
        }
        std::cout << fmt::format("* = used (preference: discrete GPU > integrated > virtual > CPU; --device N picks another)\n");
        std::cout << (context.staged_transfers()
                          ? "the sweep's buffers: device-local memory, moved by transfers (a discrete GPU)\n"
                          : "the sweep's buffers: host memory, read by the device in place\n");
    });
}

}  // namespace amhv::cli
