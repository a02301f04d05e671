#include "src/io/bvh.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

#include "src/core/angles.hpp"
#include "src/core/error.hpp"

namespace amhv {

namespace {

// The file's words, read one at a time from the stream: memory stays a word, whatever the file's
// size (a 100 MB take is never held as text, let alone as a list of strings).
class Tokens {
public:
    Tokens(std::istream& in, std::string source) : in_(*in.rdbuf()), source_(std::move(source)) { advance(); }

    bool done() const { return !has_; }
    int line() const { return has_ ? current_line_ : line_; }
    const std::string& peek() const {
        static const std::string end;
        return has_ ? current_ : end;
    }
    std::string take(const char* what) {
        if (!has_) error("file ends where {} was expected", what);
        std::string out = std::move(current_);
        advance();
        return out;
    }
    void expect(const std::string& word) {
        int at = line();
        std::string got = take(word.c_str());
        if (got != word) error_at(at, "expected '{}', found '{}'", word, printable(got));
    }
    double number(const char* what) {
        int at = line();
        std::string text = take(what);
        double value = 0;
        auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
        if (ec != std::errc() || end != text.data() + text.size() || !std::isfinite(value))
            error_at(at, "{} '{}' is not a finite number", what, printable(text));
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
    // Loads the next word into current_ (or leaves has_ false at the end): LF, CRLF or a lone CR end
    // a line; '#' and '//' start a comment to the end of the line; '{' and '}' are words alone.
    void advance() {
        has_ = false;
        current_.clear();
        for (;;) {
            const int c = in_.sbumpc();
            if (c == std::char_traits<char>::eof()) return;
            if (c == '\n' || (c == '\r' && in_.sgetc() != '\n')) {
                ++line_;
            } else if (std::isspace(c)) {
                continue;
            } else if (c == '#' || (c == '/' && in_.sgetc() == '/')) {
                for (int d = in_.sgetc(); d != std::char_traits<char>::eof() && d != '\n' && d != '\r'; d = in_.sgetc()) in_.sbumpc();
            } else {
                has_ = true;
                current_line_ = line_;
                current_.push_back(char(c));
                if (c == '{' || c == '}') return;
                for (int d = in_.sgetc(); d != std::char_traits<char>::eof() && !std::isspace(d) && d != '{' && d != '}'; d = in_.sgetc()) {
                    if (current_.size() >= kMaxWord) error_at(line_, "a word longer than {} characters: not a BVH file", kMaxWord);
                    current_.push_back(char(in_.sbumpc()));
                }
                return;
            }
        }
    }

    static constexpr std::size_t kMaxWord = 4096;
    std::streambuf& in_;
    std::string source_;
    std::string current_;
    bool has_ = false;
    int current_line_ = 1, line_ = 1;
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
    tokens.error_at(at, "unknown channel '{}'", printable(name));
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
            const int name_line = tokens.line();
            std::string child = tokens.take("a joint name");
            // Names identify joints (parts, tracks, scenes): a repeated name would make one ambiguous.
            if (motion.joint_index(child) >= 0) tokens.error_at(name_line, "joint '{}' is defined twice", printable(child));
            parse_joint(tokens, motion, index, false, std::move(child));
        } else if (word == "End" && !end_site) {
            tokens.expect("Site");
            parse_joint(tokens, motion, index, true, motion.joints[std::size_t(index)].name + "_end");
        } else {
            tokens.error_at(at, "unexpected '{}' in joint {}", printable(word), motion.joints[std::size_t(index)].name);
        }
    }
    tokens.expect("}");
}

bool is_rotation(BvhJoint::Channel channel) {
    return channel == BvhJoint::Channel::XRotation || channel == BvhJoint::Channel::YRotation || channel == BvhJoint::Channel::ZRotation;
}

int axis_of(BvhJoint::Channel channel) {
    switch (channel) {
        case BvhJoint::Channel::XRotation: case BvhJoint::Channel::XPosition: return 0;
        case BvhJoint::Channel::YRotation: case BvhJoint::Channel::YPosition: return 1;
        default: return 2;
    }
}

Eigen::Matrix3d axis_rotation(BvhJoint::Channel channel, double degrees) {
    double radians = angles::radians(degrees);
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
    const ReadingFile reading(path.string());
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) fail(path.string(), "cannot open BVH file: it does not exist");
    if (!std::filesystem::is_regular_file(path, ec)) fail(path.string(), "cannot open BVH file: it is not a regular file");
    std::ifstream file(path, std::ios::binary);
    if (!file) fail(path.string(), "cannot open BVH file");
    const std::uintmax_t file_bytes = std::filesystem::file_size(path, ec);
    Tokens tokens(file, path.string());
    BvhMotion motion;
    motion.source = path.string();
    // A file that is not a BVH at all: say so without echoing what it holds instead.
    if (!tokens.done() && tokens.peek() != "HIERARCHY") tokens.error("is not a BVH file: it does not start with HIERARCHY");
    tokens.expect("HIERARCHY");
    tokens.expect("ROOT");
    parse_joint(tokens, motion, -1, false, tokens.take("the root joint's name"));
    while (tokens.peek() == "ROOT") tokens.error("more than one ROOT is not supported");
    tokens.expect("MOTION");
    tokens.expect("Frames:");
    motion.frame_count = int(tokens.integer("frame count", kMaxFrames));
    tokens.expect("Frame");
    tokens.expect("Time:");
    const int frame_time_line = tokens.line();
    motion.frame_time = tokens.number("frame time");
    // 10 microseconds to a minute a frame: beyond that the rate is garbage, and resampling it
    // would overflow the frame count.
    if (!(motion.frame_time >= 1e-5 && motion.frame_time <= 60))
        tokens.error_at(frame_time_line, "frame time {} s is not between 0.00001 and 60 seconds", motion.frame_time);
    std::size_t total = std::size_t(motion.frame_count) * std::size_t(motion.channel_count);
    if (total > kMaxValues) tokens.error("{} frames x {} channels is too large", motion.frame_count, motion.channel_count);
    // Every value takes at least two characters ("0 "): a header that promises more frames than
    // the file can hold reserves no more than the file can fill.
    motion.values.reserve(std::min<std::size_t>(total, std::size_t(file_bytes / 2) + 1));
    // One frame per line, as the format defines: a row with too few or too many values is named
    // by its line instead of shifting every later frame.
    for (int f = 0; f < motion.frame_count; ++f) {
        if (tokens.done()) tokens.error("motion block is truncated: {} of {} frames", f, motion.frame_count);
        const int row = tokens.line();
        for (int c = 0; c < motion.channel_count; ++c) {
            if (tokens.done())
                tokens.error_at(row, "motion block is truncated: frame {} of {} has {} of {} values", f, motion.frame_count, c,
                                motion.channel_count);
            if (tokens.line() != row)
                tokens.error_at(row, "frame {} has {} values but the hierarchy declares {} channels", f, c, motion.channel_count);
            motion.values.push_back(tokens.number("motion value"));
        }
        if (!tokens.done() && tokens.line() == row) {
            int count = motion.channel_count;
            while (!tokens.done() && tokens.line() == row) {
                tokens.take("a value");
                ++count;
            }
            tokens.error_at(row, "frame {} has {} values but the hierarchy declares {} channels", f, count, motion.channel_count);
        }
    }
    if (!tokens.done())
        tokens.error("motion block has more rows than the {} frames it declares", motion.frame_count);
    if (motion.frame_count == 0) fail(path.string(), "BVH file has no motion frames");
    return motion;
}

