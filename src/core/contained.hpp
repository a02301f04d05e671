#pragma once
// Work that may crash, run in a child process: reading a file with a library whose parsers are
// not hardened against crafted input (assimp). The child is forked, runs the work, and sends its
// result back through a pipe; a crash, a hang past the time limit or memory past the limit ends the
// child, not amhv, and comes back as one amhv::Error naming the file.
#include <cstddef>
#include <functional>
#include <string>

namespace amhv {

struct ContainLimits {
    unsigned seconds = 300;                          // wall-clock time (SIGALRM in the child)
    std::size_t memory_bytes = std::size_t(16) << 30;  // address space the child may add to what it inherits (RLIMIT_AS)
};

// Runs `work` in a forked child and returns the bytes it returned. An amhv::Error it throws is
// thrown here with the same message (another exception as "cannot be read"); a child that dies of a signal,
// passes a limit or exits otherwise gives Error("`what`: ..."). The child only runs `work` and
// writes to the pipe (it leaves by _exit: no destructors, no atexit handlers).
std::string run_contained(const std::string& what, const std::function<std::string()>& work, const ContainLimits& limits = {});

}  // namespace amhv
