#include "src/body/skeleton_roles.hpp"

#include <algorithm>
#include <cctype>

#include "src/core/error.hpp"

namespace amhv {

namespace {

std::string lower(std::string s) {
    for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
    return s;
}

bool has(const std::string& name, const char* word) { return lower(name).find(word) != std::string::npos; }

bool is_prop(const std::string& name) { return name.find("Sword") != std::string::npos || name.find("Prop") != std::string::npos; }

// +1 for a left-side name, -1 for a right-side one, 0 when the name does not say: "Left..." and
// "Right...", CMU's "L..."/"R..." before a capital (LHipJoint, RThumb), and a lowercase "l"/"r"
// before a limb word (lhand, rfoot).
int side_of(const std::string& name) {
    const std::string l = lower(name);
    if (l.rfind("left", 0) == 0) return 1;
    if (l.rfind("right", 0) == 0) return -1;
    if (name.size() > 1 && (name[0] == 'L' || name[0] == 'R') && std::isupper(static_cast<unsigned char>(name[1]))) return name[0] == 'L' ? 1 : -1;
    static const char* limb_words[] = {"hand", "foot", "shoulder", "elbow", "wrist", "knee", "hip", "arm", "leg", "toe", "finger", "thumb",
                                       "collar", "clavicle", "upperarm", "forearm", "lowerarm", "upleg", "ankle", "heel"};
    if (l.size() > 1 && (l[0] == 'l' || l[0] == 'r'))
        for (const char* word : limb_words)
            if (l.compare(1, std::string::npos, word) == 0) return l[0] == 'l' ? 1 : -1;
    return 0;
}

class Skeleton {
public:
    explicit Skeleton(const BvhMotion& motion) : motion_(motion), children_(motion.joints.size()) {
        for (std::size_t j = 1; j < motion.joints.size(); ++j)
            if (motion.joints[j].parent >= 0) children_[std::size_t(motion.joints[j].parent)].push_back(int(j));
    }
    const std::string& name(int j) const { return motion_.joints[std::size_t(j)].name; }
    bool end_site(int j) const { return motion_.joints[std::size_t(j)].end_site; }
    int parent(int j) const { return motion_.joints[std::size_t(j)].parent; }
    const std::vector<int>& children(int j) const { return children_[std::size_t(j)]; }
    std::size_t size() const { return motion_.joints.size(); }

