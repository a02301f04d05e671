#include "src/gpu/context.hpp"

#include <algorithm>
#include <cstdlib>
#include <iostream>
#include <mutex>
#include <string>

#include <fmt/format.h>

#include "src/core/sanitizers.hpp"
#if defined(AMHV_ASAN)
#include <sanitizer/lsan_interface.h>
#endif

#include "src/core/error.hpp"
#include "src/core/parallel.hpp"

VULKAN_HPP_DEFAULT_DISPATCH_LOADER_DYNAMIC_STORAGE

namespace amhv::gpu {

struct Context::ValidationLog {
    mutable std::mutex mutex;
    std::vector<std::string> messages;
    bool echo = false;  // AMHV_VALIDATION=1: also print each message on stderr as it comes
};

namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";
constexpr const char* kInstallHint =
    "install a Vulkan driver: `apt install mesa-vulkan-drivers` (lavapipe, runs on the CPU) or your GPU vendor's driver";

// The instance's devices. Enumerating them makes the driver (lavapipe) run its one-time set-up,
// whose allocations it keeps in its own globals; the loader unloads it at exit, and LeakSanitizer
// then reports them from a module it cannot name, which no suppression (tools/lsan.supp) matches.
// The sanitizer build leaves the set-up's allocations out of its leak check.
vk::raii::PhysicalDevices enumerate_devices(const vk::raii::Instance& instance) {
#if defined(AMHV_ASAN)
    const __lsan::ScopedDisabler drivers_own_set_up;
#endif
    return vk::raii::PhysicalDevices(instance);
}

VKAPI_ATTR VkBool32 VKAPI_CALL on_validation_message(VkDebugUtilsMessageSeverityFlagBitsEXT,
                                                     VkDebugUtilsMessageTypeFlagsEXT,
                                                     const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
    auto* log = static_cast<Context::ValidationLog*>(user);
    std::lock_guard lock(log->mutex);
    log->messages.emplace_back(data && data->pMessage ? data->pMessage : "(no message)");
    if (log->echo) std::cerr << "amhv: validation: " << escape_controls(log->messages.back()) << '\n';
    return VK_FALSE;
}

std::string version_string(std::uint32_t v) {
    return fmt::format("{}.{}.{}", VK_API_VERSION_MAJOR(v), VK_API_VERSION_MINOR(v), VK_API_VERSION_PATCH(v));
}

DeviceInfo describe(const vk::raii::PhysicalDevice& device, std::uint32_t index) {
    DeviceInfo info;
    info.index = index;
    auto base = device.getProperties();
    info.name = base.deviceName.data();
    info.api_version = version_string(base.apiVersion);
    switch (base.deviceType) {
        case vk::PhysicalDeviceType::eDiscreteGpu: info.type = "discrete"; info.preference = 0; break;
        case vk::PhysicalDeviceType::eIntegratedGpu: info.type = "integrated"; info.preference = 1; break;
        case vk::PhysicalDeviceType::eVirtualGpu: info.type = "virtual"; info.preference = 2; break;
        case vk::PhysicalDeviceType::eCpu: info.type = "cpu"; info.preference = 3; break;
        default: info.type = "other"; info.preference = 4; break;
    }
    const auto& limits = base.limits;
    info.max_storage_buffer_range = limits.maxStorageBufferRange;
    info.max_texel_buffer_elements = limits.maxTexelBufferElements;
    info.max_workgroup_size = {limits.maxComputeWorkGroupSize[0], limits.maxComputeWorkGroupSize[1],
                               limits.maxComputeWorkGroupSize[2]};
    info.max_workgroup_invocations = limits.maxComputeWorkGroupInvocations;
    info.max_workgroup_count_x = limits.maxComputeWorkGroupCount[0];
    info.shared_memory_bytes = limits.maxComputeSharedMemorySize;

    if (base.apiVersion < VK_API_VERSION_1_1) {
        info.problems.push_back(fmt::format("Vulkan {} < 1.1", info.api_version));
        return info;
    }
    if (base.apiVersion >= VK_API_VERSION_1_2) {
        auto chain = device.getProperties2<vk::PhysicalDeviceProperties2, vk::PhysicalDeviceDriverProperties,
                                           vk::PhysicalDeviceSubgroupProperties, vk::PhysicalDeviceMaintenance3Properties>();
        const auto& driver = chain.get<vk::PhysicalDeviceDriverProperties>();
        info.driver = fmt::format("{} ({})", driver.driverName.data(), driver.driverInfo.data());
        info.subgroup_size = chain.get<vk::PhysicalDeviceSubgroupProperties>().subgroupSize;
        info.max_allocation_size = chain.get<vk::PhysicalDeviceMaintenance3Properties>().maxMemoryAllocationSize;
    } else {
        auto chain = device.getProperties2<vk::PhysicalDeviceProperties2, vk::PhysicalDeviceSubgroupProperties,
                                           vk::PhysicalDeviceMaintenance3Properties>();
        info.driver = fmt::format("driver version {}", base.driverVersion);
        info.subgroup_size = chain.get<vk::PhysicalDeviceSubgroupProperties>().subgroupSize;
        info.max_allocation_size = chain.get<vk::PhysicalDeviceMaintenance3Properties>().maxMemoryAllocationSize;
    }
    for (const auto& extension : device.enumerateDeviceExtensionProperties())
        if (std::string(extension.extensionName.data()) == VK_EXT_EXTERNAL_MEMORY_HOST_EXTENSION_NAME) {
            auto host = device.getProperties2<vk::PhysicalDeviceProperties2, vk::PhysicalDeviceExternalMemoryHostPropertiesEXT>();
            info.host_import_alignment = host.get<vk::PhysicalDeviceExternalMemoryHostPropertiesEXT>().minImportedHostPointerAlignment;
        }
    auto memory = device.getMemoryProperties();
    for (std::uint32_t h = 0; h < memory.memoryHeapCount; ++h)
        if (memory.memoryHeaps[h].flags & vk::MemoryHeapFlagBits::eDeviceLocal)
            info.device_local_bytes = std::max<std::uint64_t>(info.device_local_bytes, memory.memoryHeaps[h].size);

    auto families = device.getQueueFamilyProperties();
    if (std::none_of(families.begin(), families.end(),
                     [](const auto& f) { return bool(f.queueFlags & vk::QueueFlagBits::eCompute); }))
        info.problems.push_back("no compute queue");
    if (!device.getFeatures().shaderInt64) info.problems.push_back("no shaderInt64 (the exact rasteriser needs 64-bit integers)");
    if (info.max_storage_buffer_range < (1u << 24))
        info.problems.push_back(fmt::format("maxStorageBufferRange {} < 16 MiB", info.max_storage_buffer_range));
    return info;
}

}  // namespace

