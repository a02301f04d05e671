#include "io/bvh.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include "core/error.hpp"

namespace amhv {

namespace {

struct Token {
    std::string text;
    int line;
};

class Tokens {
public:
    Tokens(const std::string& text, std::string source) : source_(std::move(source)) {
        int line = 1;
        std::size_t i = 0;
        while (i < text.size()) {
            char c = text[i];
            if (c == '\n') {
                ++line;
                ++i;
            } else if (std::isspace(static_cast<unsigned char>(c))) {
                ++i;
            } else if (c == '#' || (c == '/' && i + 1 < text.size() && text[i + 1] == '/')) {
                while (i < text.size() && text[i] != '\n') ++i;  // comment to end of line
            } else if (c == '{' || c == '}') {
                tokens_.push_back({std::string(1, c), line});
                ++i;
            } else {
                std::size_t j = i;
                while (j < text.size() && !std::isspace(static_cast<unsigned char>(text[j])) && text[j] != '{' && text[j] != '}') ++j;
                tokens_.push_back({text.substr(i, j - i), line});
                i = j;
            }
        }
        last_line_ = line;
    }

    bool done() const { return next_ >= tokens_.size(); }
    int line() const { return done() ? last_line_ : tokens_[next_].line; }
    const std::string& peek() const {
        static const std::string end;
        return done() ? end : tokens_[next_].text;
    }
    std::string take(const char* what) {
        if (done()) error("file ends where {} was expected", what);
        return tokens_[next_++].text;
    }
    void expect(const std::string& word) {
        int at = line();
        std::string got = take(word.c_str());
        if (got != word) error_at(at, "expected '{}', found '{}'", word, got);
    }
    double number(const char* what) {
        int at = line();
        std::string text = take(what);
        double value = 0;
        auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
        if (ec != std::errc() || end != text.data() + text.size() || !std::isfinite(value))
            error_at(at, "{} '{}' is not a finite number", what, text);
        return value;
    }
    long integer(const char* what, long max) {
        int at = line();
        double value = number(what);
        if (value < 0 || value != std::floor(value) || value > double(max)) error_at(at, "{} {} is not a whole number in 0..{}", what, value, max);
        return long(value);
    }
    template <typename... Args>
    [[noreturn]] void error(fmt::format_string<Args...> format, Args&&... args) const {
        error_at(line(), format, std::forward<Args>(args)...);
    }
    template <typename... Args>
    [[noreturn]] void error_at(int at, fmt::format_string<Args...> format, Args&&... args) const {
        throw Error(fmt::format("{}:{}: {}", source_, at, fmt::format(format, std::forward<Args>(args)...)));
    }

private:
    std::string source_;
    std::vector<Token> tokens_;
    std::size_t next_ = 0;
    int last_line_ = 1;
};

constexpr int kMaxJoints = 1024;
constexpr long kMaxFrames = 10'000'000;
constexpr std::size_t kMaxValues = 500'000'000;

BvhJoint::Channel parse_channel(Tokens& tokens) {
    int at = tokens.line();
    std::string name = tokens.take("a channel name");
    std::string lower;
    for (char c : name) lower += char(std::tolower(static_cast<unsigned char>(c)));
    if (lower == "xposition") return BvhJoint::Channel::XPosition;
    if (lower == "yposition") return BvhJoint::Channel::YPosition;
    if (lower == "zposition") return BvhJoint::Channel::ZPosition;
    if (lower == "xrotation") return BvhJoint::Channel::XRotation;
    if (lower == "yrotation") return BvhJoint::Channel::YRotation;
    if (lower == "zrotation") return BvhJoint::Channel::ZRotation;
    tokens.error_at(at, "unknown channel '{}'", name);
}

void parse_joint(Tokens& tokens, BvhMotion& motion, int parent, bool end_site, std::string name) {
    if (int(motion.joints.size()) >= kMaxJoints) tokens.error("more than {} joints", kMaxJoints);
    int index = int(motion.joints.size());
    motion.joints.push_back({});
    {
        BvhJoint& joint = motion.joints.back();
        joint.name = std::move(name);
        joint.parent = parent;
        joint.end_site = end_site;
    }
    tokens.expect("{");
    tokens.expect("OFFSET");
    Vec3 offset;
    for (int i = 0; i < 3; ++i) offset[i] = tokens.number("offset");
    motion.joints[std::size_t(index)].offset = offset;
    if (!end_site) {
        tokens.expect("CHANNELS");
        long count = tokens.integer("channel count", 6);
        std::vector<BvhJoint::Channel> channels;
        for (long i = 0; i < count; ++i) channels.push_back(parse_channel(tokens));
        auto& joint = motion.joints[std::size_t(index)];
        joint.channels = std::move(channels);
        joint.first_channel = motion.channel_count;
        motion.channel_count += int(count);
    }
    while (tokens.peek() != "}") {
        int at = tokens.line();
        std::string word = tokens.take("JOINT, End Site or '}'");
        if (word == "JOINT" && !end_site) {
            parse_joint(tokens, motion, index, false, tokens.take("a joint name"));
        } else if (word == "End" && !end_site) {
            tokens.expect("Site");
            parse_joint(tokens, motion, index, true, motion.joints[std::size_t(index)].name + "_end");
        } else {
            tokens.error_at(at, "unexpected '{}' in joint {}", word, motion.joints[std::size_t(index)].name);
        }
    }
    tokens.expect("}");
}

Eigen::Matrix3d axis_rotation(BvhJoint::Channel channel, double degrees) {
    double radians = degrees * M_PI / 180.0;
    switch (channel) {
        case BvhJoint::Channel::XRotation: return Eigen::AngleAxisd(radians, Vec3::UnitX()).toRotationMatrix();
        case BvhJoint::Channel::YRotation: return Eigen::AngleAxisd(radians, Vec3::UnitY()).toRotationMatrix();
        case BvhJoint::Channel::ZRotation: return Eigen::AngleAxisd(radians, Vec3::UnitZ()).toRotationMatrix();
        default: return Eigen::Matrix3d::Identity();
    }
}

}  // namespace

int BvhMotion::joint_index(const std::string& name) const {
    for (std::size_t i = 0; i < joints.size(); ++i)
        if (joints[i].name == name) return int(i);
    return -1;
}

std::vector<Eigen::Isometry3d> BvhMotion::global_transforms(int frame) const {
    std::vector<Eigen::Isometry3d> global(joints.size());
    const double* row = values.data() + std::size_t(frame) * std::size_t(channel_count);
    for (std::size_t j = 0; j < joints.size(); ++j) {
        const BvhJoint& joint = joints[j];
        Eigen::Isometry3d local = Eigen::Isometry3d::Identity();
        Vec3 translation = joint.offset;
        Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
        for (std::size_t c = 0; c < joint.channels.size(); ++c) {
            double value = row[joint.first_channel + int(c)];
            switch (joint.channels[c]) {
                case BvhJoint::Channel::XPosition: translation.x() += value; break;
                case BvhJoint::Channel::YPosition: translation.y() += value; break;
                case BvhJoint::Channel::ZPosition: translation.z() += value; break;
                default: rotation = rotation * axis_rotation(joint.channels[c], value); break;  // in listed order
            }
        }
        local.translation() = translation;
        local.linear() = rotation;
        global[j] = joint.parent < 0 ? local : global[std::size_t(joint.parent)] * local;
    }
    return global;
}

BvhMotion read_bvh(const std::filesystem::path& path) {
    std::ifstream file(path, std::ios::binary);
    if (!file) fail(path.string(), "cannot open BVH file");
    std::stringstream buffer;
    buffer << file.rdbuf();
    Tokens tokens(buffer.str(), path.string());
    BvhMotion motion;
    motion.source = path.string();
    tokens.expect("HIERARCHY");
    tokens.expect("ROOT");
    parse_joint(tokens, motion, -1, false, tokens.take("the root joint's name"));
    while (tokens.peek() == "ROOT") tokens.error("more than one ROOT is not supported");
    tokens.expect("MOTION");
    tokens.expect("Frames:");
    motion.frame_count = int(tokens.integer("frame count", kMaxFrames));
    tokens.expect("Frame");
    tokens.expect("Time:");
    motion.frame_time = tokens.number("frame time");
    if (!(motion.frame_time > 0)) tokens.error("frame time must be positive");
    std::size_t total = std::size_t(motion.frame_count) * std::size_t(motion.channel_count);
    if (total > kMaxValues) tokens.error("{} frames x {} channels is too large", motion.frame_count, motion.channel_count);
    motion.values.reserve(total);
    for (int f = 0; f < motion.frame_count; ++f)
        for (int c = 0; c < motion.channel_count; ++c) {
            if (tokens.done())
                tokens.error("motion block is truncated: frame {} of {} has {} of {} values", f, motion.frame_count, c,
                             motion.channel_count);
            motion.values.push_back(tokens.number("motion value"));
        }
    if (!tokens.done())
        tokens.error("motion block has more values than {} frames x {} channels", motion.frame_count, motion.channel_count);
    if (motion.frame_count == 0) fail(path.string(), "BVH file has no motion frames");
    return motion;
}

}  // namespace amhv