    // Joints below j (j included), parents first.
    std::vector<int> subtree(int j) const {
        std::vector<int> out{j};
        for (std::size_t n = 0; n < out.size(); ++n)
            for (int c : children(out[n])) out.push_back(c);
        return out;
    }
    // The joints from `from` down to `to` (both included; `to` below `from`).
    std::vector<int> path(int from, int to) const {
        std::vector<int> out;
        for (int j = to; j >= 0; j = parent(j)) {
            out.push_back(j);
            if (j == from) break;
        }
        std::reverse(out.begin(), out.end());
        return out;
    }
    // The child leading to the largest subtree (the limb's main chain), or -1.
    int main_child(int j) const {
        int best = -1;
        std::size_t most = 0;
        for (int c : children(j))
            if (!end_site(c) && !is_prop(name(c)) && subtree(c).size() > most) best = c, most = subtree(c).size();
        return best;
    }
    // The first joint of j's subtree (parents first) whose name passes `test`, or -1.
    template <typename Test>
    int find_below(int j, const Test& test) const {
        for (int k : subtree(j))
            if (!end_site(k) && !is_prop(name(k)) && test(name(k))) return k;
        return -1;
    }
    int side(int j) const {
        int votes = 0;
        for (int k : subtree(j)) votes += end_site(k) ? 0 : side_of(name(k));
        return votes > 0 ? 1 : votes < 0 ? -1 : 0;
    }
    const std::string& source() const { return motion_.source; }

private:
    const BvhMotion& motion_;
    std::vector<std::vector<int>> children_;
};

bool is_elbow(const std::string& n) { return has(n, "elbow") || has(n, "forearm") || has(n, "lowerarm"); }
bool is_knee(const std::string& n) {
    return has(n, "knee") || has(n, "shin") || has(n, "calf") || has(n, "lowerleg") || (has(n, "leg") && !has(n, "upleg") && !has(n, "upperleg"));
}

[[noreturn]] void missing(const Skeleton& s, const std::string& role, const char* like) {
    fail(s.source(), "no joint plays the role of the {} (a joint named like {}); amhv finds a skeleton's joints by role", role, like);
}

// Spine names by position: the 18/19 vocabulary's LowerBack, Spine, Spine1 for the joints between
// the root and the neck, the neck's Neck, Neck1, ...
void name_spine(const Skeleton& s, const std::vector<int>& spine, std::vector<std::string>& names) {
    names[std::size_t(spine.front())] = "Hips";
    names[std::size_t(spine.back())] = "Head";
    std::size_t neck = spine.size() - 1;
    for (std::size_t n = 1; n + 1 < spine.size(); ++n)
        if (has(s.name(spine[n]), "neck")) {
            neck = n;
            break;
        }
    const std::size_t torso = neck - 1;  // joints between the root and the neck
    for (std::size_t n = 1; n < neck; ++n) {
        const std::size_t from_end = neck - n;  // 1: the last before the neck
        names[std::size_t(spine[n])] = from_end == 1 ? "Spine1" : (n == 1 && torso >= 3) ? "LowerBack" : "Spine";
    }
    for (std::size_t n = neck; n + 1 < spine.size(); ++n) names[std::size_t(spine[n])] = n == neck ? "Neck" : fmt::format("Neck{}", n - neck);
}

// An arm from its first joint off the spine, anchored at the elbow.
void name_arm(const Skeleton& s, int first, int elbow, const std::string& side, std::vector<std::string>& names) {
    const std::vector<int> chain = s.path(first, elbow);
    if (chain.size() < 2) missing(s, lower(side) + " upper arm", (side + "Arm or " + side + "Shoulder above the elbow").c_str());
    for (std::size_t n = 0; n + 2 < chain.size(); ++n) names[std::size_t(chain[n])] = side + "Shoulder";  // clavicles
    names[std::size_t(chain[chain.size() - 2])] = side + "Arm";
    names[std::size_t(elbow)] = side + "ForeArm";
    const int wrist = s.main_child(elbow);
    if (wrist < 0) missing(s, lower(side) + " wrist", (side + "Wrist or " + side + "Hand").c_str());
    names[std::size_t(wrist)] = side + "Hand";
    for (int k : s.subtree(wrist)) {
        if (k == wrist || s.end_site(k) || is_prop(s.name(k))) continue;
        const std::string& n = s.name(k);
        const bool named = n.find("Hand") != std::string::npos || n.find("Finger") != std::string::npos || n.find("Index") != std::string::npos;
        if (has(n, "thumb")) names[std::size_t(k)] = n.find("Thumb") != std::string::npos ? n : side.substr(0, 1) + "Thumb";
        else names[std::size_t(k)] = named ? n : side + "Finger";
    }
}

// A leg from its first joint off the root, anchored at the knee.
void name_leg(const Skeleton& s, int first, int knee, const std::string& side, std::vector<std::string>& names) {
    const std::vector<int> chain = s.path(first, knee);
    if (chain.size() < 2) missing(s, lower(side) + " thigh", (side + "UpLeg or " + side + "Hip above the knee").c_str());
    for (std::size_t n = 0; n + 2 < chain.size(); ++n) names[std::size_t(chain[n])] = side.substr(0, 1) + "HipJoint";
    names[std::size_t(chain[chain.size() - 2])] = side + "UpLeg";
    names[std::size_t(knee)] = side + "Leg";
    const int ankle = s.main_child(knee);
    if (ankle < 0) missing(s, lower(side) + " ankle", (side + "Foot or " + side + "Ankle").c_str());
    names[std::size_t(ankle)] = side + "Foot";
    for (int k : s.subtree(ankle))
        if (k != ankle && !s.end_site(k) && !is_prop(s.name(k))) names[std::size_t(k)] = side + "ToeBase";
}

}  // namespace

const std::vector<std::string>& role_vocabulary() {
    static const std::vector<std::string> roles = [] {
        std::vector<std::string> out{"Hips", "LowerBack", "Spine", "Spine1", "Neck", "Neck1", "Head"};
        for (const char* side : {"Left", "Right"})
            for (const char* limb : {"Shoulder", "Arm", "ForeArm", "Hand", "UpLeg", "Leg", "Foot", "ToeBase"}) out.push_back(std::string(side) + limb);
        return out;
    }();
    return roles;
}

std::vector<std::string> role_names(const BvhMotion& motion) {
    const Skeleton s(motion);
    std::vector<std::string> names(s.size());
    for (std::size_t j = 0; j < s.size(); ++j) names[j] = s.name(int(j));
    int head = -1;
    for (std::size_t j = 0; j < s.size() && head < 0; ++j)
        if (!s.end_site(int(j)) && has(s.name(int(j)), "head")) head = int(j);
    if (head < 0) missing(s, "head", "Head");
    const std::vector<int> spine = s.path(0, head);
    name_spine(s, spine, names);
    std::array<int, 4> found{};  // left arm, right arm, left leg, right leg
    for (int joint : spine)
        for (int branch : s.children(joint)) {
            if (std::find(spine.begin(), spine.end(), branch) != spine.end() || s.end_site(branch) || is_prop(s.name(branch))) continue;
            const int elbow = s.find_below(branch, is_elbow), knee = elbow < 0 ? s.find_below(branch, is_knee) : -1;
            if (elbow < 0 && knee < 0) continue;  // an extra branch: its joints keep their names
            const int side = s.side(branch);
            if (side == 0)
                fail(s.source(), "the {} chain from joint {} does not say whether it is left or right (no Left/Right/L/R in its joint names)",
                     elbow >= 0 ? "arm" : "leg", s.name(branch));
            const std::string prefix = side > 0 ? "Left" : "Right";
            if (elbow >= 0) name_arm(s, branch, elbow, prefix, names);
            else name_leg(s, branch, knee, prefix, names);
            ++found[std::size_t((elbow >= 0 ? 0 : 2) + (side > 0 ? 0 : 1))];
        }
    const char* roles[] = {"left elbow", "right elbow", "left knee", "right knee"};
    const char* like[] = {"LeftElbow or LeftForeArm", "RightElbow or RightForeArm", "LeftKnee or LeftLeg", "RightKnee or RightLeg"};
    for (std::size_t r = 0; r < 4; ++r) {
        if (found[r] == 0) missing(s, roles[r], like[r]);
        if (found[r] > 1) fail(s.source(), "{} limbs have a joint in the role of the {} (named like {}); amhv finds a skeleton's joints by role", found[r], roles[r], like[r]);
    }
    for (std::size_t j = 0; j < s.size(); ++j)
        if (s.end_site(int(j))) names[j] = names[std::size_t(s.parent(int(j)))] + "_end";
    return names;
}

}  // namespace amhv
