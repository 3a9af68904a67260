#pragma once
// ServerProcess: runs the real raycastd binary on a free loopback port (--port 0), reads the
// port from its first line of output, and kills it (SIGKILL by default, like a crash) when the
// test is done. The binary's path comes from the RAYCASTD_BINARY compile definition.

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <httplib.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace raycastd::testing {

class ServerProcess {
  public:
    explicit ServerProcess(std::vector<std::string> extra_args = {}) {
        int out[2];
        if (pipe(out) != 0)
            throw std::runtime_error("pipe failed");
        std::vector<std::string> args = {RAYCASTD_BINARY, "--port", "0", "--threads", "4"};
        args.insert(args.end(), extra_args.begin(), extra_args.end());
        std::vector<char*> argv;
        for (auto& a : args)
            argv.push_back(a.data());
        argv.push_back(nullptr);
        posix_spawn_file_actions_t fa;
        posix_spawn_file_actions_init(&fa);
        posix_spawn_file_actions_adddup2(&fa, out[1], 1);
        posix_spawn_file_actions_addclose(&fa, out[0]);
        const int rc = posix_spawn(&pid_, argv[0], &fa, nullptr, argv.data(), environ);
        posix_spawn_file_actions_destroy(&fa);
        close(out[1]);
        if (rc != 0) {
            close(out[0]);
            throw std::runtime_error("cannot start " + args[0]);
        }
        // "raycastd listening on http://127.0.0.1:PORT\n"
        FILE* f = fdopen(out[0], "r");
        char line[256] = {0};
        if (!f || !std::fgets(line, sizeof line, f)) {
            if (f)
                std::fclose(f);
            stop();
            throw std::runtime_error("raycastd printed nothing (did it fail to start?)");
        }
        std::fclose(f);
        const std::string s(line);
        const auto colon = s.rfind(':');
        port_ = std::stoi(s.substr(colon + 1));
    }
    ~ServerProcess() { stop(); }
    ServerProcess(const ServerProcess&) = delete;
    ServerProcess& operator=(const ServerProcess&) = delete;

    int port() const { return port_; }
    pid_t pid() const { return pid_; }
    /// A keep-alive client for this server.
    std::unique_ptr<httplib::Client> client() const {
        auto c = std::make_unique<httplib::Client>("127.0.0.1", port_);
        c->set_read_timeout(120, 0);
        return c;
    }
    /// Kills the server with `sig` and waits for it; true if it was still running.
    bool stop(int sig = SIGKILL) {
        if (pid_ <= 0)
            return false;
        kill(pid_, sig);
        int status = 0;
        waitpid(pid_, &status, 0);
        pid_ = -1;
        return true;
    }
    /// True while the process has not exited.
    bool alive() {
        if (pid_ <= 0)
            return false;
        int status = 0;
        return waitpid(pid_, &status, WNOHANG) == 0;
    }

  private:
    pid_t pid_ = -1;
    int port_ = 0;
};

}  // namespace raycastd::testing
