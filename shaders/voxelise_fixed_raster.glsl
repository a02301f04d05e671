// Exact fixed-point crossing test shared by the voxelisation kernels.
// It mirrors src/voxelise/fixed_raster.hpp line for line: vertex coordinates are integers in units of
// 1/SUBVOXEL of a voxel, so every decision below is integer arithmetic and the GPU and the CPU
// reference agree bit for bit (no float rounding, no FMA contraction).
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

const int64_t SUBVOXEL = 64;

int64_t edge_function(ivec2 a, ivec2 b, ivec2 p) {
    return int64_t(b.x - a.x) * int64_t(p.y - a.y) - int64_t(b.y - a.y) * int64_t(p.x - a.x);
}

// Top-left rule: a sample exactly on an edge belongs to exactly one of the two triangles that share
// it, so a watertight surface is crossed exactly once.
bool is_top_left(ivec2 a, ivec2 b) {
    int dy = b.y - a.y;
    int dx = b.x - a.x;
    return dy < 0 || (dy == 0 && dx < 0);
}

// fixed_raster.hpp's covers(w, a, b) as a 32-bit edge value for the raster's coverage test: it is
// non-negative exactly when covers holds (w > 0, or w == 0 on a top-left edge), and clamped to
// +-2^30 so that steps across a tile keep its sign without overflow.
int coverage_edge(int64_t w, bool top_left) {
    const int64_t limit = int64_t(1) << 30;
    return int(clamp(w, -limit, limit)) - (top_left ? 0 : 1);
}

// floor(n / d) for d > 0 without a 64-bit division (which lavapipe runs lane by lane): a float
// estimate from d's reciprocal (1.0 / float(d)), exact to within one when |n / d| stays below a few
// thousand (a crossing layer always does: it lies within the triangle's z range), then corrected
// with one exact product.
int64_t floor_div_estimated(int64_t n, int64_t d, float reciprocal) {
    int64_t q = int64_t(floor(float(n) * reciprocal));
    int64_t r = n - q * d;
    if (r < 0) q -= 1;
    else if (r >= d) q += 1;
    return q;
}
