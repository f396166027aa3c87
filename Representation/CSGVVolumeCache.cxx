// SPDX-License-Identifier: MIT
#include "CSGVVolumeCache.h"

#include "CSGVAdapter.h" // the readers' FieldData contract and array encoder (CSGV::Readers)
#include "CSGVMpiAgreement.h"

#include <vtkDataArray.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkMatrix4x4.h>
#include <vtkUnsignedCharArray.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

namespace csgvrep
{
namespace
{

/// Original labels of a relabelled volume as 32-bit labels, when every one fits.
std::vector<uint32_t> narrowMap(const std::vector<int64_t>& map, bool unsigned64)
{
  std::vector<uint32_t> out;
  out.reserve(map.size());
  for (int64_t v : map)
  {
    const bool fits = unsigned64 ? uint64_t(v) < 0xFFFFFFFFull : (v >= 0 && v < int64_t(0xFFFFFFFFll));
    if (!fits)
    {
      return {};
    }
    out.push_back(uint32_t(v));
  }
  return out;
}

/// Why no label array was found (named `labelArray`, or the first integer one), said alike by
/// resolve() and resolveAgreed(); `encodingToo`: nor is there a CSGV encoding to draw.
std::string missingLabelArray(const std::string& labelArray, bool encodingToo)
{
  if (!labelArray.empty())
  {
    return "the input has no array named '" + labelArray.substr(0, 200) + (labelArray.size() > 200 ? "...'" : "'");
  }
  return std::string("the input has no label array (one-component integer cell or point data)") +
    (encodingToo ? " and no CSGV encoding" : "");
}

/// Shifts a corner geometry by `voxels` along its own axes.
csgv::Geometry shiftCorner(csgv::Geometry g, const std::array<long, 3>& voxels)
{
  for (int r = 0; r < 3; ++r)
  {
    for (int c = 0; c < 3; ++c)
    {
      g.origin[r] += g.direction[3 * r + c] * double(voxels[c]) * g.spacing[c];
    }
  }
  return g;
}

/// Places `out.volume`, an MPI rank's piece (its bricks `box` of a volume of `dims` voxels), in the
/// volume's index space (csgv::embedPiece), with the corner geometry of the volume's voxel
/// (0,0,0); false (and `out` as it was: a volume of its own) when the piece does not fit there.
bool embedInVolume(SharedVolume& out, const csgv::BrickBox& box, const std::array<uint32_t, 3>& dims,
  const csgv::Geometry& volumeCorner)
{
  csgv::Result<csgv::CompressedVolume> embedded = csgv::embedPiece(out.volume, box, dims);
  if (!embedded)
  {
    return false;
  }
  out.pieceDims = out.volume.dim;
  out.volume = std::move(*embedded);
  out.owned = box;
  out.volumeCorner = volumeCorner;
  return true;
}

/// The corner geometry a parsed encoding or a compressed piece is drawn with: the volume's when
/// it was placed in the volume's index space, else its own.
const csgv::Geometry& drawnCorner(const SharedVolume& shared)
{
  return shared.owned.empty() ? shared.encodedGeometry : shared.volumeCorner;
}

/// A SharedVolume of the reader's encoding (parsed here, once per array and modification time).
std::string parseEncoding(vtkFieldData* fd, SharedVolume& out)
{
  csgvvtk::EncodedInput enc;
  const std::string error = csgvvtk::readEncodingArrays(fd, enc);
  if (!error.empty())
  {
    return error;
  }
  out.volume = std::move(enc.volume);
  out.encodedGeometry = enc.geometry;
  out.description = "CSGVEncoding";
  // A rank's piece: placed in the volume's index space (should that fail, it is drawn as a volume
  // of its own, as before).
  const std::array<uint32_t, 3> dims = csgvvtk::pieceVolumeDims(fd);
  const std::array<long, 3> offset = csgvvtk::pieceOffset(fd);
  const uint32_t b = out.volume.brickSize;
  if (dims[0] > 0 && dims[1] > 0 && dims[2] > 0 && b > 0 && offset[0] % b == 0 && offset[1] % b == 0 &&
    offset[2] % b == 0)
  {
    csgv::BrickBox box;
    for (int a = 0; a < 3; ++a)
    {
      box.lo[a] = uint32_t(offset[a]) / b;
      box.hi[a] = box.lo[a] + (out.volume.dim[a] + b - 1) / b;
    }
    embedInVolume(out, box, dims, shiftCorner(enc.geometry, { -offset[0], -offset[1], -offset[2] }));
  }
  out.arrayName = csgvvtk::kLabelsName;
  if (out.owned.empty())
  {
    out.palettes = enc.palettes; // the reader's sweep of these palettes (a placed piece has more)
  }
  if (enc.info.relabelled)
  {
    out.idToLabel = enc.info.map;
    out.storedToOriginal = narrowMap(enc.info.map, enc.info.unsigned64);
    out.originalsUnsigned = enc.info.unsigned64;
  }
  return std::string();
}

/// A SharedVolume of a plain label array, compressed by the readers' streaming encoder
/// (relabelling labels the format cannot hold).
std::string compressArray(vtkDataArray* array, const std::array<uint32_t, 3>& dims, SharedVolume& out,
  const csgv::EncodeOptions& options = {}, csgvvtk::PieceAgreement* agreement = nullptr)
{
  csgvvtk::EncodedArray encoded;
  const std::string error = csgvvtk::encodeLabelArray(array, dims, options, false, nullptr, encoded, agreement);
  if (!error.empty())
  {
    return error;
  }
  const std::string name = array->GetName() ? array->GetName() : "";
  out.volume = std::move(encoded.volume);
  out.arrayName = name;
  out.description = "array '" + name + "' compressed" + (encoded.mapping.relabelled ? " (relabelled)" : "");
  if (encoded.mapping.relabelled)
  {
    // Originals that do not fit 32 bits (negative, wide) cannot be named in materials:
    // materials then filter on the dense ids.
    out.idToLabel.assign(encoded.mapping.originalBits.begin(), encoded.mapping.originalBits.end());
    out.originalsUnsigned = !csgv::isSignedType(encoded.mapping.type);
    out.storedToOriginal = narrowMap(out.idToLabel, out.originalsUnsigned);
  }
  return std::string();
}

/// A plain label array that is an MPI rank's brick piece of its input's whole image
/// (vtkCSGVRepresentation asked for it: csgvvtk::brickPiece): its voxels are cropped, compressed
/// with the piece's brick size and placed in the whole image's index space, as a .csgv's pieces
/// are, so the ranks cast the same rays and share what crosses their pieces. `corner` is the
/// image's own (its voxel (0,0,0)). Without `agreement` a relabelled piece (its own ids, `ownIds`)
/// is drawn as a volume of its own; with it (collective: every piece's process calls this) the
/// pieces relabel alike with the whole image's ids. A piece without bricks draws nothing (`drawn`
/// false) and makes no collective call (MpiAgreement::catchUp does).
std::string compressPiece(vtkImageData* image, vtkDataArray* array, bool isCell, const csgv::Geometry& corner,
  int brick, int pieces, int piece, const int whole[6], SharedVolume& out, bool& drawn,
  csgvvtk::PieceAgreement* agreement = nullptr)
{
  drawn = false;
  const std::array<uint32_t, 3> dims = csgvvtk::voxelDims(whole, isCell);
  std::array<uint32_t, 3> lo, hi;
  if (!csgvvtk::pieceVoxels(dims, brick, pieces, piece, lo, hi))
  {
    return std::string();
  }
  vtkSmartPointer<vtkDataArray> cropped;
  std::string error = csgvvtk::cropVoxels(array, image->GetExtent(), whole, isCell, lo, hi, cropped);
  if (!error.empty())
  {
    return error;
  }
  csgv::EncodeOptions options;
  options.brickSize = uint32_t(brick);
  const std::array<uint32_t, 3> own{ hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2] };
  if (agreement)
  {
    agreement->offset = lo;
    agreement->volumeDims = dims;
  }
  if (!(error = compressArray(cropped, own, out, options, agreement)).empty())
  {
    return error;
  }
  drawn = true;
  const int* ext = image->GetExtent();
  // The image's voxel (0,0,0) is the whole image's voxel (ext - whole).
  const std::array<long, 3> imageAt{ long(ext[0]) - whole[0], long(ext[2]) - whole[2], long(ext[4]) - whole[4] };
  out.encodedGeometry =
    shiftCorner(corner, { long(lo[0]) - imageAt[0], long(lo[1]) - imageAt[1], long(lo[2]) - imageAt[2] });
  if (!out.idToLabel.empty() && !agreement)
  {
    out.ownIds = true; // relabelled apart from the other ranks: a volume of its own
    return std::string();
  }
  csgv::BrickBox box;
  for (int a = 0; a < 3; ++a)
  {
    box.lo[a] = lo[a] / uint32_t(brick);
    box.hi[a] = (hi[a] + uint32_t(brick) - 1) / uint32_t(brick);
  }
  embedInVolume(out, box, dims, shiftCorner(corner, { -imageAt[0], -imageAt[1], -imageAt[2] }));
  return std::string();
}

} // namespace

