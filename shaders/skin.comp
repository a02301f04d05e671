#version 450
// Linear blend skinning of a batch of a character's frames (src/body/skinning.hpp, whose
// skin_reference is the CPU reference this equals bit for bit). Invocation i skins vertex
// i % vertex_count at frame i / vertex_count of the batch: four (palette entry, weight) slots, each
// q = ((m0 x + m1 y) + m2 z) + m3 per row, summed p = w0 q0, p = p + w1 q1, ... in slot order.
// Every operation is `precise` (no fused multiply-add), and a float's add and multiply are
// correctly rounded in Vulkan, so the CPU's floats in the same order give the same bits.
// Work per invocation: four slots, no loop that grows with the input.
layout(local_size_x_id = 0) in;

// Read-only inputs as texels (on lavapipe a texel fetch gathers all lanes at once). Per vertex
// three texels: x, y, z, 0 (float bits); four palette entries; four weights (float bits).
layout(set = 0, binding = 0) uniform isamplerBuffer vertices;
// Per frame of the batch, palette_size entries of three texels: a 3x4 matrix's rows (float bits).
layout(set = 0, binding = 1) uniform isamplerBuffer palettes;
layout(std430, set = 0, binding = 2) writeonly buffer Positions { float positions[]; };

layout(push_constant) uniform Params {
    uint base;
    uint count;
    uint vertex_count;
    uint palette_size;
};

void main() {
    const uint i = base + gl_GlobalInvocationID.x;
    if (gl_GlobalInvocationID.x >= count) return;
    const uint v = i % vertex_count, frame = i / vertex_count;
    const vec4 rest = intBitsToFloat(texelFetch(vertices, int(3 * v)));
    const ivec4 bones = texelFetch(vertices, int(3 * v + 1));
    const vec4 weights = intBitsToFloat(texelFetch(vertices, int(3 * v + 2)));
    precise vec3 p = vec3(0.0);
    for (int k = 0; k < 4; ++k) {
        const int entry = int(3 * (frame * palette_size + uint(bones[k])));
        precise vec3 q;
        for (int r = 0; r < 3; ++r) {
            const vec4 m = intBitsToFloat(texelFetch(palettes, entry + r));
            precise float row = ((m.x * rest.x + m.y * rest.y) + m.z * rest.z) + m.w;
            q[r] = row;
        }
        precise vec3 term = weights[k] * q;
        p = k == 0 ? term : p + term;
    }
    positions[3 * v + 3 * vertex_count * frame] = p.x;
    positions[3 * v + 3 * vertex_count * frame + 1] = p.y;
    positions[3 * v + 3 * vertex_count * frame + 2] = p.z;
}
