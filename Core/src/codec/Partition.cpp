// SPDX-License-Identifier: MIT
#include "csgv/codec/Partition.h"

namespace csgv {

BrickBox brickPartition(const std::array<uint32_t, 3>& grid, uint32_t pieces, uint32_t piece) {
    BrickBox box;
    box.hi = grid;
    if (pieces == 0 || piece >= pieces) return BrickBox{}; // no such piece: empty
    while (pieces > 1) {
        int axis = 0;
        for (int a = 1; a < 3; ++a)
            if (box.hi[a] - box.lo[a] > box.hi[axis] - box.lo[axis]) axis = a;
        const uint32_t length = box.hi[axis] - box.lo[axis];
        const uint32_t left = pieces / 2;
        const uint32_t cut = box.lo[axis] + uint32_t(uint64_t(length) * left / pieces);
        if (piece < left) {
            box.hi[axis] = cut;
            pieces = left;
        } else {
            box.lo[axis] = cut;
            piece -= left;
            pieces -= left;
        }
    }
    return box;
}

} // namespace csgv