bool VolumeSource::bounds(double out[6]) const
{
  if (!this->shared)
  {
    return false;
  }
  if (!this->shared->owned.empty())
  {
    // A rank's piece: its own voxels (IceT and ordered compositing need each rank's part).
    csgvvtk::worldBounds(this->shared->encodedGeometry, this->shared->pieceDims, out);
    return true;
  }
  csgvvtk::worldBounds(this->corner, this->shared->volume.dim, out);
  return true;
}

bool VolumeCache::Key::operator<(const Key& o) const
{
  return std::tie(array, mtime, kind, dims) < std::tie(o.array, o.mtime, o.kind, o.dims);
}

std::shared_ptr<VolumeCache> VolumeCache::instance()
{
  // Function-local: created on first use, and every user holds a copy, so the last holder (not
  // static destruction order) ends it.
  static const std::shared_ptr<VolumeCache> cache = std::make_shared<VolumeCache>();
  return cache;
}

std::mutex& volumeMutex()
{
  return VolumeCache::instance()->mutex();
}

std::shared_ptr<SharedVolume> VolumeCache::lookup(const Key& key)
{
  for (auto it = this->Entries.begin(); it != this->Entries.end();)
  {
    it = it->second.expired() ? this->Entries.erase(it) : std::next(it);
  }
  auto it = this->Entries.find(key);
  return it == this->Entries.end() ? nullptr : it->second.lock();
}

