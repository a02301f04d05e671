#include "src/propose/proposals.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace amhv::propose {

namespace {

// Holds of A and B on the same hand pairing: B's shifts of least coupled motion, each with the
// frames both hold.
void hold_candidates(const HandTrack& a, const ContactEvent& ea, const HandTrack& b, const ContactEvent& eb, std::vector<Candidate>& out) {
    const int shortest = std::max(1, int(std::lround(kMinHoldSeconds * a.fps)));
    struct Tried {
        int shift;
        std::array<int, 2> frames;
        Coupling c;
    };
    std::vector<Tried> tried;
    // Shift s: A's frame f meets B's f + s; the frames both hold are A's [max(a0, b0 - s), min(a1, b1 - s)].
    for (int s = eb.first - ea.last; s <= eb.last - ea.first; ++s) {
        const int first = std::max(ea.first, eb.first - s), last = std::min(ea.last, eb.last - s);
        if (last - first + 1 < shortest) continue;
        tried.push_back({s, {first, last}, coupled_motion(a, ea.hand, b, eb.hand, first, last, s)});
    }
    std::vector<const Tried*> minima;
    for (std::size_t i = 0; i < tried.size(); ++i) {
        const bool below_left = i == 0 || tried[i].c.rms_m < tried[i - 1].c.rms_m;
        const bool below_right = i + 1 == tried.size() || tried[i].c.rms_m <= tried[i + 1].c.rms_m;
        if (below_left && below_right) minima.push_back(&tried[i]);
    }
    std::stable_sort(minima.begin(), minima.end(), [](const Tried* x, const Tried* y) { return x->c.rms_m < y->c.rms_m; });
    if (minima.size() > std::size_t(kShiftsPerPair)) minima.resize(std::size_t(kShiftsPerPair));
    for (const Tried* t : minima) {
        Candidate c;
        c.a = t->frames;
        c.hand_a = ea.hand;
        c.hand_b = eb.hand;
        c.variant = 'a';
        c.coupling_m = t->c.rms_m;
        c.why = fmt::format("A {}; B {}; the hands' relative motion {:.1f} cm RMS when B's frame {} meets A's {}", ea.why, eb.why, 100 * t->c.rms_m,
                            c.a[0] + t->shift, c.a[0]);
        const auto shake = joined_shake(a, ea.hand, b, eb.hand, t->frames[0], t->frames[1], t->shift);
        if (shake) {
            c.a = shake->a;
            c.why += fmt::format("; they shake over A's frames {}-{} ({} strokes up and down, the slowest at {:.2f} m/s)", c.a[0], c.a[1],
                                 shake->strokes, shake->slowest_mps);
        }
        c.b = {c.a[0] + t->shift, c.a[1] + t->shift};
        out.push_back(c);
    }
}

}  // namespace

Coupling coupled_motion(const HandTrack& a, Hand hand_a, const HandTrack& b, Hand hand_b, int a0, int a1, int shift) {
    const int n = a1 - a0 + 1;
    const auto& pa = a.hand[int(hand_a)];
    const auto& pb = b.hand[int(hand_b)];
    auto at_a = [&](int f) { return pa[std::size_t(f - a.first)]; };
    auto at_b = [&](int f) { return pb[std::size_t(f + shift - b.first)]; };
    Vec3 mean_a = Vec3::Zero(), mean_b = Vec3::Zero();
    for (int f = a0; f <= a1; ++f) mean_a += at_a(f), mean_b += at_b(f);
    mean_a /= double(n), mean_b /= double(n);
    // Least squares over theta of sum |p - R(theta) q|^2 (p, q about their means): the planar part
    // is |p|^2 + |q|^2 - 2 (cos theta * dot + sin theta * cross), least at theta = atan2(cross, dot).
    double dot = 0, cross = 0, squares = 0, heights = 0;
    for (int f = a0; f <= a1; ++f) {
        const Vec3 p = at_a(f) - mean_a, q = at_b(f) - mean_b;
        dot += p.x() * q.x() + p.y() * q.y();
        cross += q.x() * p.y() - q.y() * p.x();
        squares += p.x() * p.x() + p.y() * p.y() + q.x() * q.x() + q.y() * q.y();
        heights += (p.z() - q.z()) * (p.z() - q.z());
    }
    const double planar = std::max(0.0, squares - 2.0 * std::hypot(dot, cross));
    return {std::sqrt((planar + heights) / double(n)), std::atan2(cross, dot)};
}

