// SPDX-License-Identifier: MIT
#pragma once
/// @file Words.h
/// @brief 32-bit words at any byte address: loadWord and WordPtr, a pointer-like reader.
///
/// Why: a `.csgv` stores each encoding array's words at byte 69 + 4k of the file, so a
/// memory-mapped file (page-aligned base) holds them at addresses of 1 modulo 4. Reading such a
/// word through a `const uint32_t*` is undefined behaviour in C++, and GCC may vectorise a loop
/// over it with loads that assume alignment. Every reader of encoding words therefore loads them
/// with memcpy, which compilers turn into one plain (unaligned-capable) load on x86-64 and aarch64:
/// no cost where the words are aligned, no undefined behaviour where they are not.
/// Words are little-endian in files and in memory (hosts are little-endian: x86-64, aarch64).

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <vector>

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "CSGV words are little-endian in memory; big-endian hosts are not supported"
#endif

namespace csgv {

/// Word `i` of the words starting at `p` (any alignment).
inline uint32_t loadWord(const void* p, size_t i = 0) {
    uint32_t v;
    std::memcpy(&v, static_cast<const unsigned char*>(p) + i * sizeof(uint32_t), sizeof v);
    return v;
}

/// @brief A read-only pointer to 32-bit words that may lie at any byte address.
///
/// Reads like a `const uint32_t*` (`w[i]`, `*w`, `w + n`, `w - v`, iteration, comparisons) but
/// yields words by value, loaded with loadWord. It is a random-access iterator whose reference
/// is the value, so `std::vector<uint32_t>(w, w + n)` and `v.insert(v.end(), w, w + n)` work; bulk
/// copies are faster through copyTo (one memcpy).
class WordPtr {
public:
    using iterator_category = std::random_access_iterator_tag;
    using value_type = uint32_t;
    using difference_type = std::ptrdiff_t;
    using pointer = void;
    using reference = uint32_t;

    WordPtr() = default;
    explicit WordPtr(const void* bytes) : m_p(static_cast<const unsigned char*>(bytes)) {}
    WordPtr(const uint32_t* words) : m_p(reinterpret_cast<const unsigned char*>(words)) {} // NOLINT: as a pointer converts

    uint32_t operator[](size_t i) const { return loadWord(m_p, i); }
    uint32_t operator*() const { return loadWord(m_p); }
    /// The first byte of the words.
    const void* bytes() const { return m_p; }
    /// Copies `count` words to `dst` (aligned storage of the caller's).
    void copyTo(uint32_t* dst, size_t count) const {
        if (count) std::memcpy(dst, m_p, count * sizeof(uint32_t));
    }
    explicit operator bool() const { return m_p != nullptr; }

    WordPtr& operator+=(difference_type n) {
        m_p += n * difference_type(sizeof(uint32_t));
        return *this;
    }
    WordPtr& operator-=(difference_type n) { return *this += -n; }
    WordPtr& operator++() { return *this += 1; }
    WordPtr operator++(int) {
        WordPtr old = *this;
        *this += 1;
        return old;
    }
    WordPtr& operator--() { return *this -= 1; }
    WordPtr operator--(int) {
        WordPtr old = *this;
        *this -= 1;
        return old;
    }
    friend WordPtr operator+(WordPtr w, difference_type n) { return w += n; }
    friend WordPtr operator+(difference_type n, WordPtr w) { return w += n; }
    friend WordPtr operator-(WordPtr w, difference_type n) { return w -= n; }
    friend difference_type operator-(WordPtr a, WordPtr b) {
        return (a.m_p - b.m_p) / difference_type(sizeof(uint32_t));
    }
    friend bool operator==(WordPtr a, WordPtr b) { return a.m_p == b.m_p; }
    friend bool operator!=(WordPtr a, WordPtr b) { return a.m_p != b.m_p; }
    friend bool operator<(WordPtr a, WordPtr b) { return a.m_p < b.m_p; }
    friend bool operator>(WordPtr a, WordPtr b) { return a.m_p > b.m_p; }
    friend bool operator<=(WordPtr a, WordPtr b) { return a.m_p <= b.m_p; }
    friend bool operator>=(WordPtr a, WordPtr b) { return a.m_p >= b.m_p; }

private:
    const unsigned char* m_p = nullptr;
};

/// Appends `count` words at `w` to `out` (one memcpy).
inline void appendWords(std::vector<uint32_t>& out, WordPtr w, size_t count) {
    const size_t at = out.size();
    out.resize(at + count);
    w.copyTo(out.data() + at, count);
}

} // namespace csgv
