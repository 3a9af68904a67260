// bench_http_load: many small requests against a running raycastd, to measure request
// overhead rather than tracing. C++ rather than Python because a Python client holding the GIL
// would measure itself: on this 2-core machine the load generator shares the cores with the
// server, so it must be cheap per request.
//
//   bench_http_load --port P --path /v1/scenes/ID/intersect --body-file F
//                   [--connections 16] [--seconds 5] [--content-type application/json]
//
// Opens `connections` keep-alive connections (TCP_NODELAY on), one thread each, and POSTs the
// same body in a loop until the time is up. Prints one JSON object:
//   {"requests": N, "ok": N, "errors": N, "seconds": S, "req_s": R, "statuses": {"200": N}}

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <httplib.h>
#include <nlohmann/json.hpp>

namespace {

struct Args {
    int port = 0;
    std::string path;
    std::string body;
    std::string content_type = "application/json";
    int connections = 16;
    double seconds = 5.0;
};

bool parse_args(int argc, char** argv, Args& a) {
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        const std::string value = i + 1 < argc ? argv[i + 1] : "";
        ++i;
        if (arg == "--port") {
            a.port = std::atoi(value.c_str());
        } else if (arg == "--path") {
            a.path = value;
        } else if (arg == "--body-file") {
            std::ifstream in(value, std::ios::binary);
            a.body.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
        } else if (arg == "--content-type") {
            a.content_type = value;
        } else if (arg == "--connections") {
            a.connections = std::atoi(value.c_str());
        } else if (arg == "--seconds") {
            a.seconds = std::atof(value.c_str());
        } else {
            std::fprintf(stderr, "bench_http_load: unknown argument %s\n", arg.c_str());
            return false;
        }
    }
    return a.port > 0 && !a.path.empty() && a.connections > 0 && a.seconds > 0.0;
}

}  // namespace

int main(int argc, char** argv) {
    Args args;
    if (!parse_args(argc, argv, args)) {
        std::fprintf(stderr,
                     "usage: bench_http_load --port P --path PATH --body-file F "
                     "[--connections N] [--seconds S] [--content-type T]\n");
        return 2;
    }
    std::atomic<bool> stop{false};
    std::mutex mu;
    std::map<int, long> statuses;  // HTTP status → count; -1: transport error
    std::vector<std::thread> threads;
    const auto start = std::chrono::steady_clock::now();
    for (int c = 0; c < args.connections; ++c) {
        threads.emplace_back([&] {
            httplib::Client client("127.0.0.1", args.port);
            client.set_keep_alive(true);
            client.set_tcp_nodelay(true);
            std::map<int, long> mine;
            while (!stop.load(std::memory_order_relaxed)) {
                auto res = client.Post(args.path.c_str(), args.body, args.content_type.c_str());
                ++mine[res ? res->status : -1];
            }
            std::lock_guard<std::mutex> lock(mu);
            for (const auto& [status, n] : mine)
                statuses[status] += n;
        });
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(args.seconds));
    stop = true;
    for (auto& t : threads)
        t.join();
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

    long total = 0;
    long ok = 0;
    nlohmann::json by_status = nlohmann::json::object();
    for (const auto& [status, n] : statuses) {
        total += n;
        if (status == 200)
            ok += n;
        by_status[std::to_string(status)] = n;
    }
    const nlohmann::json out = {{"requests", total},     {"ok", ok},
                                {"errors", total - ok},  {"seconds", elapsed},
                                {"req_s", ok / elapsed}, {"connections", args.connections},
                                {"statuses", by_status}};
    std::printf("%s\n", out.dump().c_str());
    return 0;
}
