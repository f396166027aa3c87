// SPDX-License-Identifier: MIT
/// @file
/// Which of several hits at one pixel a one-rank render would report (MPI ranks' pieces, or
/// several Segmentation Volume displays of a view): the smallest of this key. An opaque hit (its
/// window depth, 0..1) before a semi-transparent one (which a render keeps only where the ray meets
/// no opaque surface: 2 + depth) before none (4). Header-only: the GUI's pick panel uses it too.
#ifndef CSGVHitOrder_h
#define CSGVHitOrder_h

namespace csgvrep
{

inline double hitOrder(bool hit, bool translucent, double depth)
{
  return !hit ? 4.0 : translucent ? 2.0 + depth : depth;
}

} // namespace csgvrep

#endif
