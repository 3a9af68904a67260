#include "engine/utf8.h"

#include <gtest/gtest.h>

namespace raycastd::engine {
namespace {

const std::string kFffd = "\xEF\xBF\xBD";

TEST(Utf8, WellFormedTextIsKept) {
    for (const std::string s : {"", "spider.mtl", "caf\xC3\xA9", "\xE2\x82\xAC 5",
                                "\xF0\x9F\x90\x9E", "\xF4\x8F\xBF\xBF", "\xED\x9F\xBF"}) {
        EXPECT_EQ(valid_utf8(s), s);
    }
}

TEST(Utf8, IllFormedSequencesBecomeReplacementCharacters) {
    // Latin-1 "café"; a lone continuation byte; C0/C1 and F5 leads; an overlong "/" (C0 AF);
    // a surrogate (ED A0 80); above U+10FFFF (F4 90 80 80); a sequence cut short by the end or
    // by an ASCII byte, replaced as one maximal subpart (Unicode §3.9).
    EXPECT_EQ(valid_utf8("caf\xE9.mtl"), "caf" + kFffd + ".mtl");
    EXPECT_EQ(valid_utf8("a\x80"
                         "b"),
              "a" + kFffd + "b");
    EXPECT_EQ(valid_utf8("\xC0\xAF"), kFffd + kFffd);
    EXPECT_EQ(valid_utf8("\xF5\x80"), kFffd + kFffd);
    EXPECT_EQ(valid_utf8("\xED\xA0\x80"), kFffd + kFffd + kFffd);
    EXPECT_EQ(valid_utf8("\xF4\x90\x80\x80"), kFffd + kFffd + kFffd + kFffd);
    EXPECT_EQ(valid_utf8("\xE2\x82"), kFffd);
    EXPECT_EQ(valid_utf8("\xE2\x82x"), kFffd + "x");
    EXPECT_EQ(valid_utf8("\xF0\x9F\x90"), kFffd);
}

}  // namespace
}  // namespace raycastd::engine