VolumeSource VolumeSource::placed(vtkMatrix4x4* placement) const
{
  VolumeSource out = *this;
  if (!placement || placement->IsIdentity())
  {
    return out;
  }
  const csgv::Geometry& g = this->corner;
  csgv::Geometry& p = out.corner;
  for (int r = 0; r < 3; ++r)
  {
    p.origin[r] = placement->GetElement(r, 3);
    for (int k = 0; k < 3; ++k)
    {
      p.origin[r] += placement->GetElement(r, k) * g.origin[k];
    }
  }
  for (int c = 0; c < 3; ++c)
  {
    // Column c of M3 * direction * spacing: the world step of index axis c.
    double axis[3] = { 0, 0, 0 };
    for (int r = 0; r < 3; ++r)
    {
      for (int k = 0; k < 3; ++k)
      {
        axis[r] += placement->GetElement(r, k) * g.direction[3 * k + c] * g.spacing[c];
      }
    }
    const double length = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    p.spacing[c] = length; // 0 for a zero scale: the renderer says the geometry is singular
    for (int r = 0; r < 3; ++r)
    {
      p.direction[3 * r + c] = length > 0 ? axis[r] / length : (r == c ? 1.0 : 0.0);
    }
  }
  return out;
}

bool usablePlacement(vtkMatrix4x4* placement)
{
  for (int i = 0; placement && i < 16; ++i)
  {
    if (!(std::abs(placement->GetData()[i]) <= kLargestPlacement)) // NaN fails too
    {
      return false;
    }
  }
  return true;
}

bool placeBounds(vtkMatrix4x4* placement, double bounds[6])
{
  if (!placement || placement->IsIdentity())
  {
    return true;
  }
  double lo[3], hi[3];
  for (int k = 0; k < 3; ++k)
  {
    lo[k] = std::numeric_limits<double>::infinity();
    hi[k] = -lo[k];
  }
  for (int corner = 0; corner < 8; ++corner)
  {
    const double in[4] = { bounds[(corner & 1) ? 1 : 0], bounds[(corner & 2) ? 3 : 2], bounds[(corner & 4) ? 5 : 4], 1.0 };
    double out[4];
    placement->MultiplyPoint(in, out);
    for (int k = 0; k < 3; ++k)
    {
      lo[k] = std::min(lo[k], out[k]);
      hi[k] = std::max(hi[k], out[k]);
    }
  }
  bool finite = true;
  for (int k = 0; k < 3; ++k)
  {
    bounds[2 * k] = lo[k];
    bounds[2 * k + 1] = hi[k];
    finite = finite && std::isfinite(lo[k]) && std::isfinite(hi[k]);
  }
  return finite && usablePlacement(placement);
}

