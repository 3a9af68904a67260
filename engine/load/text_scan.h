#pragma once
// Internal to engine/load: the line and number scanning the text formats (OBJ, MTL, OFF, ASCII
// STL) share. Numbers are parsed with std::from_chars, which ignores the C locale (strtod would
// read "0,5" in a German locale).

#include <charconv>
#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

namespace raycastd::engine::detail {

/// Splits text into lines at "\n", "\r\n" or a lone "\r"; the last line may lack an ending.
class LineReader {
  public:
    explicit LineReader(std::string_view text) : text_(text) {}

    /// The next line without its ending; false at the end of the text.
    bool next(std::string_view& line) {
        if (pos_ >= text_.size())
            return false;
        const std::size_t end = text_.find_first_of("\r\n", pos_);
        if (end == std::string_view::npos) {
            line = text_.substr(pos_);
            pos_ = text_.size();
        } else {
            line = text_.substr(pos_, end - pos_);
            pos_ = end + 1;
            if (text_[end] == '\r' && pos_ < text_.size() && text_[pos_] == '\n')
                ++pos_;
        }
        ++number_;
        return true;
    }
    /// Offset of the first byte after the line last returned and its ending.
    std::size_t position() const { return pos_; }
    /// 1-based number of the line last returned.
    std::size_t number() const { return number_; }

  private:
    std::string_view text_;
    std::size_t pos_ = 0;
    std::size_t number_ = 0;
};

inline bool is_blank(char c) {
    return c == ' ' || c == '\t' || c == '\v' || c == '\f';
}

/// The whitespace-separated tokens of a line (after cutting a '#' comment when `comments`).
inline std::vector<std::string_view> tokens(std::string_view line, bool comments = true) {
    if (comments)
        line = line.substr(0, line.find('#'));
    std::vector<std::string_view> out;
    std::size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && is_blank(line[i]))
            ++i;
        std::size_t start = i;
        while (i < line.size() && !is_blank(line[i]))
            ++i;
        if (i > start)
            out.push_back(line.substr(start, i - start));
    }
    return out;
}

/// A whole token as a double ("1", "-.5", "+1e-05", "nan"); nullopt when it is not one.
inline std::optional<double> parse_double(std::string_view s) {
    if (!s.empty() && s[0] == '+')
        s.remove_prefix(1);
    double v = 0.0;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || end != s.data() + s.size() || s.empty())
        return std::nullopt;
    return v;
}

/// A whole token as a signed integer; nullopt when it is not one or overflows.
inline std::optional<std::int64_t> parse_int(std::string_view s) {
    if (!s.empty() && s[0] == '+')
        s.remove_prefix(1);
    std::int64_t v = 0;
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
    if (ec != std::errc() || end != s.data() + s.size() || s.empty())
        return std::nullopt;
    return v;
}

}  // namespace raycastd::engine::detail
