#pragma once
// `amhv view DIR --serve PORT`: a read-only web server for one output folder, on this machine only
// (docs/scenes.md, "The page"). It is cpp-httplib (Debian's libcpp-httplib: a thread pool, read and
// write timeouts, bounded requests, every handler's exception caught) with one decision of amhv's
// own in front of every file, `answer_request`:
//   - GET and HEAD only (405 otherwise); a Host header, when sent, must name this machine
//     (localhost, 127.0.0.1 or [::1], with the server's port if any): a web page elsewhere cannot
//     reach the server by DNS rebinding (403);
//   - the path must be relative to the folder: no empty component (so no "//x", which would be
//     absolute), no "." or "..", no backslash, no NUL, nothing hidden (".name"), at most 32
//     components and 1024 bytes; "/" is index.html;
//   - the file is opened component by component below the folder with O_NOFOLLOW: a symbolic link
//     anywhere below it is never followed (404), and only a regular file is served (no FIFO,
//     device or folder), up to 1 GiB.
#include <filesystem>
#include <string>

namespace httplib {
class Server;
}

namespace amhv::pipeline {

// The folder served: its path and an open descriptor of it, taken when the server starts.
class ServedFolder {
public:
    explicit ServedFolder(const std::filesystem::path& dir);
    ~ServedFolder();
    ServedFolder(const ServedFolder&) = delete;
    ServedFolder& operator=(const ServedFolder&) = delete;
    int fd() const { return fd_; }
    const std::filesystem::path& path() const { return path_; }

private:
    std::filesystem::path path_;
    int fd_ = -1;
};

struct ServeAnswer {
    int status = 404;
    std::string content_type = "text/plain; charset=utf-8";
    std::string body;  // the file, or a one-line reason
};

// The server's decision for one request: `method`, the decoded `path` (as the HTTP library gives
// it), the Host header (`host`, empty when none) and the server's `port`. Never throws.
ServeAnswer answer_request(const ServedFolder& folder, const std::string& method, const std::string& path, const std::string& host, int port);

// Sets `server`'s limits (timeouts, request size, 16 threads) and routes every method to
// answer_request on `folder` (the server of serve_folder, and of the request fuzzer).
void route_requests(httplib::Server& server, const ServedFolder& folder, int port);

// Serves `dir` on 127.0.0.1:`port` until the process is stopped; a request never stops it.
[[noreturn]] void serve_folder(const std::filesystem::path& dir, int port);

}  // namespace amhv::pipeline
