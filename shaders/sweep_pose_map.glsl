// The sweep's pull mapping; mirrors src/sweep/pose_map.hpp line for line (integer arithmetic only,
// so the GPU and the CPU reference map every column to the same source column).
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

const int POSITION_BITS = 12;
const int TRIG_BITS = 24;

// trig = (cos_q, sin_q); roots in fixed point (1/2^POSITION_BITS voxel).
i64vec2 source_column(int64_t gx, int64_t gy, i64vec2 trig, i64vec2 root_a, i64vec2 root_b) {
    const int64_t half_voxel = int64_t(1) << (POSITION_BITS - 1);
    int64_t dx = gx * (int64_t(1) << POSITION_BITS) + half_voxel - root_a.x;
    int64_t dy = gy * (int64_t(1) << POSITION_BITS) + half_voxel - root_a.y;
    int64_t px = trig.x * dx + trig.y * dy + root_b.x * (int64_t(1) << TRIG_BITS);
    int64_t py = -trig.y * dx + trig.x * dy + root_b.y * (int64_t(1) << TRIG_BITS);
    // Arithmetic shift: floor division for negative values too (GLSL sign-extends signed >>).
    return i64vec2(px >> (POSITION_BITS + TRIG_BITS), py >> (POSITION_BITS + TRIG_BITS));
}
