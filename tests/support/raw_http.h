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
///
/// The head is looked for, and its Content-Length read, once per answer rather than once per
/// recv: reading the length by copying the rest of the buffer after each 4 KB recv made reading
/// an answer quadratic in its size, so that a loaded machine (load 8 on 2 cores) took longer to
/// read 4 MB than to compute it (Cancel.StreamedAnswerPastTheTimeLimitIsCutShort: a body cut
/// at 1 s by the server was still being read by the client at 10 s, and at 20 s with 32 MB).
inline std::string read_answer(int s, std::chrono::milliseconds timeout = std::chrono::seconds(5)) {
    std::string out;
    const auto until = std::chrono::steady_clock::now() + timeout;
    std::size_t head_end = std::string::npos;      ///< of the head, once it is complete
    std::size_t answer_bytes = std::string::npos;  ///< head + body, when it has a length
    char buf[64 * 1024];
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
        if (head_end == std::string::npos) {
            // The terminator may straddle two reads: look again from just before this one.
            const std::size_t from = out.size() - static_cast<std::size_t>(n);
            head_end = out.find("\r\n\r\n", from < 3 ? 0 : from - 3);
            if (head_end != std::string::npos) {
                const auto cl = out.find("Content-Length: ");
                if (cl != std::string::npos && cl < head_end)
                    answer_bytes = head_end + 4 + std::stoul(out.substr(cl + 16, 20));
            }
        }
        if (out.size() >= answer_bytes)
            break;
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