std::optional<Shake> joined_shake(const HandTrack& a, Hand hand_a, const HandTrack& b, Hand hand_b, int a0, int a1, int shift) {
    const auto& pa = a.hand[int(hand_a)];
    const auto& pb = b.hand[int(hand_b)];
    // A's frames where both tracks have the hand: [lo, hi].
    const int lo = std::max(a.first, b.first - shift), hi = std::min(a.first + a.frames() - 1, b.first + b.frames() - 1 - shift);
    auto height = [&](int f) { return (pa[std::size_t(f - a.first)].z() + pb[std::size_t(f + shift - b.first)].z()) / 2; };
    const int h = std::max(1, int(std::lround(kSpanSeconds / 2 * a.fps)));
    struct Stroke {
        int first, last, sign;
        double peak;
    };
    std::vector<Stroke> strokes;
    std::vector<double> speed;  // per frame from a0: |vertical speed|
    for (int f = std::max(a0, lo); f <= std::min(a1, hi); ++f) {
        const int before = std::max(lo, f - h), after = std::min(hi, f + h);
        const double v = after > before ? (height(after) - height(before)) * a.fps / double(after - before) : 0.0;
        speed.push_back(std::abs(v));
        const int sign = v > 0 ? 1 : v < 0 ? -1 : strokes.empty() ? 1 : strokes.back().sign;
        if (strokes.empty() || sign != strokes.back().sign) strokes.push_back({f, f, sign, 0.0});
        strokes.back().last = f;
        strokes.back().peak = std::max(strokes.back().peak, std::abs(v));
    }
    std::optional<Shake> best;
    for (std::size_t i = 0; i < strokes.size();) {
        std::size_t j = i;
        while (j < strokes.size() && strokes[j].peak >= kPumpSpeed) ++j;
        const int count = int(j - i);
        if (count >= kPumpStrokes && (!best || count > best->strokes)) {
            // From the first moving frame of the first stroke to the last of the last.
            const int from = std::max(a0, lo);
            int first = strokes[i].first, last = strokes[j - 1].last;
            while (speed[std::size_t(first - from)] < kStillSpeed) ++first;
            while (speed[std::size_t(last - from)] < kStillSpeed) --last;
            best = Shake{{first, last}, count, strokes[i].peak};
            for (std::size_t k = i; k < j; ++k) best->slowest_mps = std::min(best->slowest_mps, strokes[k].peak);
        }
        i = std::max(j, i + 1);
    }
    return best;
}

std::vector<Candidate> candidates(const HandTrack& a, const std::vector<ContactEvent>& events_a, const HandTrack& b,
                                  const std::vector<ContactEvent>& events_b) {
    std::vector<Candidate> out;
    const int b_first = b.first, b_last = b.first + b.frames() - 1;
    for (const ContactEvent& ea : events_a)
        for (const ContactEvent& eb : events_b) {
            if (ea.variant != eb.variant) continue;
            if (ea.variant == 'a') {
                hold_candidates(a, ea, b, eb, out);
                continue;
            }
            const int shift = eb.moment - ea.moment;
            Candidate c;
            c.a = {ea.first, ea.last};
            c.b = {ea.first + shift, ea.last + shift};
            if (c.b[0] < b_first || c.b[1] > b_last) continue;  // B's take does not hold A's window there
            c.hand_a = ea.hand;
            c.hand_b = eb.hand;
            c.variant = 'b';
            c.why = fmt::format("A: {}; B: {}", ea.why, eb.why);
            out.push_back(c);
        }
    return out;
}

KeySegment candidate_segment(const Candidate& c, int index) {
    KeySegment k;
    k.index = index;
    k.a = c.a;
    k.b = c.b;
    k.type = parse_interaction_type(c.variant == 'a' ? "0&0a" : "0&0b", "proposal");
    auto interest = [](Hand hand) {
        PartSpec p;
        p.kind = PartSpec::Kind::Parts;
        p.labels = {hand_part(hand)};
        return p;
    };
    auto fidelity = [](Hand hand) {
        const std::string side = hand == Hand::Left ? "left" : "right";
        PartSpec p;
        p.kind = PartSpec::Kind::PartsExcept;
        p.labels = {side + "_upper_arm", side + "_forearm", side + "_hand"};
        return p;
    };
    k.interest_a = interest(c.hand_a);
    k.interest_b = interest(c.hand_b);
    k.fidelity_a = fidelity(c.hand_a);
    k.fidelity_b = fidelity(c.hand_b);
    k.visibility.enabled = true;
    k.visibility.half_angle_deg = kProposalViewDeg;
    return k;
}

}  // namespace amhv::propose
