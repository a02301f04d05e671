#pragma once
// Linear blend skinning of a character's frames (docs/method.md section 9, "Skinning"), the one
// definition both backends follow: the plain CPU reference here and skin.comp on Vulkan
// (src/body/skin_vulkan.hpp). Both compute in 32-bit floats, every operation in the same order and
// none fused, so their positions are equal bit for bit, and so are the quantised points the
// voxeliser reads from them.
//
// The host folds into each frame's palette (one 3x4 matrix per bone, then one per node an unskinned
// mesh rides on) everything that is linear and shared: the bone's global transform times its
// offset, the file's units and axes, the lift, and minus the frame's anchor (the mean of the
// palette's translations). A skinned position is then a float within a body's reach of zero, where
// a float's step is a fraction of a micrometre, and the host adds the anchor back in double.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "src/core/geometry.hpp"
#include "src/io/character_file.hpp"
#include "src/io/mesh_sequence.hpp"

namespace amhv {

// What every frame of a character shares: per vertex its bind position and four (palette entry,
// weight) slots; an unused slot is entry 0 with weight 0 (adding 0 x a finite point changes no
// bit of a finite sum).
struct SkinVertices {
    std::vector<float> rest;          // 4 per vertex: x, y, z (the file's units and axes), 0
    std::vector<std::int32_t> bones;  // 4 per vertex: palette entries
    std::vector<float> weights;       // 4 per vertex
    std::uint32_t palette_size = 0;   // matrices per frame
    std::size_t count() const { return rest.size() / 4; }
};

// One frame's palette: 12 floats per entry (a 3x4 matrix, row by row), and the anchor the skinned
// positions are relative to (scene axes, metres).
struct SkinFrame {
    std::vector<float> palette;
    Vec3 anchor = Vec3::Zero();
};

SkinVertices skin_vertices(const CharacterFile& character);
// Frame `frame` of `character` taken to the scene by `units`; a frame the animation lacks is an
// error naming the file.
SkinFrame skin_frame(const CharacterFile& character, int frame, const UnitsAndAxes& units);

// Vertices first .. first + count - 1 skinned by `palette` into out (3 floats each):
// q = ((m0 x + m1 y) + m2 z) + m3 per row, then p = w0 q0, p = p + w1 q1, ... in slot order.
void skin_reference(const SkinVertices& vertices, std::span<const float> palette, std::size_t first, std::size_t count, float* out);

class Skinner {
public:
    virtual ~Skinner() = default;
    virtual std::string name() const = 0;
    // Every vertex at every frame: out holds frames.size() x vertices.count() x 3 floats, frame by frame.
    virtual void skin(const SkinVertices& vertices, std::span<const SkinFrame> frames, std::vector<float>& out) = 0;
};

// The reference on every core.
class CpuSkinner final : public Skinner {
public:
    std::string name() const override { return "cpu"; }
    void skin(const SkinVertices& vertices, std::span<const SkinFrame> frames, std::vector<float>& out) override;
};

// Frame f's positions of `skinned` (as Skinner::skin writes them) in the scene: anchor added in double.
std::vector<Vec3> skinned_points(std::span<const float> skinned, std::size_t vertices, std::size_t f, const SkinFrame& frame);

// Frames first..last of `character` (whose vertices are `vertices`), taken to the scene by
// `units` and skinned by `skinner` in one call: per frame, every vertex (skinned_points).
std::vector<std::vector<Vec3>> skin_frames(Skinner& skinner, const SkinVertices& vertices, const CharacterFile& character, int first, int last,
                                           const UnitsAndAxes& units);

}  // namespace amhv
