// SPDX-License-Identifier: MIT
/**
 * Computed attributes (voxel count, surface area, bounding box, centroid) of a volume whose
 * whole-brick pieces live on several MPI ranks (the reader hands each rank its bricks): every
 * rank computes exact sums for its piece, rank 0 adds them and the faces across the pieces'
 * touching sides (their outer voxel layers), and every rank gets the whole volume's table, equal
 * bit for bit to one rank's. Collective: every rank of the controller calls it together, in the
 * data phase (the representation's REQUEST_UPDATE), never while rendering.
 */
#ifndef CSGVPieceAttributes_h
#define CSGVPieceAttributes_h

#include "CSGVVolumeCache.h"

#include <string>

class vtkImageData;
class vtkMultiProcessController;

namespace csgvrep
{

/// Installs the whole volume's computed attributes as `source.shared->computed` on every rank
/// whose input is a piece of a `.csgv` placed in the volume's index space (SharedVolume::owned).
/// Ranks without a volume take part with nothing. Returns "" or an error (the same on every rank). When some rank's input is
/// not such a piece (a plain label array each rank compressed), nothing is installed and every
/// rank keeps the attributes of its own piece ("" is returned and `reduced` is false).
std::string reduceComputedAttributes(
  vtkMultiProcessController* controller, vtkImageData* input, const VolumeSource& source, bool& reduced);

/// Gives every rank holding a piece of a .csgv (SharedVolume::owned) the labels just beyond its
/// piece (`source.shared->ghost`), from the neighbours' outer layers. Collective like the above.
std::string shareGhostFaces(vtkMultiProcessController* controller, const VolumeSource& source);

} // namespace csgvrep

#endif