double BvhMotion::fps() const {
    const double rate = 1.0 / frame_time;
    const double whole = std::round(rate);
    return std::abs(rate - whole) <= 1e-4 * whole ? whole : rate;
}

bool starts_with_tpose(const BvhMotion& motion) {
    if (motion.frame_count < 2 || motion.joints.empty()) return false;
    auto whole_rotations = [&](int frame) {
        const double* row = motion.values.data() + std::size_t(frame) * std::size_t(motion.channel_count);
        for (const BvhJoint& joint : motion.joints)
            for (std::size_t c = 0; c < joint.channels.size(); ++c)
                if (is_rotation(joint.channels[c]) && row[joint.first_channel + int(c)] != std::round(row[joint.first_channel + int(c)]))
                    return false;
        return true;
    };
    const BvhJoint& root = motion.joints.front();
    for (std::size_t c = 0; c < root.channels.size(); ++c)
        if (is_rotation(root.channels[c]) && motion.values[std::size_t(root.first_channel) + c] != 0.0) return false;
    return whole_rotations(0) && !whole_rotations(1);
}

TPose parse_tpose(const std::string& text, const std::string& what) {
    if (text == "auto") return TPose::Auto;
    if (text == "skip") return TPose::Skip;
    if (text == "keep") return TPose::Keep;
    throw Error(fmt::format("{}: '{}' is not auto, skip or keep", what, text));
}

std::string_view to_string(TPose mode) {
    switch (mode) {
        case TPose::Auto: return "auto";
        case TPose::Skip: return "skip";
        case TPose::Keep: return "keep";
    }
    return "?";
}

