// raycastd: parse flags, build the App, listen; SIGINT/SIGTERM stop it cleanly. With
// --health-check it serves nothing and asks a running server whether it is healthy.

#include <atomic>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <thread>

#include <pthread.h>
#include <signal.h>

#include "server/app.h"
#include "server/malloc_tuning.h"

namespace {

/// --health-check: 0 when the server at `c`'s address answers GET /v1/health with 200.
int health_check(const raycastd::server::Config& c) {
    // A server listening on every address is reached on loopback.
    const std::string host = c.host == "0.0.0.0" ? "127.0.0.1" : c.host == "::" ? "::1" : c.host;
    httplib::Client client(host, c.port);
    client.set_connection_timeout(3, 0);
    client.set_read_timeout(3, 0);
    const auto res = client.Get("/v1/health");
    if (res && res->status == 200)
        return 0;
    std::cerr << "raycastd: health check of " << host << ":" << c.port << " failed: "
              << (res ? "HTTP " + std::to_string(res->status) : httplib::to_string(res.error()))
              << "\n";
    return 1;
}

}  // namespace

int main(int argc, char** argv) {
    std::string message;
    bool error = false;
    auto config = raycastd::server::parse_args(argc, argv, message, error);
    if (!config) {
        (error ? std::cerr : std::cout) << message;
        return error ? 2 : 0;
    }
    if (config->health_check)
        return health_check(*config);
    // Before any thread starts: a fresh server's first render had paid twice its time in
    // trimmed and refaulted heap pages (server/malloc_tuning.cpp).
    raycastd::server::tune_malloc();
    // A client that hangs up mid-response, or a closed stdout, must not end the server.
    std::signal(SIGPIPE, SIG_IGN);
    // SIGINT/SIGTERM are taken by one thread with sigwait (blocked everywhere else, so every
    // thread started from here inherits the mask). A signal that arrives before the server is
    // listening is not lost: the watcher keeps asking it to stop until it has.
    sigset_t stop_signals;
    sigemptyset(&stop_signals);
    sigaddset(&stop_signals, SIGINT);
    sigaddset(&stop_signals, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);

    raycastd::server::App app(*config);
    std::string startup_error;
    if (!app.start(startup_error)) {
        std::cerr << "raycastd: " << startup_error << "\n";
        return 1;
    }
    const int port = app.bind();
    if (port < 0) {
        std::cerr << "raycastd: cannot listen on " << config->host << ":" << config->port << "\n";
        return 1;
    }
    std::atomic<bool> done{false};
    std::thread watcher([&] {
        int sig = 0;
        sigwait(&stop_signals, &sig);
        while (!done) {
            app.stop();
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
        }
    });
    if (!raycastd::server::is_loopback_host(config->host) && config->token.empty()) {
        std::cerr << "raycastd: WARNING: listening on " << config->host
                  << " without --token: anyone who can reach this port can register and delete "
                     "scenes. Set --token or RAYCASTD_TOKEN, or bind to 127.0.0.1.\n";
    }
    std::printf("raycastd listening on http://%s:%d\n", config->host.c_str(), port);
    std::fflush(stdout);
    const bool ok = app.listen_after_bind();
    done = true;
    // Wake the watcher if no signal came (listening failed): it ends once `done` is seen.
    pthread_kill(watcher.native_handle(), SIGTERM);
    watcher.join();
    return ok ? 0 : 1;
}
