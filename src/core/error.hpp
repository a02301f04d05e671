#pragma once
// One exception type for every user-facing failure: its message is the one line the CLI prints.
#include <stdexcept>
#include <string>

#include <fmt/format.h>

namespace amhv {

class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// "what: message", the form every input error takes (what = a file, a key, an option).
template <typename... Args>
[[noreturn]] void fail(const std::string& what, fmt::format_string<Args...> format, Args&&... args) {
    throw Error(what + ": " + fmt::format(format, std::forward<Args>(args)...));
}

}  // namespace amhv
