// SPDX-License-Identifier: MIT
#include "TestData.h"

#include <cstdio>
#include <cstdlib>
#include <sys/wait.h>
#include <zlib.h>

#include "csgv/base/FileUtil.h"

#include <algorithm>
#include <cstdlib>
#include <dirent.h>
#include <filesystem>
#include <gtest/gtest.h>
#include <map>
#include <mutex>
#include <unistd.h>

namespace csgvtest {

std::string fixture(const std::string& name) { return std::string(CSGV_FIXTURE_DIR) + "/" + name; }

std::vector<std::string> allFixtureNames() {
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(CSGV_FIXTURE_DIR)) {
        const std::string n = e.path().filename().string();
        if (n.size() > 5 && n.compare(n.size() - 5, 5, ".csgv") == 0) names.push_back(n);
    }
    std::sort(names.begin(), names.end());
    return names;
}

const csgv::LabelVolume& sourceVolume(const std::string& fixtureName) {
    static std::mutex mutex;
    static std::map<std::string, csgv::LabelVolume> cache;
    const std::string stem = fixtureName.substr(0, fixtureName.find('_'));
    std::lock_guard<std::mutex> lock(mutex);
    auto it = cache.find(stem);
    if (it == cache.end()) {
        csgv::Result<csgv::LabelVolume> v = csgv::readVraw(fixture(stem + ".vraw.gz"));
        EXPECT_TRUE(v.isOk()) << v.message();
        it = cache.emplace(stem, std::move(*v)).first;
    }
    return it->second;
}

std::vector<uint8_t> fixtureBytes(const std::string& name) {
    csgv::Result<std::vector<uint8_t>> b = csgv::readFile(fixture(name), uint64_t(1) << 30);
    EXPECT_TRUE(b.isOk()) << b.message();
    return b.isOk() ? *b : std::vector<uint8_t>{};
}

csgv::CompressedVolume loadFixture(const std::string& name) {
    csgv::Result<csgv::CompressedVolume> v = csgv::readCsgv(fixture(name));
    EXPECT_TRUE(v.isOk()) << v.message();
    return v.isOk() ? *v : csgv::CompressedVolume{};
}

std::string tempDir() {
    static std::string dir = [] {
        std::string d = (std::filesystem::temp_directory_path() / ("csgv-test-" + std::to_string(::getpid()))).string();
        std::filesystem::create_directories(d);
        static struct Cleanup {
            std::string path;
            ~Cleanup() {
                std::error_code ec;
                std::filesystem::remove_all(path, ec);
            }
        } cleanup{d};
        return d;
    }();
    return dir;
}

csgv::LabelVolume referenceCoarsen(const csgv::LabelVolume& fine) {
    csgv::LabelVolume out;
    for (int a = 0; a < 3; ++a) out.dim[a] = fine.dim[a] / 2 + fine.dim[a] % 2;
    out.labels.assign(size_t(out.voxelCount()), 0);
    for (uint32_t z = 0; z < out.dim[2]; ++z)
        for (uint32_t y = 0; y < out.dim[1]; ++y)
            for (uint32_t x = 0; x < out.dim[0]; ++x) {
                // Children in child-index order; count each label, first seen wins ties.
                std::vector<std::pair<uint32_t, int>> tally; // label, count, in first-seen order
                for (int child = 0; child < 8; ++child) {
                    const uint32_t fx = x * 2 + (child & 1), fy = y * 2 + (child >> 1 & 1), fz = z * 2 + (child >> 2);
                    if (fx >= fine.dim[0] || fy >= fine.dim[1] || fz >= fine.dim[2]) continue;
                    const uint32_t l = fine.at(fx, fy, fz);
                    auto it = std::find_if(tally.begin(), tally.end(), [&](const auto& p) { return p.first == l; });
                    if (it == tally.end()) tally.emplace_back(l, 1);
                    else ++it->second;
                }
                auto best = tally.begin();
                for (auto it = tally.begin(); it != tally.end(); ++it)
                    if (it->second > best->second) best = it;
                out.labels[size_t(out.index(x, y, z))] = best->first;
            }
    return out;
}

} // namespace csgvtest

