#pragma once
// The Vulkan runtime's first noun: one instance, the chosen physical device, its compute queue.
// Device selection prefers discrete > integrated > virtual > CPU (lavapipe) and says why a device
// was rejected. Validation layers go on when asked (tests always ask); every message they emit is
// counted so a test can fail on it.
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <vulkan/vulkan_raii.hpp>

namespace amhv::gpu {

struct DeviceInfo {
    std::uint32_t index = 0;
    std::string name;
    std::string type;    // discrete, integrated, virtual, cpu, other
    std::string driver;  // driver name and info
    std::string api_version;
    vk::DeviceSize max_storage_buffer_range = 0;
    std::uint32_t max_texel_buffer_elements = 0;
    vk::DeviceSize max_allocation_size = 0;
    std::array<std::uint32_t, 3> max_workgroup_size{};
    std::uint32_t max_workgroup_invocations = 0;
    std::uint32_t max_workgroup_count_x = 0;
    std::uint32_t shared_memory_bytes = 0;
    std::uint32_t subgroup_size = 0;
    std::uint64_t device_local_bytes = 0;
    // VK_EXT_external_memory_host: host memory can back a buffer (0: not supported), with this
    // alignment of pointer and size.
    vk::DeviceSize host_import_alignment = 0;
    std::vector<std::string> problems;  // why it cannot be used; empty = usable
    int preference = 0;                 // lower is preferred

    bool usable() const { return problems.empty(); }
    // The device works in host memory (a CPU driver such as lavapipe, or an integrated GPU) and can
    // import it: a kernel may write straight into the host's own arrays.
    bool shares_host_memory() const { return host_import_alignment > 0 && (type == "cpu" || type == "integrated"); }
};

struct ContextOptions {
    std::optional<std::uint32_t> device_index;
    bool validation = false;
    // Lay the kernels' buffers out as for a GPU with memory of its own (device-local, moved by
    // transfers) whatever the device: the tests run the discrete-GPU path on lavapipe.
    bool staged_transfers = false;
};

// True when AMHV_VALIDATION=1 is set: the CLI then turns validation layers on too.
bool validation_requested_by_environment();

class Context {
public:
    explicit Context(ContextOptions options = {});
    ~Context();
    Context(const Context&) = delete;
    Context& operator=(const Context&) = delete;

    const std::vector<DeviceInfo>& devices() const { return devices_; }
    const DeviceInfo& selected() const { return devices_[selected_]; }
    // Kernel inputs and results live in device-local memory and move by transfers (a discrete GPU,
    // whose shaders would read host memory across the bus, or when asked); otherwise kernels read
    // and write host memory in place.
    bool staged_transfers() const { return staged_transfers_; }

    vk::raii::Device& device() { return *device_; }
    vk::raii::PhysicalDevice& physical_device() { return *physical_device_; }
    vk::raii::Queue& queue() { return *queue_; }
    std::uint32_t queue_family() const { return queue_family_; }

    // Index of a memory type allowed by `type_bits` with all `required` flags, preferring `preferred`.
    std::uint32_t memory_type(std::uint32_t type_bits, vk::MemoryPropertyFlags required,
                              vk::MemoryPropertyFlags preferred) const;

    std::size_t validation_message_count() const;
    std::vector<std::string> validation_messages() const;

    struct ValidationLog;  // shared with the debug callback

private:
    // Declared first so it outlives the messenger, which may report while the device goes away.
    std::unique_ptr<ValidationLog> log_;
    std::unique_ptr<vk::raii::Context> loader_;
    std::unique_ptr<vk::raii::Instance> instance_;
    std::unique_ptr<vk::raii::DebugUtilsMessengerEXT> messenger_;
    std::unique_ptr<vk::raii::PhysicalDevice> physical_device_;
    std::unique_ptr<vk::raii::Device> device_;
    std::unique_ptr<vk::raii::Queue> queue_;
    std::uint32_t queue_family_ = 0;
    std::vector<DeviceInfo> devices_;
    std::size_t selected_ = 0;
    bool staged_transfers_ = false;
    vk::PhysicalDeviceMemoryProperties memory_properties_;
};

}  // namespace amhv::gpu
