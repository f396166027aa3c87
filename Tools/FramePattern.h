// SPDX-License-Identifier: MIT
#pragma once
/// @file FramePattern.h
/// @brief The file-name pattern of `csgv render --video` (`frame_%04d.png`), parsed once and
/// formatted by us: a user's pattern is never handed to printf, where `%s` or `%n` would read or
/// write memory the tool does not own.

#include "csgv/base/Status.h"

#include <cstdint>
#include <string>

namespace csgv {

/// @brief Exactly one integer conversion (`%d`, `%Nd`, `%0Nd`, width up to 9) and `%%` for a
/// percent sign; everything else in the pattern is literal.
struct FramePattern {
    std::string prefix, suffix;
    uint32_t width = 0;
    bool zeroPad = false;

    static Result<FramePattern> parse(const std::string& pattern) {
        FramePattern p;
        bool seen = false;
        const auto refuse = [&pattern](const std::string& why) {
            return Status::error("--video pattern '" + pattern + "' " + why +
                                 " (it takes exactly one %d or %0Nd, such as frame_%04d.png, and %% for a percent sign)");
        };
        for (size_t i = 0; i < pattern.size(); ++i) {
            std::string& out = seen ? p.suffix : p.prefix;
            if (pattern[i] != '%') {
                out += pattern[i];
                continue;
            }
            if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
                out += '%';
                ++i;
                continue;
            }
            size_t j = i + 1;
            const bool zero = j < pattern.size() && pattern[j] == '0';
            if (zero) ++j;
            uint32_t width = 0;
            size_t digits = 0;
            for (; j < pattern.size() && pattern[j] >= '0' && pattern[j] <= '9'; ++j, ++digits)
                width = width * 10 + uint32_t(pattern[j] - '0');
            if (digits > 1 || width > 9) return refuse("has a field width above 9 at position " + std::to_string(i));
            if (j >= pattern.size() || pattern[j] != 'd')
                return refuse("has the conversion '" + pattern.substr(i, std::min<size_t>(j + 1, pattern.size()) - i) +
                              "' at position " + std::to_string(i));
            if (seen) return refuse("has a second conversion at position " + std::to_string(i));
            seen = true;
            p.zeroPad = zero;
            p.width = width;
            i = j;
        }
        if (!seen) return refuse("has no %d");
        return p;
    }

    std::string format(uint64_t n) const {
        std::string digits = std::to_string(n);
        if (digits.size() < width) digits.insert(0, width - digits.size(), zeroPad ? '0' : ' ');
        return prefix + digits + suffix;
    }
};

} // namespace csgv
