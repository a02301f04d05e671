#include "src/sweep/interaction.hpp"

#include <algorithm>
#include <cctype>

#include "src/core/error.hpp"

namespace amhv {

namespace {

char symbol(SurfaceLabel label) {
    switch (label) {
        case SurfaceLabel::Plus: return '+';
        case SurfaceLabel::Minus: return '-';
        default: return '0';
    }
}

bool parse_label(char c, SurfaceLabel& label) {
    if (c == '+') label = SurfaceLabel::Plus;
    else if (c == '-') label = SurfaceLabel::Minus;
    else if (c == '0') label = SurfaceLabel::Lateral;
    else return false;
    return true;
}

}  // namespace

std::string InteractionType::name() const {
    if (near) return "near";
    std::string text{symbol(a), '&', symbol(b)};
    if (variant) text += variant;
    return text;
}

InteractionType parse_interaction_type(const std::string& text, const std::string& what) {
    std::string compact;
    for (char c : text)
        if (!std::isspace(static_cast<unsigned char>(c)) && c != '(' && c != ')') compact += char(std::tolower(static_cast<unsigned char>(c)));
    // "0&0-a" and "0&0_a" spell the variant with a separator.
    if (compact.size() == 5 && (compact[3] == '-' || compact[3] == '_')) compact.erase(3, 1);
    InteractionType type;
    if (compact == "near") {
        type.variant = 'b';
        type.near = true;
        return type;
    }
    bool ok = compact.size() >= 3 && compact[1] == '&' && parse_label(compact[0], type.a) && parse_label(compact[2], type.b);
    if (ok && type.lateral_pair()) {
        ok = compact.size() == 4 && std::string("abc").find(compact[3]) != std::string::npos;
        if (ok) type.variant = compact[3];
    } else if (ok) {
        ok = compact.size() == 3;
    }
    if (!ok)
        fail(what, "unknown interaction type '{}'; the dictionary has +&-, -&+, +&+, -&-, +&0, 0&+, -&0, 0&-, 0&0a, 0&0b, 0&0c, and near (beyond the paper)", text);
    return type;
}

}  // namespace amhv
