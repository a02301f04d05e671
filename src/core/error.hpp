#pragma once
// One exception type for every user-facing failure: its message is the one line the CLI prints.
#include <stdexcept>
#include <string>
#include <string_view>

#include <fmt/format.h>

namespace amhv {

class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// A piece of a file (a token, a library's complaint) as an error message may show it: bytes that
// are not printable as '?', at most `max` characters.
inline std::string printable(std::string_view text, std::size_t max = 40) {
    std::string out;
    for (char c : text.substr(0, max)) out += (c >= 0x20 && c < 0x7f) ? c : '?';
    return text.size() > max ? out + "..." : out;
}

// A message line with control characters escaped (\xNN), so that no file name can move the
// terminal's cursor or colour its output.
inline std::string escape_controls(std::string_view text) {
    std::string out;
    for (unsigned char c : text) out += (c < 0x20 || c == 0x7f) ? fmt::format("\\x{:02x}", c) : std::string(1, char(c));
    return out;
}

// "what: message", the form every input error takes (what = a file, a key, an option).
template <typename... Args>
[[noreturn]] void fail(const std::string& what, fmt::format_string<Args...> format, Args&&... args) {
    throw Error(what + ": " + fmt::format(format, std::forward<Args>(args)...));
}

// The input file the run is reading, for the out-of-memory message: while one of these lives, an
// allocation that fails is reported as the file's ("out of memory while reading FILE"), not as a
// voxel or range too fine. Readers make one for the length of their read; the innermost wins.
class ReadingFile {
public:
    explicit ReadingFile(std::string path);
    ~ReadingFile();
    ReadingFile(const ReadingFile&) = delete;
    ReadingFile& operator=(const ReadingFile&) = delete;
    // The file being read now; else the innermost one whose read an exception left; else empty.
    static std::string current();

private:
    std::string previous_;
    int exceptions_ = 0;
};

}  // namespace amhv
