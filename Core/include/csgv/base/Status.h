// SPDX-License-Identifier: MIT
#pragma once
/// @file Status.h
/// @brief Errors as values: nothing in Core throws across its boundary, calls exit or aborts.

#include <cstdint>
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

} // namespace csgv
