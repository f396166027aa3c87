// SPDX-License-Identifier: MIT
#pragma once
/// @file WordArray.h
/// @brief One encoding array of a CompressedVolume: 32-bit words that the volume either owns
/// (the encoder's output, a file read into memory) or views in storage someone else keeps alive
/// (a memory-mapped `.csgv`, the bytes of a VTK array), so that one copy of an encoding serves
/// every reader of it.

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
    /// A view of `count` words at `words`, which `keeper` keeps alive (and valid) while any copy of
    /// the view lives.
    static WordArray view(const uint32_t* words, size_t count, std::shared_ptr<const void> keeper) {
        WordArray a;
        a.m_view = words;
        a.m_viewSize = count;
        a.m_keeper = std::move(keeper);
        return a;
    }

    bool isView() const { return m_keeper != nullptr; }
    size_t size() const { return isView() ? m_viewSize : m_owned.size(); }
    bool empty() const { return size() == 0; }
    const uint32_t* data() const { return isView() ? m_view : m_owned.data(); }
    const uint32_t* begin() const { return data(); }
    const uint32_t* end() const { return data() + size(); }
    uint32_t operator[](size_t i) const { return data()[i]; }

    /// The words as a vector of its own, to change: a view is copied first (and is a view no
    /// more).
    std::vector<uint32_t>& owned() {
        if (isView()) {
            m_owned.assign(m_view, m_view + m_viewSize);
            m_view = nullptr;
            m_viewSize = 0;
            m_keeper.reset();
        }
        return m_owned;
    }
    uint32_t* data() { return owned().data(); }
    /// Bytes of memory this array holds of its own (a view: none).
    size_t ownedBytes() const { return m_owned.capacity() * sizeof(uint32_t); }

private:
    std::vector<uint32_t> m_owned;
    const uint32_t* m_view = nullptr;
    size_t m_viewSize = 0;
    std::shared_ptr<const void> m_keeper;
};

} // namespace csgv
