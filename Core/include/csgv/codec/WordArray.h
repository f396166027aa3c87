// SPDX-License-Identifier: MIT
#pragma once
/// @file WordArray.h
/// @brief One encoding array of a CompressedVolume: 32-bit words that the volume either owns
/// (the encoder's output, a file read into memory) or views in storage someone else keeps alive
/// (a memory-mapped `.csgv`, the bytes of a VTK array), so that one copy of an encoding serves
/// every reader of it. A view may start at any byte address (a memory-mapped `.csgv` holds its
/// words at odd offsets), so its words are read through WordPtr (base/Words.h), never through a
/// `const uint32_t*`.

#include "csgv/base/Words.h"

#include <cstddef>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

namespace csgv {

class WordArray {
public:
    WordArray() = default;
    WordArray(std::vector<uint32_t> words) : m_owned(std::move(words)) {} // NOLINT: implicit, as a vector was
    /// A view of `count` words starting at byte `bytes` (any alignment), which `keeper` keeps alive
    /// and unchanged while any copy of the view lives.
    static WordArray view(const void* bytes, size_t count, std::shared_ptr<const void> keeper) {
        WordArray a;
        a.m_view = static_cast<const unsigned char*>(bytes);
        a.m_viewSize = count;
        a.m_keeper = std::move(keeper);
        return a;
    }

    bool isView() const { return m_keeper != nullptr; }
    size_t size() const { return isView() ? m_viewSize : m_owned.size(); }
    bool empty() const { return size() == 0; }
    /// The words, wherever they lie (read them through the WordPtr: a view may be unaligned).
    WordPtr words() const { return isView() ? WordPtr(m_view) : WordPtr(m_owned.data()); }
    /// The first byte of the words (for memcpy and uploads).
    const void* bytes() const { return isView() ? static_cast<const void*>(m_view) : m_owned.data(); }
    WordPtr begin() const { return words(); }
    WordPtr end() const { return words() + std::ptrdiff_t(size()); }
    uint32_t operator[](size_t i) const { return words()[i]; }
    /// Copies words [first, first + count) to `dst`.
    void copyTo(uint32_t* dst, size_t first, size_t count) const { (words() + std::ptrdiff_t(first)).copyTo(dst, count); }

    /// The words as a vector of its own, to change: a view is copied first (and is a view no
    /// more).
    std::vector<uint32_t>& owned() {
        if (isView()) {
            m_owned.resize(m_viewSize);
            WordPtr(m_view).copyTo(m_owned.data(), m_viewSize);
            m_view = nullptr;
            m_viewSize = 0;
            m_keeper.reset();
        }
        return m_owned;
    }
    /// Bytes of memory this array holds of its own (a view: none).
    size_t ownedBytes() const { return m_owned.capacity() * sizeof(uint32_t); }

private:
    std::vector<uint32_t> m_owned;
    const unsigned char* m_view = nullptr;
    size_t m_viewSize = 0;
    std::shared_ptr<const void> m_keeper;
};

} // namespace csgv