namespace csgvtest {

int runFixtureScript(const std::string& script, const std::vector<std::string>& args) {
    std::string cmd = std::string("'") + CSGV_PYTHON3 + "' '" + CSGV_INPUT_SCRIPTS + "/" + script + "'";
    for (const std::string& a : args) {
        std::string q;
        for (char c : a) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
        cmd += " '" + q + "'";
    }
    const int rc = std::system(cmd.c_str());
    return rc == -1 ? -1 : WEXITSTATUS(rc);
}

} // namespace csgvtest

namespace csgvtest {

void expectSourceContract(csgv::InputSource& source, const std::vector<uint64_t>& expected) {
    const csgv::InputInfo& info = source.info();
    ASSERT_EQ(info.voxelCount(), expected.size()) << "source dimensions disagree with the expected volume";
    const uint64_t slice = uint64_t(info.dim[0]) * info.dim[1];
    const uint32_t D = info.dim[2];
    std::vector<uint64_t> got;
    for (uint32_t depth : {1u, 2u, 5u, D}) {
        if (depth == 0 || depth > D) continue;
        std::vector<uint32_t> starts;
        for (uint32_t z = 0; z < D; z += depth) starts.push_back(z);
        std::vector<std::vector<uint32_t>> orders = {starts, std::vector<uint32_t>(starts.rbegin(), starts.rend()), starts};
        // A fixed shuffle (reproducible): swap by a linear congruential sequence.
        uint64_t r = 12345;
        for (size_t i = orders[2].size(); i > 1; --i) {
            r = r * 6364136223846793005ull + 1442695040888963407ull;
            std::swap(orders[2][i - 1], orders[2][size_t((r >> 33) % i)]);
        }
        for (int pass = 0; pass < 2; ++pass)
            for (const auto& order : orders)
                for (uint32_t z0 : order) {
                    const uint32_t d = std::min(depth, D - z0);
                    got.assign(size_t(slice * d), 0xDEADBEEFull);
                    const csgv::Status s = source.readSlab(z0, d, got.data());
                    ASSERT_TRUE(s.isOk()) << "readSlab(" << z0 << ", " << d << "): " << s.message();
                    for (size_t i = 0; i < got.size(); ++i)
                        if (got[i] != expected[size_t(slice * z0) + i]) {
                            const uint64_t v = slice * z0 + i;
                            FAIL() << "readSlab(" << z0 << ", " << d << ") voxel (" << v % info.dim[0] << ", "
                                   << (v / info.dim[0]) % info.dim[1] << ", " << v / slice << ") is " << got[i]
                                   << ", expected " << expected[size_t(v)];
                        }
                }
    }
    // Uniform boxes (any source may list some): inside the region asked about, disjoint, and every
    // voxel of each holds its value; over whole slabs, and over bands of rows when the source
    // reads them.
    const uint32_t W = info.dim[0], H = info.dim[1];
    std::vector<csgv::UniformBox> boxes;
    const auto checkBoxes = [&](uint32_t z0, uint32_t depth, uint32_t y0, uint32_t rows) {
        source.uniformBoxes(z0, depth, y0, rows, boxes);
        const std::string region = "uniformBoxes(" + std::to_string(z0) + ", " + std::to_string(depth) + ", " +
                                   std::to_string(y0) + ", " + std::to_string(rows) + ")";
        const std::array<uint32_t, 3> lo = {0, y0, z0}, hi = {W, y0 + rows, z0 + depth};
        for (size_t i = 0; i < boxes.size(); ++i) {
            const csgv::UniformBox& b = boxes[i];
            for (int a = 0; a < 3; ++a)
                ASSERT_TRUE(b.lo[a] >= lo[a] && b.lo[a] < b.hi[a] && b.hi[a] <= hi[a]) << region << ": box " << i
                                                                                        << " is empty or outside";
            for (size_t j = 0; j < i; ++j) {
                const csgv::UniformBox& o = boxes[j];
                bool apart = false;
                for (int a = 0; a < 3; ++a) apart = apart || b.hi[a] <= o.lo[a] || o.hi[a] <= b.lo[a];
                ASSERT_TRUE(apart) << region << ": boxes " << j << " and " << i << " overlap";
            }
            for (uint32_t z = b.lo[2]; z < b.hi[2]; ++z)
                for (uint32_t y = b.lo[1]; y < b.hi[1]; ++y)
                    for (uint32_t x = b.lo[0]; x < b.hi[0]; ++x)
                        ASSERT_EQ(expected[size_t(x + uint64_t(W) * (y + uint64_t(H) * z))], b.value)
                            << region << ": box " << i << " voxel (" << x << ", " << y << ", " << z << ")";
        }
    };
    for (uint32_t depth : {1u, 4u, D})
        for (uint32_t z0 = 0; z0 < D; z0 += depth) checkBoxes(z0, std::min(depth, D - z0), 0, H);
    // Bands of rows, when the source reads them: every row band of a few heights at a few depths,
    // bottom band first, the same values readSlab gives; rows past the volume are an error.
    if (!source.readsRows()) return;
    for (uint32_t rows : {3u, 16u})
        for (uint32_t y0 = 0; y0 < H; y0 += rows) checkBoxes(0, D, y0, std::min(rows, H - y0));
    for (uint32_t rows : {1u, 3u, H})
        for (uint32_t depth : {1u, 4u, D}) {
            if (rows == 0 || rows > H || depth == 0 || depth > D) continue;
            for (uint32_t z0 = 0; z0 < D; z0 += depth)
                for (uint32_t y0 = (H - 1) / rows * rows;; y0 -= rows) {
                    const uint32_t h = std::min(rows, H - y0), d = std::min(depth, D - z0);
                    got.assign(size_t(uint64_t(W) * h * d), 0xDEADBEEFull);
                    const csgv::Status s = source.readRows(z0, d, y0, h, got.data());
                    ASSERT_TRUE(s.isOk()) << "readRows(" << z0 << ", " << d << ", " << y0 << ", " << h
                                          << "): " << s.message();
                    for (size_t i = 0; i < got.size(); ++i) {
                        const uint64_t x = i % W, y = y0 + (i / W) % h, z = z0 + i / (uint64_t(W) * h);
                        if (got[i] != expected[size_t(x + W * (y + uint64_t(H) * z))])
                            FAIL() << "readRows(" << z0 << ", " << d << ", " << y0 << ", " << h << ") voxel (" << x
                                   << ", " << y << ", " << z << ") is " << got[i] << ", expected "
                                   << expected[size_t(x + W * (y + uint64_t(H) * z))];
                    }
                    if (y0 == 0) break;
                }
        }
    got.assign(size_t(W) * 2, 0);
    const csgv::Status beyond = source.readRows(0, 1, H - 1, 2, got.data());
    EXPECT_FALSE(beyond.isOk()) << "readRows past the last row must fail";
    EXPECT_NE(beyond.message().find("beyond the volume's height"), std::string::npos) << beyond.message();
}

} // namespace csgvtest

namespace csgvtest {

void writeBytes(const std::string& path, const Bytes& bytes) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    ASSERT_NE(f, nullptr) << path;
    if (!bytes.empty()) {
        ASSERT_EQ(std::fwrite(bytes.data(), 1, bytes.size(), f), bytes.size());
    }
    std::fclose(f);
}

Bytes textBytes(const std::string& s) { return Bytes(s.begin(), s.end()); }

Bytes operator+(Bytes a, const Bytes& b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
}

Bytes gzipBytes(const Bytes& raw) {
    z_stream s{};
    EXPECT_EQ(deflateInit2(&s, 6, Z_DEFLATED, 31, 8, Z_DEFAULT_STRATEGY), Z_OK);
    Bytes out(deflateBound(&s, uLong(raw.size())) + 64);
    s.next_in = const_cast<Bytes::value_type*>(raw.data());
    s.avail_in = uInt(raw.size());
    s.next_out = out.data();
    s.avail_out = uInt(out.size());
    EXPECT_EQ(deflate(&s, Z_FINISH), Z_STREAM_END);
    out.resize(s.total_out);
    deflateEnd(&s);
    return out;
}

} // namespace csgvtest
