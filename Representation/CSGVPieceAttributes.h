// SPDX-License-Identifier: MIT
/**
 * What the MPI ranks holding pieces of one `.csgv` share (the reader hands each rank its bricks,
 * placed in the volume's index space: SharedVolume::owned), in the data phase (the
 * representation's REQUEST_UPDATE, once per data update), never while rendering:
 * - every piece's outer voxel layers, exchanged once; from them each rank gets the labels just
 *   beyond its piece (ghost faces, for translucent materials across ranks);
 * - the whole volume's coarse levels (each rank decodes its own bricks there): what secondary
 *   rays (shadows, ambient occlusion, path tracing) see of the other ranks' bricks;
 * - when asked for, the computed attributes (voxel count, surface area, bounding box, centroid):
 *   every rank computes exact sums for its piece, rank 0 adds them and the faces across the
 *   pieces' touching sides (from the layers), and every rank gets the whole volume's table, equal
 *   bit for bit to one rank's.
 * Collective: every rank of the controller calls it together.
 */
#ifndef CSGVPieceAttributes_h
#define CSGVPieceAttributes_h

#include "CSGVVolumeCache.h"

#include <string>

class vtkMultiProcessController;

namespace csgvrep
{

/// Sets `source.shared->ghost`, `source.shared->coarse` and, with `computed`, `source.shared->computed` on every rank whose
/// volume is such a piece; ranks without a volume take part with nothing. When some rank's input
/// is not a piece of a .csgv (a plain label array each rank compressed), nothing is shared.
/// `reduced` says whether the computed attributes were installed. Returns "" or an error (the
/// same on every rank for the parts decided on rank 0).
std::string shareAcrossRanks(
  vtkMultiProcessController* controller, const VolumeSource& source, bool computed, bool& reduced);

} // namespace csgvrep

#endif
