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

    bool lateral_pair() const { return a == SurfaceLabel::Lateral && b == SurfaceLabel::Lateral; }
    std::string name() const;  // canonical spelling: "+&-", "0&0a", ...
};

// Accepts "+&-", "+ & -", "0&0a", "0&0 (a)", "0&0-a" and the other label pairs. Throws amhv::Error
// naming `what` and listing the accepted types otherwise.
InteractionType parse_interaction_type(const std::string& text, const std::string& what);

}  // namespace amhv
