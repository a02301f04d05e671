#pragma once
// The other nouns of the Vulkan runtime: Buffer (storage memory), Kernel (a compute pipeline from
// embedded SPIR-V, specialised at creation) and Sequence (a recorded batch of fills, dispatches
// and barriers submitted at once).
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "src/gpu/context.hpp"

namespace amhv::gpu {

class Buffer {
public:
    enum class Memory {
        Device,  // GPU-only scratch: device-local memory
        Host,    // read or written by the host: host-visible, coherent, cached where possible
    };
    Buffer(Context& context, vk::DeviceSize size, Memory memory);
    // A buffer over `size` bytes of host memory at `pointer` (VK_EXT_external_memory_host; both
    // aligned to the device's host_import_alignment). The memory stays the caller's and must
    // outlive the buffer.
    static std::unique_ptr<Buffer> import_host(Context& context, void* pointer, vk::DeviceSize size);

    vk::Buffer handle() const { return *buffer_; }
    vk::DeviceSize size() const { return size_; }
    Memory memory() const { return kind_; }
    // Host buffers only.
    template <typename T>
    std::span<T> mapped() {
        return {static_cast<T*>(mapped_), std::size_t(size_ / sizeof(T))};
    }

private:
    Buffer(vk::DeviceSize size, vk::raii::Buffer buffer, vk::raii::DeviceMemory memory, void* mapped);
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
// A copy of `bytes` bytes at `data` for kernels to read: with staged transfers, device-local memory
// filled through a bounded host staging buffer (and ready for any later submit); else host memory.
std::unique_ptr<Buffer> upload_for_kernels(Context& context, const void* data, std::size_t bytes);

// How a shader sees one binding. Texel views read through the sampler path: on lavapipe a
// storage-buffer access runs lane by lane, a texel fetch gathers all lanes at once.
enum class Binding {
    Storage,    // layout(std430) buffer
    Texels32,   // uniform usamplerBuffer: one uint per texel
    Texels64,   // uniform usamplerBuffer: one uvec2 per texel (in .xy)
    Texels128,  // uniform isamplerBuffer: one ivec4 per texel
};

// A kernel's buffers bound for dispatches: the descriptor set and the texel views it refers to.
struct BoundBuffers {
    vk::raii::DescriptorSet set;
    std::vector<vk::raii::BufferView> views;
};

class Kernel {
public:
    // `buffer_count` storage buffers at bindings 0..n-1 of set 0; specialisation constant i is
    // `specialisation[i]` (constant 0 is the workgroup size by convention of our shaders).
    Kernel(Context& context, std::span<const std::uint32_t> spirv, std::uint32_t buffer_count,
           std::uint32_t push_constant_bytes, std::vector<std::uint32_t> specialisation);
    // Binding i of set 0 is `bindings[i]`.
    Kernel(Context& context, std::span<const std::uint32_t> spirv, std::vector<Binding> bindings,
           std::uint32_t push_constant_bytes, std::vector<std::uint32_t> specialisation);

