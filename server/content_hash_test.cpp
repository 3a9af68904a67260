// Content hashes: SHA-256 against the FIPS 180-4 example vectors, canonical JSON independent of
// key order, whitespace and number spelling, and scene ids that follow the files they read.

#include "server/content_hash.h"

#include <gtest/gtest.h>

namespace raycastd::server {
namespace {

TEST(ContentHash, Sha256KnownVectors) {
    // FIPS 180-4 examples (NIST CSRC "SHA256.pdf") and the empty string.
    EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
    EXPECT_EQ(sha256_hex("abc"),
              "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
    EXPECT_EQ(sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
              "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
    EXPECT_EQ(sha256_hex(std::string(1000000, 'a')),
              "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
    // Bytes, not C strings: a NUL inside counts.
    EXPECT_NE(sha256_hex(std::string_view("a\0b", 3)), sha256_hex("a"));
}

TEST(ContentHash, CanonicalJsonIgnoresKeyOrderWhitespaceAndNumberSpelling) {
    const Json a = Json::parse(R"({"b": [1, 2.0, {"y": 1, "x": 2}], "a": "s", "c": 2e0})");
    const Json b = Json::parse(R"({ "c":2, "a":"s",
                                    "b":[1.0,2,{"x":2.0,"y":1e0}] })");
    EXPECT_EQ(canonical_json(a), canonical_json(b));
    EXPECT_EQ(canonical_json(a), R"({"a":"s","b":[1.0,2.0,{"x":2.0,"y":1.0}],"c":2.0})");
    // Array order is meaning: objects are numbered in the order given.
    EXPECT_NE(canonical_json(Json::parse("[1,2]")), canonical_json(Json::parse("[2,1]")));
}

TEST(ContentHash, SceneRequestKeyIsCanonicalForDocumentsOnly) {
    const std::string doc1 = R"({"objects":[{"type":"sphere","center":[0,0,10],"radius":2}]})";
    const std::string doc2 =
        R"({ "objects" : [ {"radius":2.0,"center":[0,0,10],"type":"sphere"} ]})";
    EXPECT_EQ(scene_request_key("application/json", doc1),
              scene_request_key("application/json", doc2));
    // A model file is its bytes; the content type is part of the key.
    EXPECT_NE(scene_request_key("model/obj", "v 0 0 0\n"),
              scene_request_key("model/obj", "v 0 0 0 \n"));
    EXPECT_NE(scene_request_key("model/obj", doc1), scene_request_key("application/json", doc1));
    // A body that is not JSON is hashed as it is.
    EXPECT_NE(scene_request_key("application/json", "{oops"),
              scene_request_key("application/json", "{oops "));
    EXPECT_EQ(scene_request_key("application/json", doc1).size(), 64u);
}

TEST(ContentHash, SceneIdCoversTheFilesRead) {
    const std::string key = scene_request_key("application/json", R"({"objects":[]})");
    const std::string none = scene_id(key, {});
    EXPECT_EQ(none.rfind("sc_", 0), 0u);
    EXPECT_EQ(none.size(), 3u + 32u);
    const std::string one = scene_id(key, {{"a.obj", sha256_hex("v 0 0 0")}});
    const std::string changed = scene_id(key, {{"a.obj", sha256_hex("v 0 0 1")}});
    EXPECT_NE(one, none);
    EXPECT_NE(one, changed);
    EXPECT_EQ(one, scene_id(key, {{"a.obj", sha256_hex("v 0 0 0")}}));
}

TEST(ContentHash, SameSecretIsEquality) {
    EXPECT_TRUE(same_secret("s3cret", "s3cret"));
    EXPECT_FALSE(same_secret("s3cret", "s3creT"));
    EXPECT_FALSE(same_secret("s3cret", "s3cret "));
    EXPECT_FALSE(same_secret("", "x"));
    EXPECT_TRUE(same_secret("", ""));
}

}  // namespace
}  // namespace raycastd::server
