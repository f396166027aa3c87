// SPDX-License-Identifier: MIT
#pragma once
/// @file Status.h
/// @brief Errors as values: nothing in Core throws across its boundary, calls exit or aborts.

#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>

namespace csgv {

/// @brief Success, or one clear message naming what is wrong (file, brick, level, node, field).
class Status {
public:
    Status() = default;
    static Status ok() { return Status(); }
    static Status error(std::string message) {
        Status s;
        s.m_failed = true;
        s.m_message = std::move(message);
        return s;
    }
    bool isOk() const { return !m_failed; }
    explicit operator bool() const { return !m_failed; }
    const std::string& message() const { return m_message; }
    /// Prefixes the message with context, e.g. the file name.
    Status& prefix(const std::string& context) {
        if (m_failed) m_message = context + ": " + m_message;
        return *this;
    }

private:
    bool m_failed = false;
    std::string m_message;
};

/// @brief A value or an error message.
template <typename T>
class Result {
public:
    Result(T value) : m_value(std::move(value)) {}                 // NOLINT: implicit by design
    Result(Status status) : m_status(std::move(status)) {}          // NOLINT: implicit by design
    bool isOk() const { return m_status.isOk(); }
    explicit operator bool() const { return m_status.isOk(); }
    const Status& status() const { return m_status; }
    const std::string& message() const { return m_status.message(); }
    T& value() { return m_value; }
    const T& value() const { return m_value; }
    T& operator*() { return m_value; }
    const T& operator*() const { return m_value; }
    T* operator->() { return &m_value; }
    const T* operator->() const { return &m_value; }

private:
    T m_value{};
    Status m_status;
};

/// "12.5 MiB": memory figures in messages (host and device budgets alike).
std::string mebibytes(uint64_t bytes);

/// Quotes text from a file or a user for a message: bounded, with unprintable bytes (a NUL
/// included) escaped, so that a binary file named as NRRD, a BLOB label or a name of a megabyte
/// does not fill the message with garbage or cut it short.
inline std::string quotedText(const std::string& s, size_t maxChars = 60) {
    std::string out = "'";
    for (size_t i = 0; i < s.size() && i < maxChars; ++i) {
        const unsigned char c = static_cast<unsigned char>(s[i]);
        if (c >= 32 && c < 127) {
            out += char(c);
        } else {
            char buf[8];
            std::snprintf(buf, sizeof buf, "\\x%02x", c);
            out += buf;
        }
    }
    if (s.size() > maxChars) out += "...";
    return out + "'";
}

} // namespace csgv
