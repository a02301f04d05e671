#include "src/core/contained.hpp"

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <new>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include "src/core/error.hpp"
#include "src/core/sanitizers.hpp"

namespace amhv {

namespace {

// Writes all of `bytes` to `fd`; false when the pipe is gone.
bool write_all(int fd, const std::string& bytes) {
    std::size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) return false;
        done += std::size_t(n);
    }
    return true;
}

// The process's mapped address space in bytes (/proc/self/statm's first field, in pages); 0 when
// unknown.
std::size_t mapped_bytes() {
    std::FILE* statm = std::fopen("/proc/self/statm", "r");
    if (!statm) return 0;
    unsigned long pages = 0;
    const int read = std::fscanf(statm, "%lu", &pages);
    std::fclose(statm);
    return read == 1 ? std::size_t(pages) * std::size_t(::sysconf(_SC_PAGESIZE)) : 0;
}

// The child: limits, the work, then one status byte ('R' result, 'E' error) and the payload.
[[noreturn]] void child(int fd, const std::function<std::string()>& work, const ContainLimits& limits) {
    // A fault ends the child by its signal, whatever handler the parent has (a sanitizer's report
    // and exit included): the parent names the signal. Interrupts end it as they end the parent.
    for (const int s : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT, SIGPIPE, SIGINT, SIGTERM}) ::signal(s, SIG_DFL);
    ::alarm(limits.seconds);
    const rlimit no_core{0, 0};  // a crash leaves no core file behind
    ::setrlimit(RLIMIT_CORE, &no_core);
#ifndef AMHV_ASAN  // AddressSanitizer reserves terabytes of address space for its shadow
    // On top of what the parent had mapped when it forked (a GPU driver's reservations included).
    const rlim_t cap = rlim_t(mapped_bytes() + limits.memory_bytes);
    const rlimit memory{cap, cap};
    ::setrlimit(RLIMIT_AS, &memory);
#endif
    std::string out;
    try {
        const std::string result = work();
        out.reserve(result.size() + 1);
        out.push_back('R');
        out.append(result);
    } catch (const std::bad_alloc&) {
        out = "Eneeds more memory than the reader may take";
    } catch (const Error& e) {
        out = "F";
        out.append(e.what());
    } catch (...) {  // a library's own exception: its text is not shown (docs/scenes.md)
        out = "Ethe reader failed on it";
    }
    ::_exit(write_all(fd, out) ? 0 : 3);
}

std::string signal_name(int signal) {
    switch (signal) {
        case SIGSEGV: return "a segmentation fault (SIGSEGV)";
        case SIGBUS: return "a bus error (SIGBUS)";
        case SIGABRT: return "an abort (SIGABRT)";
        case SIGFPE: return "an arithmetic fault (SIGFPE)";
        case SIGILL: return "an illegal instruction (SIGILL)";
        case SIGKILL: return "SIGKILL (out of memory?)";
        default: return fmt::format("signal {}", signal);
    }
}

}  // namespace

std::string run_contained(const std::string& what, const std::function<std::string()>& work, const ContainLimits& limits) {
    int fds[2];
    if (::pipe(fds) != 0) fail(what, "cannot make a pipe for its reader: {}", std::strerror(errno));
    const pid_t pid = ::fork();
    if (pid < 0) {
        ::close(fds[0]), ::close(fds[1]);
        fail(what, "cannot start its reader: {}", std::strerror(errno));
    }
    if (pid == 0) {
        ::close(fds[0]);
        child(fds[1], work, limits);
    }
    ::close(fds[1]);
    std::string bytes;
    char buffer[1 << 16];
    for (;;) {
        const ssize_t n = ::read(fds[0], buffer, sizeof buffer);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break;
        bytes.append(buffer, std::size_t(n));
    }
    ::close(fds[0]);
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    if (WIFSIGNALED(status)) {
        if (WTERMSIG(status) == SIGALRM) fail(what, "its reader took over {} s and was stopped", limits.seconds);
        fail(what, "cannot be read: the reader (assimp) crashed on it with {}; the file is malformed or of a kind it mishandles",
             signal_name(WTERMSIG(status)));
    }
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || bytes.empty())
        fail(what, "cannot be read: the reader (assimp) stopped on it without an answer (exit status {})", WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    if (bytes[0] == 'F') throw Error(bytes.substr(1));
    if (bytes[0] == 'E') fail(what, "cannot be read: {}", bytes.substr(1));
    return bytes.substr(1);
}

}  // namespace amhv
