#include "src/compose/recognise.hpp"

#include <algorithm>
#include <cmath>

#include "src/compose/features.hpp"
#include "src/core/parallel.hpp"

namespace amhv::compose {

namespace {

// Per frame j of the take, how well the example matches it: the largest diagonally blurred
// similarity over the example's frames i (each diagonal, i - j fixed, is one alignment of the
// example in the take; the blur averages a pair with its aligned neighbours). Distances weigh each
// feature dimension by `weight`.
std::vector<double> votes(const FeatureClip& example, const FeatureClip& take, const Eigen::ArrayXd& weight, int blur) {
    const int n = int(example.size()), m = int(take.size());
    Eigen::MatrixXd w(n, m);
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < m; ++j)
            w(i, j) = std::exp(-(weight * (example[std::size_t(i)] - take[std::size_t(j)]).array().square()).sum() / (kSimilarityScale * kSimilarityScale));
    std::vector<double> h(std::size_t(m), 0.0);
    for (int c = 0; c < m; ++c) {
        const int shift = c - n / 2;  // j = i + shift
        for (int i = std::max(0, -shift); i < n && i + shift < m; ++i) {
            double sum = 0;
            int count = 0;
            for (int o = -blur; o <= blur; ++o) {
                const int a = i + o, b = i + shift + o;
                if (a < 0 || a >= n || b < 0 || b >= m) continue;
                sum += w(a, b);
                ++count;
            }
            h[std::size_t(i + shift)] = std::max(h[std::size_t(i + shift)], sum / count);
        }
    }
    return h;
}

// Per frame, the action whose examples match it best, when the match reaches kMinVote; then the
// nodes: runs of one action at least kMinExampleSeconds long (shorter runs stay unknown).
std::vector<Node> label_frames(const Library& library, int take, const std::vector<std::vector<double>>& h, const std::vector<int>& actions,
                               TakeLabels& labels) {
    const LibraryTake& t = library.takes[std::size_t(take)];
    const std::size_t count = std::size_t(t.frames());
    labels.action.assign(count, -1);
    labels.confidence.assign(count, 0.0);
    for (std::size_t f = 0; f < count; ++f)
        for (std::size_t e = 0; e < actions.size(); ++e)
            if (h[e][f] >= kMinVote && h[e][f] > labels.confidence[f]) {
                labels.confidence[f] = h[e][f];
                labels.action[f] = actions[e];
            }
    std::vector<Node> nodes;
    const std::size_t min_length = std::size_t(std::ceil(kMinExampleSeconds * library.fps));
    for (std::size_t start = 0; start < count;) {
        std::size_t end = start;
        while (end + 1 < count && labels.action[end + 1] == labels.action[start]) ++end;
        if (labels.action[start] >= 0 && end - start + 1 < min_length) {
            for (std::size_t f = start; f <= end; ++f) labels.action[f] = -1, labels.confidence[f] = 0;
        } else if (labels.action[start] >= 0) {
            Node node{take, t.first + int(start), t.first + int(end), labels.action[start], 0.0};
            for (std::size_t f = start; f <= end; ++f) node.vote += labels.confidence[f] / double(end - start + 1);
            nodes.push_back(node);
        }
        start = end + 1;
    }
    return nodes;
}

}  // namespace