BvhMotion resample_bvh(const BvhMotion& motion, double fps) {
    if (!(fps > 0) || !std::isfinite(fps)) fail(motion.source, "cannot resample to {} frames per second", fps);
    const double step = motion.fps() / fps;  // source frames per output frame
    const int last = motion.frame_count - 1;
    // Output frames whose moment lies within the take; the 1e-9 keeps the last one when the
    // ratio is a whole number that floating point misses by an ulp.
    const double frames = std::floor(double(last) / step + 1e-9) + 1;
    if (!(frames <= double(kMaxFrames)))
        fail(motion.source, "resampling to {} fps gives {} frames: more than {}", fps, frames, kMaxFrames);
    const long count = long(frames);
    if (std::size_t(count) * std::size_t(motion.channel_count) > kMaxValues)
        fail(motion.source, "resampling to {} fps gives {} frames: too many", fps, count);

    BvhMotion out = motion;
    out.frame_time = 1.0 / fps;
    out.frame_count = int(count);
    out.first_frame = int(std::ceil(double(motion.first_frame) / step - 1e-9));
    out.values.assign(std::size_t(count) * std::size_t(motion.channel_count), 0.0);
    const std::size_t channels = std::size_t(motion.channel_count);
    for (long k = 0; k < count; ++k) {
        double s = double(k) * step;
        // Moments that fall on a captured frame copy it exactly.
        if (std::abs(s - std::round(s)) < 1e-6) s = std::round(s);
        const int i = std::min(int(std::floor(s)), last);
        const int j = std::min(i + 1, last);
        const double w = s - double(i);
        const double* a = motion.values.data() + std::size_t(i) * channels;
        const double* b = motion.values.data() + std::size_t(j) * channels;
        double* row = out.values.data() + std::size_t(k) * channels;
        if (w == 0.0 || i == j) {
            std::copy(a, a + channels, row);
            continue;
        }
        for (const BvhJoint& joint : motion.joints) {
            std::vector<std::size_t> rotations;
            for (std::size_t c = 0; c < joint.channels.size(); ++c) {
                const std::size_t at = std::size_t(joint.first_channel) + c;
                if (is_rotation(joint.channels[c])) {
                    rotations.push_back(c);
                } else {
                    row[at] = (1 - w) * a[at] + w * b[at];
                }
            }
            const bool euler = rotations.size() == 3 && joint.channels[rotations[0]] != joint.channels[rotations[1]] &&
                               joint.channels[rotations[1]] != joint.channels[rotations[2]];
            if (euler) {
                // Euler angles do not interpolate as rotations; quaternions do.
                auto quaternion = [&](const double* values) {
                    Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
                    for (std::size_t c : rotations) r = r * axis_rotation(joint.channels[c], values[std::size_t(joint.first_channel) + c]);
                    return Eigen::Quaterniond(r);
                };
                const Eigen::Matrix3d r = quaternion(a).slerp(w, quaternion(b)).toRotationMatrix();
                const Vec3 turned = r.eulerAngles(axis_of(joint.channels[rotations[0]]), axis_of(joint.channels[rotations[1]]),
                                                  axis_of(joint.channels[rotations[2]]));
                for (int n = 0; n < 3; ++n) row[std::size_t(joint.first_channel) + rotations[std::size_t(n)]] = angles::degrees(turned[n]);
            } else {
                for (std::size_t c : rotations) {
                    const std::size_t at = std::size_t(joint.first_channel) + c;
                    const double turn = std::remainder(b[at] - a[at], 360.0);  // the short way round
                    row[at] = a[at] + w * turn;
                }
            }
        }
    }
    return out;
}

namespace {

const char* channel_name(BvhJoint::Channel c) {
    switch (c) {
        case BvhJoint::Channel::XPosition: return "Xposition";
        case BvhJoint::Channel::YPosition: return "Yposition";
        case BvhJoint::Channel::ZPosition: return "Zposition";
        case BvhJoint::Channel::XRotation: return "Xrotation";
        case BvhJoint::Channel::YRotation: return "Yrotation";
        default: return "Zrotation";
    }
}

void write_joint(const BvhMotion& motion, std::size_t j, int depth, std::string& out) {
    const BvhJoint& joint = motion.joints[j];
    const std::string indent(std::size_t(depth), '\t');
    out += indent + (joint.end_site ? std::string("End Site") : (joint.parent < 0 ? "ROOT " : "JOINT ") + joint.name) + "\n" + indent + "{\n";
    out += fmt::format("{}\tOFFSET {:.6f} {:.6f} {:.6f}\n", indent, joint.offset.x(), joint.offset.y(), joint.offset.z());
    if (!joint.end_site) {
        out += fmt::format("{}\tCHANNELS {}", indent, joint.channels.size());
        for (BvhJoint::Channel c : joint.channels) out += std::string(" ") + channel_name(c);
        out += "\n";
    }
    for (std::size_t child = j + 1; child < motion.joints.size(); ++child)
        if (motion.joints[child].parent == int(j)) write_joint(motion, child, depth + 1, out);
    out += indent + "}\n";
}

}  // namespace

