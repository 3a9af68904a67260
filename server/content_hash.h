#pragma once
// Content hashes: what makes two requests the same scene. A scene's id covers its canonical
// request and every file it read, so posting the same thing twice gives the same id, and a
// changed file gives a new one; the stateless calls' scene cache is keyed the same way.

#include <map>
#include <string>
#include <string_view>

#include "server/schema/json_read.h"

namespace raycastd::server {

/// Lower-case hex SHA-256 (FIPS 180-4) of the bytes: 64 characters.
std::string sha256_hex(std::string_view bytes);

/// Whether two secrets are equal, in time independent of where they differ and of their
/// lengths: their SHA-256 digests are compared with OpenSSL's constant-time CRYPTO_memcmp.
bool same_secret(std::string_view a, std::string_view b);

/// The document with sorted keys and every number as a double, so that "2", "2.0" and "2e0"
/// (and any key order or whitespace) serialise alike.
std::string canonical_json(const Json& doc);

/// The hash of a scene request in canonical form: a scene document ("application/json")
/// re-serialised by canonical_json, a model file as its bytes. A document that is not JSON is
/// hashed as its bytes (its build reports the error).
std::string scene_request_key(std::string_view content_type, std::string_view body);

/// "sc_" + the first 128 bits, in hex, of the SHA-256 over `request_key` and every file the
/// scene read (its path and the SHA-256 of its bytes, in path order).
std::string scene_id(const std::string& request_key,
                     const std::map<std::string, std::string>& file_sha);

}  // namespace raycastd::server