bool validation_requested_by_environment() {
    const char* value = std::getenv("AMHV_VALIDATION");
    return value && std::string(value) == "1";
}

// Lavapipe (Mesa's CPU driver) runs a dispatch on LP_NUM_THREADS threads, one per core by default,
// each taking a fixed share of its workgroups: a core whose share ends early waits for the other.
// With two threads per core, it takes another thread's instead (measured on the 2-core VM: a 10 mm
// voxelisation about 1 ms faster in 41, the paper scene about 2 s in 35). Set before the driver
// reads it, at enumeration; a value the user set stays, and other drivers ignore it.
static void ask_lavapipe_for_two_threads_per_core() {
    setenv("LP_NUM_THREADS", std::to_string(2 * core_count()).c_str(), /*overwrite=*/0);
}

Context::Context(ContextOptions options) : log_(std::make_unique<ValidationLog>()) {
    ask_lavapipe_for_two_threads_per_core();
    try {
        loader_ = std::make_unique<vk::raii::Context>();
    } catch (const std::exception&) {
        throw Error(fmt::format("no Vulkan loader (libvulkan.so.1) found: {}", kInstallHint));
    }

    bool validation = options.validation || validation_requested_by_environment();
    log_->echo = validation_requested_by_environment();
    std::vector<const char*> layers;
    std::vector<const char*> extensions;
    if (validation) {
        auto available = loader_->enumerateInstanceLayerProperties();
        bool found = std::any_of(available.begin(), available.end(),
                                 [](const auto& l) { return std::string(l.layerName.data()) == kValidationLayer; });
        if (!found)
            throw Error("Vulkan validation was requested but VK_LAYER_KHRONOS_validation is not installed: "
                        "`apt install vulkan-validationlayers`");
        layers.push_back(kValidationLayer);
        extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
        extensions.push_back(VK_EXT_VALIDATION_FEATURES_EXTENSION_NAME);
    }

    vk::ApplicationInfo app{.pApplicationName = "amhv", .applicationVersion = 1, .pEngineName = "amhv",
                            .engineVersion = 1, .apiVersion = VK_API_VERSION_1_2};
    vk::DebugUtilsMessengerCreateInfoEXT messenger_info{
        .messageSeverity = vk::DebugUtilsMessageSeverityFlagBitsEXT::eWarning | vk::DebugUtilsMessageSeverityFlagBitsEXT::eError,
        .messageType = vk::DebugUtilsMessageTypeFlagBitsEXT::eGeneral | vk::DebugUtilsMessageTypeFlagBitsEXT::eValidation |
                       vk::DebugUtilsMessageTypeFlagBitsEXT::ePerformance,
        .pfnUserCallback = on_validation_message,
        .pUserData = log_.get()};
    // Synchronisation validation too: a missing barrier is a race on a real GPU even where lavapipe
    // happens to run the work in order.
    const vk::ValidationFeatureEnableEXT enabled_features[] = {vk::ValidationFeatureEnableEXT::eSynchronizationValidation};
    vk::ValidationFeaturesEXT validation_features{.pNext = &messenger_info, .enabledValidationFeatureCount = 1, .pEnabledValidationFeatures = enabled_features};
    vk::InstanceCreateInfo instance_info{.pNext = validation ? static_cast<const void*>(&validation_features) : nullptr,
                                         .pApplicationInfo = &app,
                                         .enabledLayerCount = std::uint32_t(layers.size()),
                                         .ppEnabledLayerNames = layers.data(),
                                         .enabledExtensionCount = std::uint32_t(extensions.size()),
                                         .ppEnabledExtensionNames = extensions.data()};
    try {
        instance_ = std::make_unique<vk::raii::Instance>(*loader_, instance_info);
    } catch (const vk::SystemError& e) {
        throw Error(fmt::format("cannot create a Vulkan instance ({}): {}", e.what(), kInstallHint));
    }
    if (validation) messenger_ = std::make_unique<vk::raii::DebugUtilsMessengerEXT>(*instance_, messenger_info);

    vk::raii::PhysicalDevices physical_devices = enumerate_devices(*instance_);
    if (physical_devices.empty()) throw Error(fmt::format("no Vulkan device found: {}", kInstallHint));
    for (std::uint32_t i = 0; i < physical_devices.size(); ++i) devices_.push_back(describe(physical_devices[i], i));

    if (options.device_index) {
        if (*options.device_index >= devices_.size())
            throw Error(fmt::format("--device {}: there are only {} Vulkan devices (see `amhv devices`)", *options.device_index,
                                    devices_.size()));
        const auto& chosen = devices_[*options.device_index];
        if (!chosen.usable())
            throw Error(fmt::format("--device {}: {} cannot be used: {}", chosen.index, chosen.name, fmt::join(chosen.problems, "; ")));
        selected_ = chosen.index;
    } else {
        std::optional<std::size_t> best;
        for (std::size_t i = 0; i < devices_.size(); ++i)
            if (devices_[i].usable() && (!best || devices_[i].preference < devices_[*best].preference)) best = i;
        if (!best) {
            std::vector<std::string> reasons;
            for (const auto& d : devices_) reasons.push_back(fmt::format("{}: {}", d.name, fmt::join(d.problems, "; ")));
            throw Error(fmt::format("no usable Vulkan device ({}); {}", fmt::join(reasons, " | "), kInstallHint));
        }
        selected_ = *best;
    }

    physical_device_ = std::make_unique<vk::raii::PhysicalDevice>(std::move(physical_devices[selected_]));
    auto families = physical_device_->getQueueFamilyProperties();
    for (std::uint32_t i = 0; i < families.size(); ++i)
        if (families[i].queueFlags & vk::QueueFlagBits::eCompute) {
            queue_family_ = i;
            break;
        }
    float priority = 1.0f;
    vk::DeviceQueueCreateInfo queue_info{.queueFamilyIndex = queue_family_, .queueCount = 1, .pQueuePriorities = &priority};
    vk::PhysicalDeviceFeatures features{.shaderInt64 = VK_TRUE};
    std::vector<const char*> device_extensions;
    if (selected().host_import_alignment) device_extensions.push_back(VK_EXT_EXTERNAL_MEMORY_HOST_EXTENSION_NAME);
    vk::DeviceCreateInfo device_info{.queueCreateInfoCount = 1,
                                     .pQueueCreateInfos = &queue_info,
                                     .enabledExtensionCount = std::uint32_t(device_extensions.size()),
                                     .ppEnabledExtensionNames = device_extensions.data(),
                                     .pEnabledFeatures = &features};
    device_ = std::make_unique<vk::raii::Device>(*physical_device_, device_info);
    queue_ = std::make_unique<vk::raii::Queue>(*device_, queue_family_, 0);
    memory_properties_ = physical_device_->getMemoryProperties();
    staged_transfers_ = options.staged_transfers || selected().type == "discrete";
}

Context::~Context() = default;

std::uint32_t Context::memory_type(std::uint32_t type_bits, vk::MemoryPropertyFlags required,
                                   vk::MemoryPropertyFlags preferred) const {
    std::optional<std::uint32_t> fallback;
    for (std::uint32_t i = 0; i < memory_properties_.memoryTypeCount; ++i) {
        if (!(type_bits & (1u << i))) continue;
        auto flags = memory_properties_.memoryTypes[i].propertyFlags;
        if ((flags & required) != required) continue;
        if ((flags & preferred) == preferred) return i;
        if (!fallback) fallback = i;
    }
    if (!fallback) throw Error(fmt::format("{}: no Vulkan memory type with the required properties", selected().name));
    return *fallback;
}

std::size_t Context::validation_message_count() const {
    std::lock_guard lock(log_->mutex);
    return log_->messages.size();
}

std::vector<std::string> Context::validation_messages() const {
    std::lock_guard lock(log_->mutex);
    return log_->messages;
}

}  // namespace amhv::gpu