Eigen::ArrayXd feature_weights(const std::vector<FeatureClip>& clips, const std::vector<int>& actions) {
    const Eigen::Index dims = clips.front().front().size();
    std::vector<int> kinds(actions.begin(), actions.end());
    std::sort(kinds.begin(), kinds.end());
    kinds.erase(std::unique(kinds.begin(), kinds.end()), kinds.end());
    std::vector<Eigen::ArrayXd> mean(kinds.size(), Eigen::ArrayXd::Zero(dims));
    std::vector<double> count(kinds.size(), 0.0);
    Eigen::ArrayXd all = Eigen::ArrayXd::Zero(dims);
    std::vector<std::size_t> kind_of(clips.size());  // clip -> index into kinds
    for (std::size_t c = 0; c < clips.size(); ++c) {
        kind_of[c] = std::size_t(std::lower_bound(kinds.begin(), kinds.end(), actions[c]) - kinds.begin());
        for (const Eigen::VectorXd& x : clips[c]) {
            mean[kind_of[c]] += x.array();
            count[kind_of[c]] += 1;
            all += x.array();
        }
    }
    double total = 0;
    for (std::size_t k = 0; k < kinds.size(); ++k) mean[k] /= count[k], total += count[k];
    all /= total;
    Eigen::ArrayXd between = Eigen::ArrayXd::Zero(dims), within = Eigen::ArrayXd::Zero(dims);
    for (std::size_t k = 0; k < kinds.size(); ++k) between += count[k] * (mean[k] - all).square();
    for (std::size_t c = 0; c < clips.size(); ++c)
        for (const Eigen::VectorXd& x : clips[c]) within += (x.array() - mean[kind_of[c]]).square();
    // A joint's coordinate enters a feature divided by the square root of the key joints' count (9).
    const double floor = total * kFeatureNoise * kFeatureNoise / double(KeyJoints{}.all().size());
    const Eigen::ArrayXd ratio = between / within.max(floor);
    if (kinds.size() < 2 || ratio.sum() <= 0) return Eigen::ArrayXd::Ones(dims);
    return ratio * (double(dims) / ratio.sum());
}

std::vector<std::vector<Eigen::VectorXd>> library_features(const Library& library) {
    const KeyJoints key = key_joints(library.roles, library.file.string());
    std::vector<std::vector<Eigen::VectorXd>> out(library.takes.size());
    parallel_for(library.takes.size(), [&](std::size_t t) {
        const LibraryTake& take = library.takes[t];
        const PoseTrack track = pose_track(take.motion, library.units, key);
        out[t] = motion_features(track, key, library.fps, take.first, take.last);
    });
    return out;
}

Recognition recognise(const Library& library, const std::vector<std::vector<Eigen::VectorXd>>& features, int leave_out) {
    std::vector<int> examples;
    for (std::size_t e = 0; e < library.examples.size(); ++e)
        if (library.examples[e].take != leave_out) examples.push_back(int(e));
    const int blur = std::max(1, int(std::lround(kBlurSeconds * library.fps)));
    std::vector<FeatureClip> clips;
    std::vector<int> actions;
    for (int e : examples) {
        const ActionExample& example = library.examples[std::size_t(e)];
        const auto& source = features[std::size_t(example.take)];
        const int from = example.first - library.takes[std::size_t(example.take)].first;
        clips.emplace_back(source.begin() + from, source.begin() + from + (example.last - example.first + 1));
        actions.push_back(library.action_index(example.action));
    }
    // Each example also in a mirror: an action done to the left is the action done to the right.
    for (std::size_t c = 0, given = clips.size(); c < given; ++c) {
        FeatureClip mirror;
        for (const Eigen::VectorXd& x : clips[c]) mirror.push_back(mirrored_feature(x));
        clips.push_back(std::move(mirror));
        actions.push_back(actions[c]);
    }
    const Eigen::ArrayXd weight = clips.empty() ? Eigen::ArrayXd() : feature_weights(clips, actions);
    Recognition out;
    out.labels.resize(library.takes.size());
    std::vector<std::vector<Node>> per_take(library.takes.size());
    parallel_for(library.takes.size(), [&](std::size_t t_) { const int t = int(t_);
        std::vector<std::vector<double>> h;
        for (const FeatureClip& clip : clips) h.push_back(votes(clip, features[std::size_t(t)], weight, blur));
        per_take[std::size_t(t)] = label_frames(library, t, h, actions, out.labels[std::size_t(t)]);
    });
    for (auto& nodes : per_take) out.nodes.insert(out.nodes.end(), nodes.begin(), nodes.end());
    return out;
}

}  // namespace amhv::compose
