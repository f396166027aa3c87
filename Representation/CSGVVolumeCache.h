// SPDX-License-Identifier: MIT
/**
 * @file CSGVVolumeCache.h
 * @brief What an input image resolves to (the CSGV reader's encoding, or a label array
 * compressed on the fly through the readers' adapter), cached process-wide per (array,
 * modification time) so that every view of one volume shares one compressed volume and one
 * upload.
 *
 * The cache is an owned singleton: VolumeCache::instance() hands out a shared_ptr that every
 * user keeps, so the cache (and the mutex that guards SharedVolume's mutable members) lives until
 * its last user goes, also when representations outlive static destruction at exit.
 *
 * Not a wrapped header: Core and VulkanBackend types may appear here.
 */
#ifndef CSGVVolumeCache_h
#define CSGVVolumeCache_h

#include "csgv/codec/TieredVolume.h"
#include "csgv/attributes/Attributes.h"
#include "csgv/base/Geometry.h"
#include "csgv/codec/Container.h"
#include "csgv/gpu/GpuVolume.h"
#include "csgv/gpu/UploadPolicy.h"

#include <vtkType.h>

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

class vtkImageData;
class vtkMatrix4x4;
class vtkMultiProcessController;

namespace csgv
{
namespace gpu
{
class Context;
}
}

namespace csgvrep
{

/// Labels just outside each side of a piece (-x, +x, -y, +y, -z, +z).
using GhostFaces = std::array<std::vector<uint32_t>, 6>;

/// The whole volume's stored labels at its coarse levels, on every rank holding a piece: what
/// shadow, ambient-occlusion and path-tracing rays see of the other ranks' bricks.
struct CoarseStandIns
{
  uint32_t first = 0;                        ///< the finest level held
  std::vector<std::vector<uint32_t>> levels; ///< levels first, first + 1, ..., the coarsest; x fastest
};

/// @brief One compressed volume and its upload, shared by every view showing the same data.
struct SharedVolume
{
  csgv::CompressedVolume volume;
  /// The encoding's own level-0 corner geometry (CSGVEncoding inputs; parsed with it).
  csgv::Geometry encodedGeometry;
  /// Stored label -> original label when the volume is relabelled and originals fit 32 bits.
  std::vector<uint32_t> storedToOriginal;
  /// Stored id -> original label bits for any relabelled volume (empty: stored labels are the
  /// originals); the key of attribute arrays.
  std::vector<int64_t> idToLabel;
  /// The bits of idToLabel are unsigned 64-bit labels (a uint64 array or a file of them).
  bool originalsUnsigned = false;
  /// An MPI rank's piece of a .csgv (the reader's CSGVPieceOffset): `volume` is the piece placed
  /// in the whole volume's index space (csgv::embedPiece), `owned` its bricks (the others are
  /// absent: label 0, never drawn), `pieceDims` its own voxels, `volumeCorner` the corner
  /// geometry of the volume's voxel (0,0,0); `encodedGeometry` stays the piece's corner. Every
  /// rank then renders in one index space (the same rays, the same level-of-detail choices) and
  /// the clip box and picked voxels are in the volume's coordinates. Empty `owned`: a whole volume.
  csgv::BrickBox owned;
  std::array<uint32_t, 3> pieceDims{};
  csgv::Geometry volumeCorner;
  /// The labels just beyond a rank's piece (csgv::ghostFaces; set by the ranks together in the
  /// data phase, guarded by the volume cache's mutex), for translucent materials across ranks.
  std::shared_ptr<const GhostFaces> ghost;
  /// The whole volume's coarse levels (set by the ranks together with `ghost`, same guard).
  std::shared_ptr<const CoarseStandIns> coarse;
  /// The largest label `ghost` and `coarse` hold (set with them, same guard; kNone until then):
  /// the renderer's label table covers it (csgv::gpu::RendererOptions::largestOtherLabel).
  uint32_t largestOtherLabel = csgv::gpu::kNone;
  /// Computed attributes (voxel count, surface area, ...), computed once per volume on demand
  /// (guarded by the volume cache's mutex while being set).
  std::shared_ptr<const csgv::AttributeTable> computed;
  /// A plain image's MPI piece relabelled with ids of its own (its labels do not fit the format,
  /// and this rank numbered them alone): drawn as a volume of its own until the ranks agree on
  /// the whole image's ids (VolumeCache::resolveAgreed), after which it is placed like any piece.
  bool ownIds = false;
  std::string arrayName;   ///< the label array users see ("Labels" for the CSGV encoding)
  std::string description; ///< where it came from ("CSGVEncoding", "array 'Labels' compressed")
  /// What the palettes hold (csgv::summarizePalettes): the reader's, made when it opened the file,
  /// or made at the first upload (guarded by the volume cache's mutex); every upload of the
  /// volume (and of its tiers: the coarse tier keeps the palettes) takes it.
  std::shared_ptr<const csgv::PaletteSummary> palettes;
  /// The stored labels of the volume's own bricks (sorted, unique; at most 2^26, `true` in the
  /// pair when there were more), made at the first storedLabels that needs them (an MPI piece's,
  /// which the palette summary does not describe: made again at every query, a pick took 10 s
  /// on a piece of 2 million labels). Set with std::atomic_store.
  mutable std::shared_ptr<const std::pair<std::vector<uint32_t>, bool>> ownLabels;
  /// By host-memory setting (bytes; 0: automatic): the volume under that budget
  /// (ViewRenderer::tiersFor: the finest level read from the mapped file), or null when it stays
  /// whole; decided once per setting (the automatic budget when first asked), guarded by the
  /// volume cache's mutex.
  std::map<uint64_t, std::shared_ptr<const csgv::TieredVolume>> tiers;
  /// The context `gpu` was created on; declared before `gpu` so that it outlives it.
  std::shared_ptr<csgv::gpu::Context> context;
  /// The uploads: [paletted + 2 * hostDecoding] (csgv::gpu::UploadPlan::kind), for caches of labels or palette indices, decoded
  /// on the GPU or the host (views may differ; an upload no view uses any more is released when
  /// another view switches). Declared after `volume`: destroyed first (each keeps a reference to
  /// `volume`).
  std::shared_ptr<csgv::gpu::GpuVolume> gpu[csgv::gpu::kUploadKinds];
  /// Renderers using this volume; each one's cache gets an equal share of the cache budget.
  int renderers = 0;
};

/// @brief What an input image resolves to.
struct VolumeSource
{
  std::shared_ptr<SharedVolume> shared;
  csgv::Geometry corner; ///< corner geometry of voxel (0,0,0) (Metadata.h)