std::string bvh_text(const BvhMotion& motion) {
    std::string out = "HIERARCHY\n";
    write_joint(motion, 0, 0, out);
    out += fmt::format("MOTION\nFrames: {}\nFrame Time: {:.8f}\n", motion.frame_count, motion.frame_time);
    for (int f = 0; f < motion.frame_count; ++f) {
        const double* row = motion.values.data() + std::size_t(f) * std::size_t(motion.channel_count);
        for (int c = 0; c < motion.channel_count; ++c) out += fmt::format("{}{:.6f}", c ? " " : "", row[c]);
        out += "\n";
    }
    return out;
}

std::array<double, 3> euler_degrees_near(const Eigen::Matrix3d& rotation, const std::array<int, 3>& axes, const std::array<double, 3>& near) {
    const Vec3 first = rotation.eulerAngles(axes[0], axes[1], axes[2]);
    // Tait-Bryan angles have a second solution (a0 + pi, pi - a1, a2 + pi); proper Euler angles
    // (a0 + pi, -a1, a2 + pi). Each angle then moves by whole turns to lie nearest `near`.
    const bool proper = axes[0] == axes[2];
    const Vec3 second(first[0] + std::numbers::pi, proper ? -first[1] : std::numbers::pi - first[1], first[2] + std::numbers::pi);
    std::array<double, 3> best{}, candidate{};
    double best_distance = std::numeric_limits<double>::infinity();
    for (const Vec3& solution : {first, second}) {
        double distance = 0;
        for (int i = 0; i < 3; ++i) {
            const double degrees = angles::degrees(solution[i]);
            candidate[std::size_t(i)] = degrees + 360.0 * std::round((near[std::size_t(i)] - degrees) / 360.0);
            distance += std::abs(candidate[std::size_t(i)] - near[std::size_t(i)]);
        }
        if (distance < best_distance) best_distance = distance, best = candidate;
    }
    return best;
}

Eigen::Quaterniond joint_rotation(const BvhMotion& motion, int joint, int frame) {
    const BvhJoint& j = motion.joints[std::size_t(joint)];
    const double* row = motion.values.data() + std::size_t(frame) * std::size_t(motion.channel_count);
    Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
    for (std::size_t c = 0; c < j.channels.size(); ++c)
        if (is_rotation(j.channels[c])) r = r * axis_rotation(j.channels[c], row[std::size_t(j.first_channel) + c]);
    return Eigen::Quaterniond(r);
}

void set_joint_rotation(BvhMotion& motion, int joint, int frame, const Eigen::Quaterniond& rotation, int near_frame) {
    const BvhJoint& j = motion.joints[std::size_t(joint)];
    std::array<std::size_t, 3> at{};
    std::array<int, 3> axes{};
    std::size_t n = 0;
    for (std::size_t c = 0; c < j.channels.size() && n < 3; ++c)
        if (is_rotation(j.channels[c])) at[n] = std::size_t(j.first_channel) + c, axes[n++] = axis_of(j.channels[c]);
    if (n != 3) fail(motion.source, "joint '{}' has no three rotation channels to set", j.name);
    const std::size_t channels = std::size_t(motion.channel_count);
    const double* near_row = motion.values.data() + std::size_t(near_frame < 0 ? frame : near_frame) * channels;
    const std::array<double, 3> near{near_row[at[0]], near_row[at[1]], near_row[at[2]]};
    const std::array<double, 3> angles = euler_degrees_near(rotation.normalized().toRotationMatrix(), axes, near);
    double* row = motion.values.data() + std::size_t(frame) * channels;
    for (std::size_t k = 0; k < 3; ++k) row[at[k]] = angles[k];
}

BvhMotion load_bvh(const std::filesystem::path& path, const BvhLoadOptions& options) {
    BvhMotion motion = read_bvh(path);
    if (options.tpose == TPose::Skip || (options.tpose == TPose::Auto && starts_with_tpose(motion))) {
        if (motion.frame_count < 2) fail(path.string(), "cannot skip the T-pose frame: the file has only one frame");
        motion.first_frame = 1;
    }
    if (options.fps > 0 && std::abs(options.fps - motion.fps()) > 1e-9 * options.fps) motion = resample_bvh(motion, options.fps);
    return motion;
}

}  // namespace amhv
