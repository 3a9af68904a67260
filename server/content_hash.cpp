#include "server/content_hash.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>

namespace raycastd::server {

namespace {

void numbers_as_doubles(Json& j) {
    if (j.is_number()) {
        j = j.get<double>();
    } else if (j.is_structured()) {
        for (auto& child : j)
            numbers_as_doubles(child);
    }
}

}  // namespace

bool same_secret(std::string_view a, std::string_view b) {
    unsigned char da[EVP_MAX_MD_SIZE], db[EVP_MAX_MD_SIZE];
    unsigned int la = 0, lb = 0;
    EVP_Digest(a.data(), a.size(), da, &la, EVP_sha256(), nullptr);
    EVP_Digest(b.data(), b.size(), db, &lb, EVP_sha256(), nullptr);
    return la == lb && CRYPTO_memcmp(da, db, la) == 0;
}

std::string sha256_hex(std::string_view bytes) {
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned int len = 0;
    EVP_Digest(bytes.data(), bytes.size(), md, &len, EVP_sha256(), nullptr);
    static const char kHex[] = "0123456789abcdef";
    std::string out;
    for (unsigned int i = 0; i < len; ++i) {
        out.push_back(kHex[md[i] >> 4]);
        out.push_back(kHex[md[i] & 15]);
    }
    return out;
}

std::string canonical_json(const Json& doc) {
    // nlohmann's object keeps its keys sorted (std::map), so dump() writes them in order.
    Json j = doc;
    numbers_as_doubles(j);
    return j.dump(-1, ' ', false, Json::error_handler_t::replace);
}

std::string scene_request_key(std::string_view content_type, std::string_view body) {
    std::string canonical;
    if (content_type == "application/json") {
        const std::optional<Json> doc = try_parse_json(body);
        canonical = doc ? canonical_json(*doc) : std::string(body);
    } else {
        canonical = std::string(body);
    }
    return sha256_hex("raycastd-scene-v1\n" + std::string(content_type) + "\n" + canonical);
}

std::string scene_id(const std::string& request_key,
                     const std::map<std::string, std::string>& file_sha) {
    std::string material = request_key;
    for (const auto& [path, sha] : file_sha)
        material += "\n" + path + "\n" + sha;
    return "sc_" + sha256_hex(material).substr(0, 32);
}

}  // namespace raycastd::server
