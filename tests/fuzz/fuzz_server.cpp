// Fuzz target: one connection's bytes through the page server (cpp-httplib's request parser and
// amhv's routing, answer_request), on a folder with a page, a subfolder, a hidden file and a link
// out of it. The server's answer goes to a sink; it must never throw, crash or serve a file outside.
#include <httplib.h>

#include "src/pipeline/page_server.hpp"
#include "tests/fuzz/fuzz_support.hpp"

namespace {

class MemoryStream final : public httplib::Stream {
public:
    MemoryStream(const std::uint8_t* data, std::size_t size) : data_(reinterpret_cast<const char*>(data)), size_(size) {}
    bool is_readable() const override { return true; }
    bool is_writable() const override { return true; }
    ssize_t read(char* ptr, size_t size) override {
        const std::size_t n = std::min(size, size_ - at_);
        std::copy(data_ + at_, data_ + at_ + n, ptr);
        at_ += n;
        return ssize_t(n);
    }
    ssize_t write(const char* ptr, size_t size) override {
        if (written_.size() < (1u << 20)) written_.append(ptr, std::min<std::size_t>(size, (1u << 20) - written_.size()));
        return ssize_t(size);
    }
    const std::string& written() const { return written_; }
    void get_remote_ip_and_port(std::string& ip, int& port) const override { ip = "127.0.0.1", port = 40000; }
    void get_local_ip_and_port(std::string& ip, int& port) const override { ip = "127.0.0.1", port = 8080; }
    socket_t socket() const override { return 0; }

private:
    const char* data_;
    std::size_t size_, at_ = 0;
    std::string written_;
};

class FuzzedServer final : public httplib::Server {
public:
    void serve(httplib::Stream& stream) {
        bool closed = false;
        for (int request = 0; request < 4 && !closed; ++request)
            if (!process_request(stream, request == 3, closed, nullptr)) break;
    }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace amhv;
    static const std::filesystem::path dir = [] {
        const std::filesystem::path d = fuzz::folder() / "page";
        fuzz::write_input("page/index.html", reinterpret_cast<const std::uint8_t*>("<html></html>"), 13);
        fuzz::write_input("page/view/data.js", reinterpret_cast<const std::uint8_t*>("x=1;"), 4);
        fuzz::write_input("page/.amhv-output", reinterpret_cast<const std::uint8_t*>("{}"), 2);
        fuzz::write_input("secret", reinterpret_cast<const std::uint8_t*>("secret"), 6);
        std::error_code ec;
        std::filesystem::create_symlink("../secret", d / "link", ec);
        return d;
    }();
    static const pipeline::ServedFolder folder(dir);
    static FuzzedServer server;
    static const bool routed = [] {
        pipeline::route_requests(server, folder, 8080);
        return true;
    }();
    (void)routed;
    MemoryStream stream(data, size);
    server.serve(stream);
    // The file beside the folder (reachable only through the link, or a path out of the folder)
    // and the hidden marker must never be served.
    if (stream.written().find("secret") != std::string::npos || stream.written().find("\r\n\r\n{}") != std::string::npos) __builtin_trap();
    return 0;
}
