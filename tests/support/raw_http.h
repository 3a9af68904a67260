#pragma once
// Raw HTTP over a loopback socket, for tests that must send what no HTTP client library
// sends (a lying Content-Length, a head that never ends, a half-closed connection) and read
// exactly what the server answers.

#include <chrono>
#include <cstdint>
#include <string>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

namespace raycastd::testing {

/// A connected socket to 127.0.0.1:port, or −1.
inline int connect_loopback(int port) {
    const int s = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::connect(s, reinterpret_cast<sockaddr*>(&a), sizeof(a)) != 0) {
        ::close(s);
        return -1;
    }
    return s;
}

inline void send_all(int s, const std::string& bytes) {
    std::size_t sent = 0;
    while (sent < bytes.size()) {
        const ssize_t n = ::send(s, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
        if (n <= 0)
            return;
        sent += static_cast<std::size_t>(n);
    }
}

/// What the server sends until it closes, `timeout` passes, or one answer with a
/// Content-Length is complete.
inline std::string read_answer(int s, std::chrono::milliseconds timeout = std::chrono::seconds(5)) {
    std::string out;
    const auto until = std::chrono::steady_clock::now() + timeout;
    char buf[4096];
    for (;;) {
        const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                              until - std::chrono::steady_clock::now())
                              .count();
        if (left <= 0)
            break;
        pollfd p{s, POLLIN, 0};
        if (::poll(&p, 1, static_cast<int>(left)) <= 0)
            break;
        const ssize_t n = ::recv(s, buf, sizeof(buf), 0);
        if (n <= 0)
            break;
        out.append(buf, static_cast<std::size_t>(n));
        const auto head_end = out.find("\r\n\r\n");
        const auto cl = out.find("Content-Length: ");
        if (head_end != std::string::npos && cl != std::string::npos && cl < head_end) {
            const std::size_t len = std::stoul(out.substr(cl + 16));
            if (out.size() >= head_end + 4 + len)
                break;
        }
    }
    return out;
}

/// Sends `request` on a fresh connection and reads one answer.
inline std::string exchange(int port, const std::string& request,
                            std::chrono::milliseconds timeout = std::chrono::seconds(5)) {
    const int s = connect_loopback(port);
    send_all(s, request);
    std::string answer = read_answer(s, timeout);
    ::close(s);
    return answer;
}

/// The status code of an answer ("HTTP/1.1 414 ..." → 414), 0 for no answer.
inline int status_of(const std::string& answer) {
    return answer.size() > 12 && answer.rfind("HTTP/1.", 0) == 0 ? std::stoi(answer.substr(9, 3))
                                                                 : 0;
}

/// The body of an answer (after the blank line).
inline std::string body_of(const std::string& answer) {
    const auto at = answer.find("\r\n\r\n");
    return at == std::string::npos ? std::string() : answer.substr(at + 4);
}

}  // namespace raycastd::testing