    std::uint32_t workgroup_size() const { return specialisation_.at(0); }
    // Buffer i goes to binding i; a buffer may appear at several bindings (as storage and as texels).
    BoundBuffers bind(const std::vector<const Buffer*>& buffers);

private:
    friend class Sequence;
    Context& context_;
    std::vector<Binding> bindings_;
    std::vector<std::uint32_t> specialisation_;
    std::uint32_t push_constant_bytes_;
    vk::raii::DescriptorSetLayout set_layout_;
    vk::raii::PipelineLayout pipeline_layout_;
    vk::raii::DescriptorPool pool_;
    vk::raii::Pipeline pipeline_;
};

// What a Kernel is built from, so that several can be built at once (make_kernels).
struct KernelSpec {
    std::span<const std::uint32_t> spirv;
    std::vector<Binding> bindings;
    std::uint32_t push_constant_bytes;
    std::vector<std::uint32_t> specialisation;
};

// Builds `specs` on all cores, in their order. lavapipe compiles a pipeline with LLVM on the
// calling thread: the voxeliser's six took 0.2 s on one core, a serial step of every command.
std::vector<Kernel> make_kernels(Context& context, const std::vector<KernelSpec>& specs);

class Sequence;

// A buffer that the host and kernels both use. With staged transfers it is a device-local buffer
// and its host mirror, moved by copies recorded in a sequence; else one host buffer, and the copies
// are nothing.
class MirroredBuffer {
public:
    // Grows to at least `bytes` (its contents are not kept when it grows).
    void ensure(Context& context, vk::DeviceSize bytes);
    // What the kernels bind and the sequence fills.
    const Buffer& device() const { return staged_ ? *device_ : *host_; }
    // What the host writes before copy_to_device and reads after copy_to_host.
    template <typename T>
    std::span<T> host() const {
        return host_->mapped<T>();
    }
    // Records the move of the first `bytes` the host wrote to the device, before the kernels that
    // read them.
    void copy_to_device(Sequence& sequence, vk::DeviceSize bytes) const;
    // Records the move of the first `bytes` the kernels wrote to the host; the host reads them after
    // the sequence's barrier_to_host and submit.
    void copy_to_host(Sequence& sequence, vk::DeviceSize bytes) const;

private:
    bool staged_ = false;
    std::unique_ptr<Buffer> device_, host_;
};

class Sequence {
public:
    explicit Sequence(Context& context);

    // Fills the first `bytes` of `buffer` with the 32-bit `pattern`.
    void fill(const Buffer& buffer, vk::DeviceSize bytes, std::uint32_t pattern);
    // Copies `bytes` from `from` at `from_offset` to `to` at `to_offset`.
    void copy(const Buffer& from, vk::DeviceSize from_offset, const Buffer& to, vk::DeviceSize to_offset, vk::DeviceSize bytes);
    // Dispatches `invocations` invocations in as many dispatches as the device's group-count limit
    // needs. `push` must start with two uint32 (base, count), which this fills in per dispatch.
    template <typename Push>
    void dispatch(Kernel& kernel, const BoundBuffers& set, Push push, std::uint32_t invocations) {
        static_assert(sizeof(Push) >= 8 && sizeof(Push) % 4 == 0);
        dispatch_raw(kernel, set, &push, sizeof(Push), invocations);
    }
    // Dispatches as many workgroups as the uint32 at `offset` in `args` says (followed by the y
    // and z counts, 1 and 1), a count a shader wrote. `push` as for dispatch, base and count 0.
    template <typename Push>
    void dispatch_indirect(Kernel& kernel, const BoundBuffers& set, Push push, const Buffer& args, vk::DeviceSize offset) {
        static_assert(sizeof(Push) >= 8 && sizeof(Push) % 4 == 0);
        dispatch_indirect_raw(kernel, set, &push, sizeof(Push), args, offset);
    }
    // Makes everything written so far (fills, shader writes) visible to later shaders, transfers
    // and indirect dispatches.
    void barrier();
    // Makes shader writes visible to the host after submit_and_wait.
    void barrier_to_host();
    void submit_and_wait();

private:
    // Binds the kernel's pipeline, its buffers and the push constants for the dispatches that follow.
    void use(Kernel& kernel, const BoundBuffers& set, const void* push, std::uint32_t bytes);
    void dispatch_indirect_raw(Kernel& kernel, const BoundBuffers& set, void* push, std::uint32_t bytes, const Buffer& args,
                               vk::DeviceSize offset);
    void dispatch_raw(Kernel& kernel, const BoundBuffers& set, void* push, std::uint32_t bytes,
                      std::uint32_t invocations);
    Context& context_;
    vk::raii::CommandPool pool_;
    vk::raii::CommandBuffer commands_;
    vk::raii::Fence fence_;
};

}  // namespace amhv::gpu
