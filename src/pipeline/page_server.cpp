#include "src/pipeline/page_server.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <iostream>

#include <fmt/format.h>
#include <httplib.h>

#include "src/core/error.hpp"

namespace amhv::pipeline {

namespace fs = std::filesystem;

namespace {

constexpr std::size_t kMaxPath = 1024, kMaxComponents = 32;
constexpr off_t kMaxFile = off_t(1) << 30;

std::string content_type(const std::string& name) {
    const std::string ext = fs::path(name).extension().string();
    if (ext == ".html") return "text/html; charset=utf-8";
    if (ext == ".js") return "text/javascript; charset=utf-8";
    if (ext == ".json") return "application/json";
    if (ext == ".png") return "image/png";
    if (ext == ".glb") return "model/gltf-binary";
    if (ext == ".svg") return "image/svg+xml";
    if (ext == ".csv") return "text/csv; charset=utf-8";
    return "application/octet-stream";
}

ServeAnswer reason(int status, const char* text) { return {status, "text/plain; charset=utf-8", std::string(text) + "\n"}; }

// Whether the Host header names this machine: localhost, 127.0.0.1 or [::1], with this port or none.
bool host_is_local(const std::string& host, int port) {
    if (host.empty()) return true;  // HTTP/1.0 without Host: nothing to rebind
    std::string name = host, given_port;
    const std::size_t colon = host.rfind(':');
    if (colon != std::string::npos && host.find(']', colon) == std::string::npos) {
        name = host.substr(0, colon);
        given_port = host.substr(colon + 1);
    }
    std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (name != "localhost" && name != "127.0.0.1" && name != "[::1]") return false;
    return given_port.empty() || given_port == std::to_string(port);
}

// The path's components below the folder, or empty when the path is not one the server serves.
std::vector<std::string> components(const std::string& path) {
    if (path.empty() || path.front() != '/' || path.size() > kMaxPath) return {};
    if (path == "/") return {"index.html"};
    std::vector<std::string> parts;
    std::size_t at = 1;
    while (at <= path.size()) {
        const std::size_t slash = std::min(path.find('/', at), path.size());
        const std::string part = path.substr(at, slash - at);
        if (part.empty() || part.front() == '.' || part.find_first_of(std::string("\\\0", 2)) != std::string::npos) return {};
        parts.push_back(part);
        if (parts.size() > kMaxComponents) return {};
        at = slash + 1;
    }
    return parts;
}

// Opens the file below `dir_fd` one component at a time, never following a link; -1 when any step
// is missing, a link, or (at the end) not a regular file.
int open_below(int dir_fd, const std::vector<std::string>& parts) {
    int at = ::dup(dir_fd);
    for (std::size_t i = 0; at >= 0 && i < parts.size(); ++i) {
        const bool last = i + 1 == parts.size();
        const int next = ::openat(at, parts[i].c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC | O_NONBLOCK | (last ? 0 : O_DIRECTORY));
        ::close(at);
        at = next;
    }
    struct stat st {};
    if (at >= 0 && (::fstat(at, &st) != 0 || !S_ISREG(st.st_mode))) {
        ::close(at);
        return -1;
    }
    return at;
}

bool read_whole(int fd, std::string& out) {
    struct stat st {};
    if (::fstat(fd, &st) != 0 || st.st_size > kMaxFile) return false;
    out.resize(std::size_t(st.st_size));
    std::size_t got = 0;
    while (got < out.size()) {
        const ssize_t n = ::read(fd, out.data() + got, out.size() - got);
        if (n <= 0) return false;
        got += std::size_t(n);
    }
    return true;
}

}  // namespace

ServedFolder::ServedFolder(const fs::path& dir) : path_(dir) {
    fd_ = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd_ < 0) fail(dir.string(), "cannot open the folder to serve");
}

ServedFolder::~ServedFolder() {
    if (fd_ >= 0) ::close(fd_);
}

ServeAnswer answer_request(const ServedFolder& folder, const std::string& method, const std::string& path, const std::string& host, int port) {
    try {
        if (method != "GET" && method != "HEAD") return reason(405, "GET and HEAD only");
        if (!host_is_local(host, port)) return reason(403, "this server answers only requests addressed to this machine");
        const std::vector<std::string> parts = components(path);
        if (parts.empty()) return reason(404, "not found");
        const int fd = open_below(folder.fd(), parts);
        if (fd < 0) return reason(404, "not found");
        ServeAnswer answer{200, content_type(parts.back()), {}};
        const bool read = read_whole(fd, answer.body);
        ::close(fd);
        return read ? answer : reason(404, "not found");
    } catch (...) {
        return reason(500, "the server could not answer this request");
    }
}

void route_requests(httplib::Server& server, const ServedFolder& folder, int port) {
    server.new_task_queue = [] { return new httplib::ThreadPool(16); };
    server.set_read_timeout(5, 0);
    server.set_write_timeout(10, 0);
    server.set_keep_alive_timeout(2);
    server.set_keep_alive_max_count(20);
    server.set_payload_max_length(16 * 1024);
    auto handle = [&folder, port](const httplib::Request& request, httplib::Response& response, const char* method) {
        ServeAnswer answer = answer_request(folder, method, request.path, request.get_header_value("Host"), port);
        response.status = answer.status;
        if (answer.status == 405) response.set_header("Allow", "GET, HEAD");
        response.set_header("X-Content-Type-Options", "nosniff");
        response.set_header("Cache-Control", "no-store");
        response.set_content(std::move(answer.body), answer.content_type.c_str());
    };
    // GET (and HEAD, which the library answers with the GET handler and no body) is served; every
    // other method the library knows is answered 405 by the same decision.
    server.Get(".*", [handle](const httplib::Request& q, httplib::Response& r) { handle(q, r, q.method == "HEAD" ? "HEAD" : "GET"); });
    server.Post(".*", [handle](const httplib::Request& q, httplib::Response& r) { handle(q, r, "POST"); });
    server.Put(".*", [handle](const httplib::Request& q, httplib::Response& r) { handle(q, r, "PUT"); });
    server.Patch(".*", [handle](const httplib::Request& q, httplib::Response& r) { handle(q, r, "PATCH"); });
    server.Delete(".*", [handle](const httplib::Request& q, httplib::Response& r) { handle(q, r, "DELETE"); });
    server.Options(".*", [handle](const httplib::Request& q, httplib::Response& r) { handle(q, r, "OPTIONS"); });
    server.set_exception_handler([](const httplib::Request&, httplib::Response& response, std::exception_ptr) {
        response.status = 500;
        response.set_content("the server could not answer this request\n", "text/plain; charset=utf-8");
    });
}

void serve_folder(const fs::path& dir, int port) {
    if (port < 1 || port > 65535) throw Error(fmt::format("--serve: {} is not a port (1..65535)", port));
    const ServedFolder folder(dir);
    if (answer_request(folder, "GET", "/", "", port).status != 200) fail(dir.string(), "has no index.html to serve");
    httplib::Server server;
    route_requests(server, folder, port);
    if (!server.bind_to_port("127.0.0.1", port)) throw Error(fmt::format("--serve: cannot listen on 127.0.0.1:{} (in use?)", port));
    std::cout << fmt::format("serving {} at http://127.0.0.1:{}/ (Ctrl-C stops)", dir.string(), port) << std::endl;
    server.listen_after_bind();  // returns only when the listening socket itself fails
    throw Error(fmt::format("--serve: the server on 127.0.0.1:{} stopped listening", port));
}

}  // namespace amhv::pipeline
