#pragma once
// Recognising actions from a few examples (after the splicing document, section 6.1): frame to
// frame similarity of motion features between each example and each take, blurred along the
// diagonal; each frame takes the action that matches it best, and single-action nodes are the runs
// of one action (docs/method.md section 12 says where this differs from the document).
#include <vector>

#include <Eigen/Core>

#include "src/compose/library.hpp"

namespace amhv::compose {

// Similarity of two features at distance d (metres): exp(-(d / kSimilarityScale)^2), so 0.1 m
// of root-frame difference (a hand a palm's width elsewhere) reads 0.37.
inline constexpr double kSimilarityScale = 0.35;
// Distances weigh each feature dimension by Fisher's criterion over the examples (how far the
// actions' means lie apart against how far each action's frames spread), so that what tells the
// given actions apart counts, not what every standing or walking body shares. The spread within an
// action is floored at kFeatureNoise of joint position (metres), above optical capture's noise.
inline constexpr double kFeatureNoise = 0.01;
// The diagonal blur: the mean over +-kBlurSeconds of aligned frames (a pose must match with its
// neighbours, not alone).
inline constexpr double kBlurSeconds = 0.1;
// A frame is labelled with the action whose examples match it best (the blurred similarity at its
// best aligned pair) when that match reaches kMinVote; below it, the frame stays unknown.
inline constexpr double kMinVote = 0.4;

struct Node {
    int take = 0;
    int first = 0, last = 0;  // frames of the take at the library's clock, inclusive
    int action = 0;           // into Library::actions
    double vote = 0;          // the mean match over its frames
};

struct TakeLabels {
    std::vector<int> action;         // per frame in [take.first, take.last]; -1: unknown
    std::vector<double> confidence;  // the vote of the node that labels it; 0 when unknown
};

struct Recognition {
    std::vector<Node> nodes;           // per take, in frame order
    std::vector<TakeLabels> labels;    // per take
};

using FeatureClip = std::vector<Eigen::VectorXd>;

// Fisher's criterion per feature dimension over example clips (`actions[c]` is clip c's action):
// the spread of the actions' means about their common mean over the spread of each action's frames
// about its own mean, every frame counted once, divided by its mean over the dimensions so that a
// weighted distance keeps its units on average. The spread within an action is floored at
// kFeatureNoise per frame; with one action only, every weight is 1.
Eigen::ArrayXd feature_weights(const std::vector<FeatureClip>& clips, const std::vector<int>& actions);

// The motion features of every take over the frames it uses.
std::vector<std::vector<Eigen::VectorXd>> library_features(const Library& library);

// Recognition over every take, with every example except those of take `leave_out` (-1: none),
// each also in a mirror (mirrored_feature: an action done to the left is the action done to the
// right).
Recognition recognise(const Library& library, const std::vector<std::vector<Eigen::VectorXd>>& features, int leave_out = -1);

}  // namespace amhv::compose
