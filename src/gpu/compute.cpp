#include "src/gpu/compute.hpp"

#include <algorithm>
#include <cstring>
#include <optional>

#include "src/core/error.hpp"
#include "src/core/parallel.hpp"

namespace amhv::gpu {

namespace {

vk::raii::Buffer make_buffer(Context& context, vk::DeviceSize size) {
    return vk::raii::Buffer(context.device(), vk::BufferCreateInfo{
        .size = size,
        .usage = vk::BufferUsageFlagBits::eStorageBuffer | vk::BufferUsageFlagBits::eUniformTexelBuffer |
                 vk::BufferUsageFlagBits::eIndirectBuffer | vk::BufferUsageFlagBits::eTransferSrc |
                 vk::BufferUsageFlagBits::eTransferDst,
        .sharingMode = vk::SharingMode::eExclusive});
}

vk::raii::DeviceMemory allocate(Context& context, const vk::raii::Buffer& buffer, Buffer::Memory memory) {
    auto requirements = buffer.getMemoryRequirements();
    using F = vk::MemoryPropertyFlagBits;
    std::uint32_t type = memory == Buffer::Memory::Device
        ? context.memory_type(requirements.memoryTypeBits, F::eDeviceLocal, F::eDeviceLocal)
        : context.memory_type(requirements.memoryTypeBits, F::eHostVisible | F::eHostCoherent, F::eHostCached);
    try {
        return vk::raii::DeviceMemory(context.device(), vk::MemoryAllocateInfo{.allocationSize = requirements.size,
                                                                             .memoryTypeIndex = type});
    } catch (const vk::SystemError& e) {
        throw Error(fmt::format("{}: cannot allocate {:.1f} MiB of GPU memory ({})", context.selected().name,
                                double(requirements.size) / (1 << 20), e.what()));
    }
}

}  // namespace

Buffer::Buffer(Context& context, vk::DeviceSize size, Memory memory)
    : size_(std::max<vk::DeviceSize>(size, 4)),
      buffer_(make_buffer(context, size_)),
      memory_(allocate(context, buffer_, memory)),
      kind_(memory) {
    buffer_.bindMemory(*memory_, 0);
    if (memory == Memory::Host) mapped_ = memory_.mapMemory(0, size_);
}

Buffer::Buffer(vk::DeviceSize size, vk::raii::Buffer buffer, vk::raii::DeviceMemory memory, void* mapped)
    : size_(size), buffer_(std::move(buffer)), memory_(std::move(memory)), mapped_(mapped), kind_(Memory::Host) {}

std::unique_ptr<Buffer> Buffer::import_host(Context& context, void* pointer, vk::DeviceSize size) {
    constexpr auto kHandle = vk::ExternalMemoryHandleTypeFlagBits::eHostAllocationEXT;
    vk::ExternalMemoryBufferCreateInfo external{.handleTypes = kHandle};
    vk::raii::Buffer buffer(context.device(), vk::BufferCreateInfo{
                                                  .pNext = &external,
                                                  .size = size,
                                                  .usage = vk::BufferUsageFlagBits::eStorageBuffer | vk::BufferUsageFlagBits::eTransferDst,
                                                  .sharingMode = vk::SharingMode::eExclusive});
    const auto host = context.device().getMemoryHostPointerPropertiesEXT(kHandle, pointer);
    const auto requirements = buffer.getMemoryRequirements();
    using F = vk::MemoryPropertyFlagBits;
    const std::uint32_t type = context.memory_type(requirements.memoryTypeBits & host.memoryTypeBits,
                                                   F::eHostVisible | F::eHostCoherent, F::eHostCached);
    vk::ImportMemoryHostPointerInfoEXT import{.handleType = kHandle, .pHostPointer = pointer};
    vk::raii::DeviceMemory memory(context.device(), vk::MemoryAllocateInfo{.pNext = &import, .allocationSize = size, .memoryTypeIndex = type});
    buffer.bindMemory(*memory, 0);
    return std::unique_ptr<Buffer>(new Buffer(size, std::move(buffer), std::move(memory), pointer));
}

void ensure_capacity(Context& context, std::unique_ptr<Buffer>& buffer, vk::DeviceSize bytes, Buffer::Memory memory) {
    if (!buffer || buffer->size() < bytes || buffer->memory() != memory) {
        buffer.reset();  // the old memory goes back before the new is allocated
        buffer = std::make_unique<Buffer>(context, std::max<vk::DeviceSize>(bytes, 4096), memory);
    }
}

void ensure_host_capacity(Context& context, std::unique_ptr<Buffer>& buffer, vk::DeviceSize bytes) {
    ensure_capacity(context, buffer, bytes, Buffer::Memory::Host);
}

std::unique_ptr<Buffer> upload_to_host(Context& context, const void* data, std::size_t bytes) {
    auto buffer = std::make_unique<Buffer>(context, std::max<vk::DeviceSize>(bytes, 16), Buffer::Memory::Host);
    if (bytes) std::memcpy(buffer->mapped<std::uint8_t>().data(), data, bytes);
    return buffer;
}

std::unique_ptr<Buffer> upload_for_kernels(Context& context, const void* data, std::size_t bytes) {
    if (!context.staged_transfers()) return upload_to_host(context, data, bytes);
    // A bounded staging buffer, so that uploading a volume does not hold it twice in host memory.
    constexpr std::size_t kStagingBytes = std::size_t(64) << 20;
    auto buffer = std::make_unique<Buffer>(context, std::max<vk::DeviceSize>(bytes, 16), Buffer::Memory::Device);
    if (bytes == 0) return buffer;
    Buffer staging(context, std::min(bytes, kStagingBytes), Buffer::Memory::Host);
    Sequence sequence(context);
    for (std::size_t done = 0; done < bytes; done += kStagingBytes) {
        const std::size_t part = std::min(kStagingBytes, bytes - done);
        std::memcpy(staging.mapped<std::uint8_t>().data(), static_cast<const std::uint8_t*>(data) + done, part);
        sequence.copy(staging, 0, *buffer, done, part);
        // Later submits on this queue read it (and the next part reuses the staging buffer).
        sequence.barrier();
        sequence.submit_and_wait();
    }
    return buffer;
}

void MirroredBuffer::ensure(Context& context, vk::DeviceSize bytes) {
    staged_ = context.staged_transfers();
    if (staged_) ensure_capacity(context, device_, bytes, Buffer::Memory::Device);
    ensure_host_capacity(context, host_, bytes);
}

void MirroredBuffer::copy_to_device(Sequence& sequence, vk::DeviceSize bytes) const {
    if (!staged_ || bytes == 0) return;
    sequence.copy(*host_, 0, *device_, 0, std::min(bytes, device_->size()));
    sequence.barrier();  // the copy lands before the kernels read it
}

void MirroredBuffer::copy_to_host(Sequence& sequence, vk::DeviceSize bytes) const {
    if (!staged_ || bytes == 0) return;
    sequence.barrier();  // the kernels' writes land before the copy reads them
    sequence.copy(*device_, 0, *host_, 0, std::min(bytes, device_->size()));
}

namespace {

vk::DescriptorType descriptor_type(Binding binding) {
    return binding == Binding::Storage ? vk::DescriptorType::eStorageBuffer : vk::DescriptorType::eUniformTexelBuffer;
}

}  // namespace

Kernel::Kernel(Context& context, std::span<const std::uint32_t> spirv, std::uint32_t buffer_count,
               std::uint32_t push_constant_bytes, std::vector<std::uint32_t> specialisation)
    : Kernel(context, spirv, std::vector<Binding>(buffer_count, Binding::Storage), push_constant_bytes, std::move(specialisation)) {}

Kernel::Kernel(Context& context, std::span<const std::uint32_t> spirv, std::vector<Binding> kinds,
               std::uint32_t push_constant_bytes, std::vector<std::uint32_t> specialisation)
    : context_(context),
      bindings_(std::move(kinds)),
      specialisation_(std::move(specialisation)),
      push_constant_bytes_(push_constant_bytes),
      set_layout_(nullptr),
      pipeline_layout_(nullptr),
      pool_(nullptr),
      pipeline_(nullptr) {
    const auto buffer_count = std::uint32_t(bindings_.size());
    std::vector<vk::DescriptorSetLayoutBinding> bindings;
    std::uint32_t storage_count = 0;
    for (std::uint32_t b = 0; b < buffer_count; ++b) {
        bindings.push_back({.binding = b, .descriptorType = descriptor_type(bindings_[b]), .descriptorCount = 1,
                            .stageFlags = vk::ShaderStageFlagBits::eCompute});
        storage_count += bindings_[b] == Binding::Storage ? 1 : 0;
    }
    set_layout_ = vk::raii::DescriptorSetLayout(
        context.device(), vk::DescriptorSetLayoutCreateInfo{.bindingCount = buffer_count, .pBindings = bindings.data()});
    vk::PushConstantRange range{.stageFlags = vk::ShaderStageFlagBits::eCompute, .offset = 0, .size = push_constant_bytes};
    vk::DescriptorSetLayout layouts[] = {*set_layout_};
    pipeline_layout_ = vk::raii::PipelineLayout(
        context.device(), vk::PipelineLayoutCreateInfo{.setLayoutCount = 1, .pSetLayouts = layouts,
                                                       .pushConstantRangeCount = push_constant_bytes ? 1u : 0u,
                                                       .pPushConstantRanges = &range});
    constexpr std::uint32_t kMaxSets = 16;
    std::vector<vk::DescriptorPoolSize> pool_sizes;
    if (storage_count) pool_sizes.push_back({.type = vk::DescriptorType::eStorageBuffer, .descriptorCount = kMaxSets * storage_count});
    if (storage_count < buffer_count)
        pool_sizes.push_back({.type = vk::DescriptorType::eUniformTexelBuffer, .descriptorCount = kMaxSets * (buffer_count - storage_count)});
    pool_ = vk::raii::DescriptorPool(context.device(), vk::DescriptorPoolCreateInfo{
                                                           .flags = vk::DescriptorPoolCreateFlagBits::eFreeDescriptorSet,
                                                           .maxSets = kMaxSets,
                                                           .poolSizeCount = std::uint32_t(pool_sizes.size()),
                                                           .pPoolSizes = pool_sizes.data()});

    vk::raii::ShaderModule module(context.device(),
                                  vk::ShaderModuleCreateInfo{.codeSize = spirv.size_bytes(), .pCode = spirv.data()});
    std::vector<vk::SpecializationMapEntry> entries;
    for (std::uint32_t i = 0; i < specialisation_.size(); ++i)
        entries.push_back({.constantID = i, .offset = i * 4u, .size = 4});
    vk::SpecializationInfo spec{.mapEntryCount = std::uint32_t(entries.size()), .pMapEntries = entries.data(),
                                .dataSize = specialisation_.size() * 4, .pData = specialisation_.data()};
    vk::ComputePipelineCreateInfo info{
        .stage = {.stage = vk::ShaderStageFlagBits::eCompute, .module = *module, .pName = "main", .pSpecializationInfo = &spec},
        .layout = *pipeline_layout_};
    pipeline_ = vk::raii::Pipeline(context.device(), nullptr, info);
}

std::vector<Kernel> make_kernels(Context& context, const std::vector<KernelSpec>& specs) {
    std::vector<std::optional<Kernel>> built(specs.size());
    parallel_for(specs.size(), [&](std::size_t k) {
        const KernelSpec& spec = specs[k];
        built[k].emplace(context, spec.spirv, spec.bindings, spec.push_constant_bytes, spec.specialisation);
    });
    std::vector<Kernel> kernels;
    kernels.reserve(specs.size());
    for (std::optional<Kernel>& kernel : built) kernels.push_back(std::move(*kernel));
    return kernels;
}

BoundBuffers Kernel::bind(const std::vector<const Buffer*>& buffers) {
    if (buffers.size() != bindings_.size())
        throw Error(fmt::format("internal: a kernel with {} bindings was given {} buffers", bindings_.size(), buffers.size()));
    vk::DescriptorSetLayout layouts[] = {*set_layout_};
    vk::raii::DescriptorSets sets(context_.device(),
                                  vk::DescriptorSetAllocateInfo{.descriptorPool = *pool_, .descriptorSetCount = 1, .pSetLayouts = layouts});
    BoundBuffers bound{std::move(sets.front()), {}};
    // Every info and view first, so the writes below can point at them.
    std::vector<vk::DescriptorBufferInfo> infos(buffers.size());
    std::vector<vk::BufferView> view_handles(buffers.size());
    for (std::size_t i = 0; i < buffers.size(); ++i) {
        const Buffer& b = *buffers[i];
        if (bindings_[i] == Binding::Storage) {
            infos[i] = vk::DescriptorBufferInfo{.buffer = b.handle(), .offset = 0, .range = b.size()};
            continue;
        }
        const vk::DeviceSize texel = bindings_[i] == Binding::Texels128 ? 16 : bindings_[i] == Binding::Texels64 ? 8 : 4;
        const vk::Format format = bindings_[i] == Binding::Texels128 ? vk::Format::eR32G32B32A32Sint
                                  : bindings_[i] == Binding::Texels64 ? vk::Format::eR32G32Uint
                                                                      : vk::Format::eR32Uint;
        // Callers keep what a shader reads within the limit (the voxeliser sizes its batches by
        // it); a buffer may be larger than what is read, so the view covers at most the limit.
        const vk::DeviceSize texels = std::min<vk::DeviceSize>(b.size() / texel, context_.selected().max_texel_buffer_elements);
        bound.views.emplace_back(context_.device(), vk::BufferViewCreateInfo{
                                                        .buffer = b.handle(),
                                                        .format = format,
                                                        .offset = 0,
                                                        .range = texels * texel});
        view_handles[i] = *bound.views.back();
    }
    std::vector<vk::WriteDescriptorSet> writes;
    for (std::uint32_t i = 0; i < buffers.size(); ++i) {
        vk::WriteDescriptorSet write{.dstSet = *bound.set, .dstBinding = i, .descriptorCount = 1, .descriptorType = descriptor_type(bindings_[i])};
        if (bindings_[i] == Binding::Storage)
            write.pBufferInfo = &infos[i];
        else
            write.pTexelBufferView = &view_handles[i];
        writes.push_back(write);
    }
    context_.device().updateDescriptorSets(writes, nullptr);
    return bound;
}

Sequence::Sequence(Context& context)
    : context_(context),
      pool_(context.device(), vk::CommandPoolCreateInfo{.flags = vk::CommandPoolCreateFlagBits::eResetCommandBuffer,
                                                        .queueFamilyIndex = context.queue_family()}),
      commands_(std::move(vk::raii::CommandBuffers(context.device(), vk::CommandBufferAllocateInfo{
                                                                         .commandPool = *pool_,
                                                                         .level = vk::CommandBufferLevel::ePrimary,
                                                                         .commandBufferCount = 1})
                              .front())),
      fence_(context.device(), vk::FenceCreateInfo{}) {
    commands_.begin(vk::CommandBufferBeginInfo{.flags = vk::CommandBufferUsageFlagBits::eOneTimeSubmit});
}

void Sequence::fill(const Buffer& buffer, vk::DeviceSize bytes, std::uint32_t pattern) {
    commands_.fillBuffer(buffer.handle(), 0, std::min(bytes, buffer.size()) & ~vk::DeviceSize(3), pattern);
}

void Sequence::copy(const Buffer& from, vk::DeviceSize from_offset, const Buffer& to, vk::DeviceSize to_offset, vk::DeviceSize bytes) {
    commands_.copyBuffer(from.handle(), to.handle(), vk::BufferCopy{.srcOffset = from_offset, .dstOffset = to_offset, .size = bytes});
}

void Sequence::use(Kernel& kernel, const BoundBuffers& set, const void* push, std::uint32_t bytes) {
    commands_.bindPipeline(vk::PipelineBindPoint::eCompute, *kernel.pipeline_);
    commands_.bindDescriptorSets(vk::PipelineBindPoint::eCompute, *kernel.pipeline_layout_, 0, {*set.set}, nullptr);
    commands_.pushConstants<std::uint8_t>(*kernel.pipeline_layout_, vk::ShaderStageFlagBits::eCompute, 0,
                                          std::span(static_cast<const std::uint8_t*>(push), bytes));
}

void Sequence::dispatch_raw(Kernel& kernel, const BoundBuffers& set, void* push, std::uint32_t bytes,
                            std::uint32_t invocations) {
    const std::uint32_t group = kernel.workgroup_size();
    const std::uint32_t max_groups = std::min<std::uint32_t>(context_.selected().max_workgroup_count_x, 65535u);
    const std::uint32_t per_dispatch = max_groups * group;
    auto* words = static_cast<std::uint32_t*>(push);  // words[0] = base, words[1] = count
    const std::uint32_t caller_base = words[0];
    for (std::uint32_t done = 0; done < invocations; done += per_dispatch) {
        std::uint32_t count = std::min(per_dispatch, invocations - done);
        words[0] = caller_base + done;
        words[1] = count;
        use(kernel, set, push, bytes);
        commands_.dispatch((count + group - 1) / group, 1, 1);
    }
}

void Sequence::dispatch_indirect_raw(Kernel& kernel, const BoundBuffers& set, void* push, std::uint32_t bytes, const Buffer& args,
                                     vk::DeviceSize offset) {
    use(kernel, set, push, bytes);
    commands_.dispatchIndirect(args.handle(), offset);
}

void Sequence::barrier() {
    vk::MemoryBarrier memory{.srcAccessMask = vk::AccessFlagBits::eShaderWrite | vk::AccessFlagBits::eTransferWrite,
                             .dstAccessMask = vk::AccessFlagBits::eShaderRead | vk::AccessFlagBits::eShaderWrite |
                                              vk::AccessFlagBits::eTransferRead | vk::AccessFlagBits::eTransferWrite |
                                              vk::AccessFlagBits::eIndirectCommandRead};
    commands_.pipelineBarrier(vk::PipelineStageFlagBits::eComputeShader | vk::PipelineStageFlagBits::eTransfer,
                              vk::PipelineStageFlagBits::eComputeShader | vk::PipelineStageFlagBits::eTransfer |
                                  vk::PipelineStageFlagBits::eDrawIndirect,
                              {}, memory, nullptr, nullptr);
}

void Sequence::barrier_to_host() {
    vk::MemoryBarrier memory{.srcAccessMask = vk::AccessFlagBits::eShaderWrite | vk::AccessFlagBits::eTransferWrite,
                             .dstAccessMask = vk::AccessFlagBits::eHostRead};
    commands_.pipelineBarrier(vk::PipelineStageFlagBits::eComputeShader | vk::PipelineStageFlagBits::eTransfer,
                              vk::PipelineStageFlagBits::eHost, {}, memory, nullptr, nullptr);
}

void Sequence::submit_and_wait() {
    commands_.end();
    vk::CommandBuffer buffers[] = {*commands_};
    context_.queue().submit(vk::SubmitInfo{.commandBufferCount = 1, .pCommandBuffers = buffers}, *fence_);
    auto result = context_.device().waitForFences({*fence_}, VK_TRUE, UINT64_MAX);
    if (result != vk::Result::eSuccess) throw Error(fmt::format("{}: waiting for the GPU failed", context_.selected().name));
    context_.device().resetFences({*fence_});
    commands_.reset();
    commands_.begin(vk::CommandBufferBeginInfo{.flags = vk::CommandBufferUsageFlagBits::eOneTimeSubmit});
}

}  // namespace amhv::gpu