std::string VolumeCache::resolve(vtkImageData* image, const std::string& labelArray, VolumeSource& out)
{
  out = VolumeSource{};
  if (!image || image->GetNumberOfPoints() == 0)
  {
    return "the input is empty";
  }
  std::lock_guard<std::mutex> lock(this->Mutex);

  // The reader's encoding: the key is the array and its modification time, so a hit parses
  // nothing; only a new or modified encoding is parsed.
  vtkFieldData* fd = image->GetFieldData();
  vtkUnsignedCharArray* encoding = csgvvtk::encodingArray(fd);
  // Kept for the case where no label array stands in for a corrupt encoding: the user then needs
  // the parse error, not "no CSGV encoding".
  std::string encodingError;
  if (encoding && (labelArray.empty() || labelArray == csgvvtk::kLabelsName))
  {
    const Key key{ encoding, encoding->GetMTime(), 0, { { 0, 0, 0 } } };
    std::shared_ptr<SharedVolume> shared = this->lookup(key);
    if (!shared)
    {
      auto parsed = std::make_shared<SharedVolume>();
      encodingError = parseEncoding(fd, *parsed);
      if (encodingError.empty())
      {
        this->Parses++;
        // The arrays view the reader's bytes (one copy of the encoding in this process), or
        // were copied (an encoding array delivered from elsewhere).
        if (std::all_of(parsed->volume.arrays.begin(), parsed->volume.arrays.end(),
              [](const csgv::WordArray& a) { return a.isView(); }))
        {
          this->SharedParses++;
        }
        shared = parsed;
        this->Entries[key] = shared;
      }
      else
      {
        encodingError = "the input's CSGVEncoding FieldData array is unusable: " + encodingError;
      }
    }
    if (shared &&
      csgvvtk::encodingDescribes(
        image, shared->encodedGeometry, shared->owned.empty() ? shared->volume.dim : shared->pieceDims))
    {
      out.shared = shared;
      out.corner = drawnCorner(*shared);
      return std::string();
    }
    // Derived images (Extract's sub-boxes) carry the FieldData too: they show their array.
  }

  bool isCell = true;
  vtkDataArray* array = csgvvtk::findLabelArray(image, labelArray, isCell);
  if (!array)
  {
    if (!encodingError.empty())
    {
      return encodingError;
    }
    return missingLabelArray(labelArray, true);
  }
  std::array<uint32_t, 3> dims;
  out.corner = csgvvtk::imageGeometry(image, isCell, dims);
  const Key key{ array, array->GetMTime(), isCell ? 1 : 2, dims };
  int brick = 0, pieces = 0, piece = 0, whole[6];
  const bool isPiece = csgvvtk::brickPiece(fd, brick, pieces, piece, whole);
  out.shared = this->lookup(key);
  if (out.shared)
  {
    if (isPiece)
    {
      out.corner = drawnCorner(*out.shared);
    }
    return std::string();
  }
  auto shared = std::make_shared<SharedVolume>();
  this->Compressions++;
  if (isPiece)
  {
    bool drawn = false;
    const std::string error =
      compressPiece(image, array, isCell, out.corner, brick, pieces, piece, whole, *shared, drawn);
    if (!error.empty() || !drawn)
    {
      out.shared = nullptr;
      return error;
    }
    this->Entries[key] = shared;
    out.shared = shared;
    out.corner = drawnCorner(*shared);
    return std::string();
  }
  const std::string error = compressArray(array, dims, *shared);
  if (!error.empty())
  {
    return error;
  }
  this->Entries[key] = shared;
  out.shared = shared;
  return std::string();
}

std::string VolumeCache::resolveAgreed(
  vtkImageData* image, const std::string& labelArray, vtkMultiProcessController* controller, VolumeSource& out)
{
  out = VolumeSource{};
  std::lock_guard<std::mutex> lock(this->Mutex);
  bool isCell = true;
  vtkDataArray* array = image ? csgvvtk::findLabelArray(image, labelArray, isCell) : nullptr;
  int brick = 0, pieces = 0, piece = 0, whole[6];
  const bool isPiece = image && csgvvtk::brickPiece(image->GetFieldData(), brick, pieces, piece, whole);
  csgvvtk::MpiAgreement agreement(controller, uint32_t(std::max(brick, 1)), false);
  std::string error;
  auto shared = std::make_shared<SharedVolume>();
  bool drawn = false;
  std::array<uint32_t, 3> dims{};
  if (!array || !isPiece)
  {
    error = !array ? missingLabelArray(labelArray, false) : "the input is not a piece of an image";
  }
  else
  {
    out.corner = csgvvtk::imageGeometry(image, isCell, dims);
    this->Compressions++;
    error = compressPiece(image, array, isCell, out.corner, brick, pieces, piece, whole, *shared, drawn, &agreement);
  }
  agreement.catchUp(error.empty());
  if (!error.empty() || !drawn)
  {
    out = VolumeSource{};
    return error;
  }
  this->Entries[Key{ array, array->GetMTime(), isCell ? 1 : 2, dims }] = shared;
  out.shared = shared;
  out.corner = drawnCorner(*shared);
  return std::string();
}

} // namespace csgvrep
