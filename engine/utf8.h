#pragma once
// Text from model files made fit for JSON: names and messages taken from an OBJ, PLY, STL or
// OFF file are bytes in whatever encoding the exporter used (Latin-1 is common), and a JSON
// answer must be UTF-8 (RFC 8259 §8.1).

#include <string>
#include <string_view>

namespace raycastd::engine {

/// `text` with every byte sequence that is not well-formed UTF-8 (Unicode 15, table 3-7: no
/// overlong forms, no surrogates, nothing above U+10FFFF, no truncated sequence) replaced by
/// U+FFFD, one per maximal ill-formed subpart (§3.9, "U+FFFD Substitution of Maximal
/// Subparts"); well-formed text is returned unchanged.
std::string valid_utf8(std::string_view text);

}  // namespace raycastd::engine
