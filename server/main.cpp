// raycastd: parse flags, build the App, listen.

#include <csignal>
#include <cstdio>
#include <iostream>

#include "server/app.h"

namespace {

raycastd::server::App* g_app = nullptr;

void on_signal(int) {
    if (g_app) g_app->stop();
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
    g_app = &app;
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    // A client that hangs up mid-response, or a closed stdout, must not end the server.
    std::signal(SIGPIPE, SIG_IGN);
    std::printf("raycastd listening on http://%s:%d\n", config->host.c_str(), port);
    std::fflush(stdout);
    return app.listen_after_bind() ? 0 : 1;
}
