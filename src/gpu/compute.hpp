#pragma once
// The other nouns of the Vulkan runtime: Buffer (storage memory), Kernel (a compute pipeline from
// embedded SPIR-V, specialised at creation) and Sequence (a recorded batch of fills, dispatches
// and barriers submitted at once).
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "gpu/context.hpp"

namespace amhv::gpu {

class Buffer {
public:
    enum class Memory {
        Device,  // GPU-only scratch: device-local memory
        Host,    // read or written by the host: host-visible, coherent, cached where possible
    };
    Buffer(Context& context, vk::DeviceSize size, Memory memory);

    vk::Buffer handle() const { return *buffer_; }
    vk::DeviceSize size() const { return size_; }
    Memory memory() const { return kind_; }
    // Host buffers only.
    template <typename T>
    std::span<T> mapped() {
        return {static_cast<T*>(mapped_), std::size_t(size_ / sizeof(T))};
    }

private:
    vk::DeviceSize size_;
    vk::raii::Buffer buffer_;
    vk::raii::DeviceMemory memory_;
    void* mapped_ = nullptr;
    Memory kind_;
};

// Grows a buffer to at least `bytes` of `memory` (never shrinks, so batches and calls reuse it;
// its contents are not kept when it grows).
void ensure_capacity(Context& context, std::unique_ptr<Buffer>& buffer, vk::DeviceSize bytes, Buffer::Memory memory);
// The same for a host buffer.
void ensure_host_capacity(Context& context, std::unique_ptr<Buffer>& buffer, vk::DeviceSize bytes);
// A new host buffer holding a copy of `bytes` bytes at `data`.
std::unique_ptr<Buffer> upload_to_host(Context& context, const void* data, std::size_t bytes);

class Kernel {
public:
    // `buffer_count` storage buffers at bindings 0..n-1 of set 0; specialisation constant i is
    // `specialisation[i]` (constant 0 is the workgroup size by convention of our shaders).
    Kernel(Context& context, std::span<const std::uint32_t> spirv, std::uint32_t buffer_count,
           std::uint32_t push_constant_bytes, std::vector<std::uint32_t> specialisation);

    std::uint32_t workgroup_size() const { return specialisation_.at(0); }
    vk::raii::DescriptorSet bind(const std::vector<const Buffer*>& buffers);

private:
    friend class Sequence;
    Context& context_;
    std::vector<std::uint32_t> specialisation_;
    std::uint32_t push_constant_bytes_;
    vk::raii::DescriptorSetLayout set_layout_;
    vk::raii::PipelineLayout pipeline_layout_;
    vk::raii::DescriptorPool pool_;
    vk::raii::Pipeline pipeline_;
};

class Sequence {
public:
    explicit Sequence(Context& context);

    // Fills the first `bytes` of `buffer` with the 32-bit `pattern`.
    void fill(const Buffer& buffer, vk::DeviceSize bytes, std::uint32_t pattern);
    // Dispatches `invocations` invocations in as many dispatches as the device's group-count limit
    // needs. `push` must start with two uint32 (base, count), which this fills in per dispatch.
    template <typename Push>
    void dispatch(Kernel& kernel, const vk::raii::DescriptorSet& set, Push push, std::uint32_t invocations) {
        static_assert(sizeof(Push) >= 8 && sizeof(Push) % 4 == 0);
        dispatch_raw(kernel, set, &push, sizeof(Push), invocations);
    }
    // Makes everything written so far (fills, shader writes) visible to later shaders and transfers.
    void barrier();
    // Makes shader writes visible to the host after submit_and_wait.
    void barrier_to_host();
    void submit_and_wait();

private:
    void dispatch_raw(Kernel& kernel, const vk::raii::DescriptorSet& set, void* push, std::uint32_t bytes,
                      std::uint32_t invocations);
    Context& context_;
    vk::raii::CommandPool pool_;
    vk::raii::CommandBuffer commands_;
    vk::raii::Fence fence_;
};

}  // namespace amhv::gpu
