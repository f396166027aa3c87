// SPDX-License-Identifier: MIT
/**
 * @file CSGVQueryProtocol.h
 * @brief The query protocol of the Segmentation Volume, in one place: every command vtkCSGVQuery
 * carries from the client to the rendering process, its arguments and its reply.
 *
 * Why a text protocol and not typed calls: ParaView 5.11's client/server wrapping moves
 * arguments to the server, but results come back to the client only through information
 * properties read from the rendering process (vtkCSGVQuery's `Result`), and a pick's reply is a
 * structured record (label, voxel, world point, attributes) that the wrapper cannot type. So the
 * request is one string and every reply is one string: JSON, except `labels`.
 * Users: Examples/csgv_tools.py and Plugin/CSGV/pqCSGVPickPanel.cxx. Keep replies compatible
 * (add keys, never rename). Each command has a test in Testing/ParaView/test_repr_query.py.
 *
 * Commands (words separated by blanks; pixels count from the bottom-left of the last render):
 *
 * | request      | reply |
 * |--------------|-------|
 * | `summary`    | JSON `{"attributes": [{"name", "numeric", "min", "max"}...], "labels": count of labels present, "labelArray": the label array's name, "empty": true when there is no input or it has no voxels (every rank's, under MPI), "error": why attributes failed (only then; under MPI a rank with data's, or "rank N: ..." where a rank's reader failed), "failed": why the reader failed (only then; under MPI the first failed rank's, "rank N: ..."), "skipped": why materials are not drawn (only then)}` |
 * | `pick X Y`   | JSON `{"hit": bool, "label": the drawn label (the first opaque surface's, else the first semi-transparent one's: the label materials and selections name, an id where the volume's labels do not fit 32 bits, csgvrep::drawsIds), "original": the voxel's own label (the same, else the id's original, then also as decimal text "originalText"), "translucent": bool (the latter), "depth": window depth, "voxel": [i, j, k], "world": [x, y, z], "attributes": {name: value or text}, "error": (only then)}`; `{"hit": false, "error": "no rendered pixel there"}` outside the last render |
 * | `labels`     | text `W H BASE64`: the last render's label image, uint32 little-endian, row 0 at the bottom, the pick's label per pixel, 0xFFFFFFFF where nothing was hit (base64 by vtkBase64Utilities) |
 * | `colors N`   | JSON `{"labels": [[label, r, g, b, "name"]...] (ascending original labels, as the label array holds them), "truncated": bool, "text": attribute naming labels}` for at most N (default 4096) labels present that the volume shows: a material of non-zero opacity takes them in the drawn document (csgv::effectiveMaterials: hidden labels and labels outside "only" are left out) |
 * | `span {"attribute": A, "filter": F, "min": lo, "max": hi}` | JSON `{"min", "max", "labels"}`: the range of A over the labels present whose F lies in [lo, hi] (null ends when none), every rank's widened |
 * | `match SQL`  | JSON `{"labels": [drawn labels (as a pick's "label"), ascending], "truncated": bool}`: the labels whose attributes make the SQL condition true (csgv::labelsWhere over the representation's attribute table: database, loaded, computed and derived columns), at most csgv::kMaxOverlayLabels; `{"error": ...}` for a condition SQLite refuses; every rank's labels united |
 * | `defaults`   | JSON of the representation's property defaults (csgvrep::RepresentationProperties): `{"CSGVShading": 0, ...}` keyed like the server-manager XML, for the test that keeps both equal |
 * | `labelset N`  | text `BASE64`: at most N original labels present in this process's volume, int64 little-endian, ascending (the label count of `summary` over MPI ranks) |
 * | `render`     | JSON of the read-only statistics, keyed as their information properties (`{"CSGVFramesLastRender": n, "CSGVMinSamples": n, "CSGVCacheMiB": x, ...}`, csgvrep::renderStatistics): read through here, they reach a client of a remote server (a representation's own information properties are read from the client's copy, which never renders) and combine MPI ranks: the fewest samples of the ranks that rendered, the most frames, memory (budgets too) and bad bricks summed, flags and levels their largest |
 * | `stats`      | JSON `{"parses": n, "sharedParses": n, "compressions": n}`: how often this process parsed a CSGV encoding (of those, how often its words were viewed where the reader put them, not copied) and compressed a label array for the representation (each happens once per array and modification time; for tests and benchmarks) |
 * | other        | JSON `{"error": "unknown query '<word>'"}` |
 *
 * Under MPI (vtkCSGVQuery pushed to every rank) `pick`, `labels`, `summary`, `colors`, `span`, `match` and `render` are
 * answered by all ranks together: the hit per pixel a single rank reports (csgvrep::hitOrder:
 * the nearest opaque one, else the nearest semi-transparent one), attribute ranges and label sets
 * over all pieces (combineAnswers); every rank reads that answer (pvbatch --symmetric scripts).
 *
 * Not a wrapped header: Core and VulkanBackend types may appear here.
 */
#ifndef CSGVQueryProtocol_h
#define CSGVQueryProtocol_h

#include "CSGVAttributes.h"
#include "CSGVHitOrder.h"
#include "CSGVViewRenderer.h"
#include "CSGVVolumeCache.h"

#include "csgv/materials/Materials.h"

#include <string>
#include <vector>

class vtkImageData;

namespace csgvrep
{

/// @brief What a query reads: the prop's state on the rendering process.
struct QueryContext
{
  vtkImageData* input = nullptr; ///< the image shown (its FieldData attributes)
  VolumeSource source;           ///< empty when the input did not resolve
  std::string sourceError;       ///< why it did not
  bool emptyInput = false;       ///< no input, or one without voxels (a file that failed to read)
  std::string readError;         ///< why the reader failed (csgvvtk::readErrorOf), else ""
  const csgv::MaterialDocument* materials = nullptr; ///< what is drawn; null when the document is invalid
  const std::vector<std::string>* skipped = nullptr;  ///< why materials of the document are not drawn
  AttributeCache* attributes = nullptr;
  const AttributeConfig* config = nullptr;
  ViewRenderer* view = nullptr; ///< the last render (label image, G-buffer, camera)
  bool drawn = true;            ///< the view's last render drew it (else no pixels to answer)
};

/// The representation's read-only statistics (its information properties) after the last render.
struct RenderStatistics
{
  int framesLastRender = 0, minSamples = 0, cacheBits = 0, detailSeparated = 0, levelsOnDisk = 0, badBricks = 0;
  double cacheMiB = 0, deviceMiB = 0, deviceBudgetMiB = 0, detailStreamedMiB = 0, fileReadMiB = 0;
  std::string labelLookup; ///< ViewRenderer::labelLookup
};
RenderStatistics renderStatistics(const ViewRenderer& view);

/// Answers one request of the table above.
std::string answerQuery(const std::string& request, QueryContext& context);

/// One reply to `summary` or `colors N` from the replies of every rank (each holding a piece):
/// attribute ranges widened, label counts and colour lists over the union of the ranks' labels
/// (`labelSets`: each rank's labels, labelSetOf its `labelset` reply, for `summary`).
std::string combineAnswers(const std::string& request, const std::vector<std::string>& answers,
  const std::vector<std::vector<int64_t>>& labelSets);

/// The labels of a `labelset` reply (base64 of int64 little-endian; an error or "" gives none).
std::vector<int64_t> labelSetOf(const std::string& reply);

/// The base64 text of bytes (vtkBase64Utilities, padded with '=').
std::string base64(const void* data, size_t bytes);

} // namespace csgvrep

#endif
