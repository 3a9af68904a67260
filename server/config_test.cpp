#include "server/config.h"

#include <sstream>

#include <gtest/gtest.h>
#include <sys/resource.h>

namespace raycastd::server {
namespace {

std::optional<Config> parse(std::vector<std::string> args, std::string& msg, bool& error) {
    std::vector<char*> argv = {const_cast<char*>("raycastd")};
    for (auto& a : args)
        argv.push_back(a.data());
    return parse_args(static_cast<int>(argv.size()), argv.data(), msg, error);
}

TEST(Config, DefaultsAndFlags) {
    std::string msg;
    bool error = false;
    auto c = parse({"--port", "0", "--threads", "3", "--max-rays", "10", "--demo", "a.json",
                    "--demo", "b.json", "--access-log"},
                   msg, error);
    ASSERT_TRUE(c);
    EXPECT_EQ(c->host, "127.0.0.1");
    EXPECT_EQ(c->port, 0);
    EXPECT_EQ(c->threads, 3);
    EXPECT_EQ(c->limits.max_rays, 10u);
    EXPECT_EQ(c->demo.size(), 2u);
    EXPECT_EQ(c->log_level, LogLevel::info);
}

// Every flag --help lists with a number is taken with one (--request-timeout-s and then
// --max-points were once listed but refused as unknown: the list of numeric flags is separate).
TEST(Config, EveryNumericFlagOfTheHelpIsAccepted) {
    std::istringstream help(usage());
    int seen = 0;
    for (std::string line; std::getline(help, line);) {
        std::istringstream words(line);
        std::string flag, value;
        words >> flag >> value;
        if (flag.rfind("--", 0) != 0 || value != "N")
            continue;
        ++seen;
        std::string msg;
        bool error = false;
        EXPECT_TRUE(parse({flag, "1"}, msg, error)) << flag << ": " << msg;
    }
    EXPECT_GE(seen, 13);  // the test reads the help it checks
}

TEST(Config, AnswerAndJobBudgets) {
    std::string msg;
    bool error = false;
    auto d = parse({}, msg, error);
    ASSERT_TRUE(d);
    EXPECT_EQ(d->limits.answer_budget_bytes, 2ull << 30);
    EXPECT_EQ(d->limits.job_budget_bytes, 512ull << 20);
    auto c = parse({"--answer-budget-mb", "3", "--job-budget-mb", "5"}, msg, error);
    ASSERT_TRUE(c) << msg;
    EXPECT_EQ(c->limits.answer_budget_bytes, 3u << 20);
    EXPECT_EQ(c->limits.job_budget_bytes, 5u << 20);
    ::setenv("RAYCASTD_ANSWER_BUDGET_MB", "7", 1);
    EXPECT_EQ(parse({}, msg, error)->limits.answer_budget_bytes, 7u << 20);
    ::unsetenv("RAYCASTD_ANSWER_BUDGET_MB");
}

TEST(Config, MaxConnectionsIsBoundByThreadsNotFdSetsize) {
    std::string msg;
    bool error = false;
    auto c = parse({"--max-connections", "4096"}, msg, error);
    ASSERT_TRUE(c) << msg;
    EXPECT_EQ(c->threads, 4096);
    EXPECT_TRUE(parse({"--max-connections", std::to_string(kMaxConnections)}, msg, error));
    EXPECT_FALSE(parse({"--max-connections", std::to_string(kMaxConnections + 1)}, msg, error));
    EXPECT_TRUE(error);
}

TEST(Config, ReserveDescriptorsRaisesTheSoftLimitUpToTheHardOne) {
    rlimit before{};
    ASSERT_EQ(::getrlimit(RLIMIT_NOFILE, &before), 0);
    if (before.rlim_max != RLIM_INFINITY && before.rlim_max < 2048 + kReservedDescriptors)
        GTEST_SKIP() << "the hard descriptor limit is " << before.rlim_max;
    rlimit low = before;
    low.rlim_cur = 1024;
    ASSERT_EQ(::setrlimit(RLIMIT_NOFILE, &low), 0);
    std::string error;
    EXPECT_TRUE(reserve_descriptors(2048, error)) << error;
    rlimit now{};
    ::getrlimit(RLIMIT_NOFILE, &now);
    EXPECT_EQ(now.rlim_cur, 2048 + kReservedDescriptors);
    if (before.rlim_max != RLIM_INFINITY) {
        // More than the hard limit allows: refused, naming both figures.
        EXPECT_FALSE(reserve_descriptors(before.rlim_max, error));
        EXPECT_NE(error.find(std::to_string(before.rlim_max)), std::string::npos) << error;
    }
    ::setrlimit(RLIMIT_NOFILE, &before);
}

TEST(Config, HelpAndErrors) {
    std::string msg;
    bool error = false;
    EXPECT_FALSE(parse({"--help"}, msg, error));
    EXPECT_FALSE(error);
    EXPECT_NE(msg.find("--scene-root"), std::string::npos);
    EXPECT_FALSE(parse({"--port", "http"}, msg, error));
    EXPECT_TRUE(error);
    EXPECT_FALSE(parse({"--port", "70000"}, msg, error));
    EXPECT_TRUE(error);
    EXPECT_FALSE(parse({"--bogus", "1"}, msg, error));
    EXPECT_TRUE(error);
    // An unknown flag is called unknown whatever its value (it was "needs a whole number").
    EXPECT_FALSE(parse({"--bogus", "x"}, msg, error));
    EXPECT_NE(msg.find("unknown option --bogus"), std::string::npos) << msg;
    EXPECT_FALSE(parse({"--token", ""}, msg, error));
    EXPECT_TRUE(error);
    EXPECT_FALSE(parse({"--port"}, msg, error));
    EXPECT_TRUE(error);
}

TEST(Config, TokenFromTheFlagOrTheEnvironment) {
    std::string msg;
    bool error = false;
    ::unsetenv("RAYCASTD_TOKEN");
    EXPECT_EQ(parse({}, msg, error)->token, "");
    EXPECT_EQ(parse({"--token", "s3cret"}, msg, error)->token, "s3cret");
    ::setenv("RAYCASTD_TOKEN", "from-env", 1);
    EXPECT_EQ(parse({}, msg, error)->token, "from-env");
    EXPECT_EQ(parse({"--token", "flag-wins"}, msg, error)->token, "flag-wins");
    ::unsetenv("RAYCASTD_TOKEN");
}

TEST(Config, LogLevel) {
    std::string msg;
    bool error = false;
    ::unsetenv("RAYCASTD_LOG_LEVEL");
    EXPECT_EQ(parse({}, msg, error)->log_level, LogLevel::info);
    EXPECT_EQ(parse({"--log-level", "debug"}, msg, error)->log_level, LogLevel::debug);
    EXPECT_EQ(parse({"--log-level", "error"}, msg, error)->log_level, LogLevel::error);
    EXPECT_FALSE(parse({"--log-level", "verbose"}, msg, error));
    EXPECT_TRUE(error);
    EXPECT_NE(msg.find("error, warn, info or debug"), std::string::npos) << msg;
    ::setenv("RAYCASTD_LOG_LEVEL", "warn", 1);
    EXPECT_EQ(parse({}, msg, error)->log_level, LogLevel::warn);
    EXPECT_EQ(parse({"--log-level", "info"}, msg, error)->log_level, LogLevel::info);
    ::unsetenv("RAYCASTD_LOG_LEVEL");
}

TEST(Config, LimitsFromTheEnvironment) {
    std::string msg;
    bool error = false;
    EXPECT_EQ(env_name("--max-rays"), "RAYCASTD_MAX_RAYS");
    EXPECT_EQ(env_name("--memory-budget-mb"), "RAYCASTD_MEMORY_BUDGET_MB");
    ::setenv("RAYCASTD_MAX_RAYS", "1234", 1);
    ::setenv("RAYCASTD_MEMORY_BUDGET_MB", "2", 1);
    ::setenv("RAYCASTD_DATA_DIR", "/data", 1);
    auto c = parse({}, msg, error);
    ASSERT_TRUE(c) << msg;
    EXPECT_EQ(c->limits.max_rays, 1234u);
    EXPECT_EQ(c->limits.memory_budget_bytes, 2u << 20);
    EXPECT_EQ(c->data_dir, "/data");
    EXPECT_EQ(parse({"--max-rays", "7"}, msg, error)->limits.max_rays, 7u);  // the flag wins
    // A bad value is refused with the variable's name, as a bad flag is.
    ::setenv("RAYCASTD_MAX_RAYS", "lots", 1);
    EXPECT_FALSE(parse({}, msg, error));
    EXPECT_TRUE(error);
    EXPECT_NE(msg.find("RAYCASTD_MAX_RAYS=lots"), std::string::npos) << msg;
    ::unsetenv("RAYCASTD_MAX_RAYS");
    ::unsetenv("RAYCASTD_MEMORY_BUDGET_MB");
    ::unsetenv("RAYCASTD_DATA_DIR");
    // An empty RAYCASTD_TOKEN is no token (a template's blank), not an error.
    ::setenv("RAYCASTD_TOKEN", "", 1);
    auto open = parse({}, msg, error);
    ASSERT_TRUE(open) << msg;
    EXPECT_EQ(open->token, "");
    ::unsetenv("RAYCASTD_TOKEN");
}

TEST(Config, LoopbackHosts) {
    for (const char* h : {"127.0.0.1", "127.1.2.3", "localhost", "::1"})
        EXPECT_TRUE(is_loopback_host(h)) << h;
    for (const char* h : {"0.0.0.0", "::", "10.0.0.1", "192.168.1.2", "example.org"})
        EXPECT_FALSE(is_loopback_host(h)) << h;
}

TEST(Config, RequestTimeout) {
    std::string msg;
    bool error = false;
    auto none = parse({}, msg, error);
    ASSERT_TRUE(none);
    EXPECT_EQ(none->limits.request_timeout_s, 0u);  // no limit by default
    auto c = parse({"--request-timeout-s", "30"}, msg, error);
    ASSERT_TRUE(c);
    EXPECT_EQ(c->limits.request_timeout_s, 30u);
    EXPECT_FALSE(parse({"--request-timeout-s", "-1"}, msg, error));
    EXPECT_TRUE(error);
    EXPECT_FALSE(parse({"--request-timeout-s", "100000"}, msg, error));
    EXPECT_TRUE(error);
}

}  // namespace
}  // namespace raycastd::server
