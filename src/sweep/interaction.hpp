#pragma once
// Interaction types of the dictionary (docs/method.md section 5, eq. 4-11).
#include <string>

namespace amhv {

enum class SurfaceLabel { Plus, Minus, Lateral };

struct InteractionType {
    SurfaceLabel a = SurfaceLabel::Lateral;  // A's label
    SurfaceLabel b = SurfaceLabel::Lateral;  // B's label
    // Only for 0 & 0: 'a' touch at every frame, 'b' touch at some frame, 'c' never touch with B
    // leaving every contact voxel before A arrives. 0 for the other types.
    char variant = 0;
    // `near` (beyond the paper): 0 & 0 (b) on A's part grown by the key's `within_m`, with the
    // whole bodies as fidelity, so the parts come within that distance at some frame and never
    // overlap. The sweep reads it as 0 & 0 (b); only its name and the scene's rules differ.
    bool near = false;

    bool lateral_pair() const { return a == SurfaceLabel::Lateral && b == SurfaceLabel::Lateral; }
    std::string name() const;  // canonical spelling: "+&-", "0&0a", ...
};

// Accepts "+&-", "+ & -", "0&0a", "0&0 (a)", "0&0-a" and the other label pairs. Throws amhv::Error
// naming `what` and listing the accepted types otherwise.
InteractionType parse_interaction_type(const std::string& text, const std::string& what);

}  // namespace amhv