  /// World bounds of the voxels drawn (point data: voxels centred on points, half a voxel
  /// beyond the image's bounds). False when there is nothing to draw.
  bool bounds(double out[6]) const;

  /// The source drawn where `placement` (a vtkProp3D's matrix: the display's Position,
  /// Orientation, Scale and Origin) puts it: its corner geometry mapped by the matrix (spacing
  /// the lengths of the mapped axes, direction their unit vectors; any affine map, shears
  /// included, since the renderer takes a full index-to-world matrix). The same source when the
  /// matrix is the identity or null.
  VolumeSource placed(vtkMatrix4x4* placement) const;
};

/// Replaces `bounds` (xmin xmax ymin ymax zmin zmax) by the axis-aligned box around their eight
/// corners mapped by `placement` (nothing for a null or identity matrix). False when the result
/// is not finite or the placement not usable (a NaN, infinite or huge Position, Scale or
/// Orientation): no bounds to give.
bool placeBounds(vtkMatrix4x4* placement, double bounds[6]);

/// The largest magnitude a placement's element may have: the renderer works in floats, whose
/// products overflow beyond this.
constexpr double kLargestPlacement = 1e30;

/// Whether every element of `placement` is finite and within +-kLargestPlacement (null: the
/// identity).
bool usablePlacement(vtkMatrix4x4* placement);

/// @brief The process-wide cache of compressed volumes, keyed by (array, modification time).
class VolumeCache
{
public:
  /// The cache; keep the pointer for as long as you use the cache or its mutex.
  static std::shared_ptr<VolumeCache> instance();

  /// Resolves the input: the FieldData encoding of the CSGV reader when it describes this image
  /// (parsed once per encoding array and modification time: a cache hit parses nothing), else
  /// the label array (by name, or the first integer array, cell data first), compressed once
  /// per array and modification time. Returns an error message, or "" on success (an encoding
  /// that does not parse, with no label array to fall back on, reports its parse error).
  std::string resolve(vtkImageData* image, const std::string& labelArray, VolumeSource& out);

  /// Collective over `controller`'s processes, each passing its own piece of one plain image
  /// (csgvvtk::brickPiece): compresses this process's bricks again, relabelled with the ids one
  /// process gives the whole image when any piece's labels do not fit the format (the processes
  /// agree through csgvvtk::MpiAgreement), places them in the image's index space and keeps them
  /// in the cache in place of the piece resolve() compressed alone. A process without bricks
  /// takes part and resolves to nothing. Returns an error message, or "".
  std::string resolveAgreed(vtkImageData* image, const std::string& labelArray,
    vtkMultiProcessController* controller, VolumeSource& out);
  /// Guards the cache and SharedVolume's mutable members (gpu, renderers, computed).
  std::mutex& mutex() { return this->Mutex; }

  /// How many times an encoding was parsed (successfully) and an array compressed in this
  /// process (for benchmarks and tests: both happen once per array and modification time).
  uint64_t parses() const { return this->Parses; }
  uint64_t compressions() const { return this->Compressions; }
  /// Parses whose encoding arrays view the FieldData array's memory (no copy of the encoding).
  uint64_t sharedParses() const { return this->SharedParses; }

private:
  struct Key
  {
    const void* array;
    vtkMTimeType mtime;
    int kind; ///< 0: encoding, 1: cell array, 2: point array
    std::array<uint32_t, 3> dims;
    bool operator<(const Key& o) const;
  };
  std::shared_ptr<SharedVolume> lookup(const Key& key);

  std::mutex Mutex;
  std::map<Key, std::weak_ptr<SharedVolume>> Entries;
  uint64_t Parses = 0;
  uint64_t SharedParses = 0;
  uint64_t Compressions = 0;
};

/// The lock that guards the volume cache and SharedVolume's mutable members (the instance's).
std::mutex& volumeMutex();

} // namespace csgvrep

#endif
