// SPDX-License-Identifier: MIT
/**
 * @class vtkCSGVRepresentation
 * @brief The "Segmentation Volume" representation: image data whose labels are drawn voxel by
 * voxel by VulkanBackend (local shading, shadows, ambient occlusion or path tracing) and
 * composited with depth into ParaView's render view.
 *
 * Input: image data carrying the CSGV reader's encoding in its FieldData (used without
 * decoding), or any one-component integer (or integer-valued float) cell or point array, which
 * is compressed once with Core's encoder and cached until it changes (process-wide: several
 * views of one source share one compression and one upload). Point data is drawn with voxel
 * (i,j,k) centred on point (i,j,k), cell data with voxel (i,j,k) filling cell (i,j,k).
 *
 * Data stays on the rendering processes (client/server: the server renders and the client
 * receives images). Every property below resets the accumulation when it changes.
 * The drawing itself, including which render pass is used, is described in vtkCSGVVolumeProp.h.
 */
#ifndef vtkCSGVRepresentation_h
#define vtkCSGVRepresentation_h

#include "CSGVRepresentationModule.h"
#include "vtkPVDataRepresentation.h"
#include "vtkSmartPointer.h" // for Cache

#include <string> // for ivars
#include <vector> // for ivars

class vtkCSGVVolumeProp;
class vtkImageData;

class CSGVREPRESENTATION_EXPORT vtkCSGVRepresentation : public vtkPVDataRepresentation
{
public:
  static vtkCSGVRepresentation* New();
  vtkTypeMacro(vtkCSGVRepresentation, vtkPVDataRepresentation);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  int ProcessViewRequest(vtkInformationRequestKey* request, vtkInformation* inInfo,
    vtkInformation* outInfo) override;
  void SetVisibility(bool visible) override;

  /// The display's Transforming properties (ParaView's Position, Orientation, Scale and Origin,
  /// shared with the surface representation): the volume is drawn, picked and bounded where
  /// they place it, as vtkProp3D places an actor (its voxels, clip box and attributes stay).
  void SetPosition(double x, double y, double z);
  void SetOrientation(double x, double y, double z);
  void SetScale(double x, double y, double z);
  void SetOrigin(double x, double y, double z);

  /// Label array by name ("": the CSGV encoding if present, else the first integer array).
  void SetLabelArray(const char* name);
  const char* GetLabelArray() { return this->LabelArray.c_str(); }

  // The properties below (the rows of CSGVProperties.def, which holds their defaults) are
  // gathered into the backend's settings once per render.


  /// 0 local, 1 shadow, 2 ambient occlusion, 3 path tracing (default 0).
  vtkSetMacro(Shading, int);
  vtkGetMacro(Shading, int);
  /// 0: local shading only ... 1: the chosen shading mode only (default 1).
  vtkSetMacro(ShadingBlend, double);
  vtkGetMacro(ShadingBlend, double);
  /// Samples per pixel a still render accumulates within StillRenderTimeBudget (default 16).
  vtkSetMacro(FramesPerStillRender, int);
  vtkGetMacro(FramesPerStillRender, int);
  /// Seconds a still render may spend accumulating past the first complete sample (default 3).
  vtkSetMacro(StillRenderTimeBudget, double);
  vtkGetMacro(StillRenderTimeBudget, double);
  /// Added to log2(pixel footprint / voxel) when choosing levels of detail (< 0: finer; default 0).
  vtkSetMacro(LODBias, double);
  vtkGetMacro(LODBias, double);
  /// 1, 2, 4 or 8: a frame renders 1/s^2 of the pixels (default 1).
  vtkSetMacro(Subsampling, int);
  vtkGetMacro(Subsampling, int);
  /// A-trous denoising of ambient occlusion and path tracing (default on).
  vtkSetMacro(Denoise, int);
  vtkGetMacro(Denoise, int);
  /// Direction towards the key light in view coordinates (x right, y up, z to the viewer;
  /// default 0.35 0.6 0.72).
  vtkSetVector3Macro(LightDirection, double);
  vtkGetVector3Macro(LightDirection, double);
  /// Brick cache budget in MiB, shared by the views of one volume (default 0: automatic, 256 MiB
  /// on CPU devices, else a quarter of what the device reports this process may use, divided
  /// among the ranks of an MPI job, 256 MiB to 2 GiB; csgv::gpu::automaticCacheBytes).
  vtkSetMacro(CacheSizeMiB, int); // toViewSettings holds it (CSGVProperties.def), saying so
  vtkGetMacro(CacheSizeMiB, int);
  /// Device-memory budget in MiB for everything this volume's renderers allocate, the encoding
  /// included, shared by its views (default 0: automatic, three quarters of what the device
  /// reports this process may use). The cache takes what the rest leaves, up to CacheSizeMiB;
  /// an encoding larger than the budget is reported and nothing is drawn.
  vtkSetMacro(DeviceMemoryMiB, int); // toViewSettings holds it (CSGVProperties.def), saying so
  vtkGetMacro(DeviceMemoryMiB, int);
  /// Host-memory budget in MiB for the encoding (default 0: automatic, half the memory available
  /// when the volume is uploaded). A `.csgv` (rANS two-table, memory-mapped by the reader) larger
  /// than the budget keeps its coarse levels in memory when they fit it and reads the finest
  /// level (else every level) from the file on demand (csgv::TieredVolume).
  vtkSetMacro(HostMemoryMiB, int); // toViewSettings holds it (CSGVProperties.def), saying so
  vtkGetMacro(HostMemoryMiB, int);
  /// Where bricks are decoded: 0 automatic (the host on CPU devices), 1 the GPU (with detail
  /// streaming when the budget separates the finest level), 2 the host.
  vtkSetMacro(Decoding, int); // toViewSettings holds it (CSGVProperties.def), saying so
  vtkGetMacro(Decoding, int);
  /// GPU decoding: decoder steps a brick takes a frame, its decoding going on in the next frames
  /// (csgv::gpu::RendererOptions::decodeStepsPerFrame): 0 automatic (default), 1000000 every step.
  vtkSetMacro(DecodeStepsPerFrame, int); // toViewSettings holds it (CSGVProperties.def), saying so
  vtkGetMacro(DecodeStepsPerFrame, int);
  /// Cache paletting (the paper's): the brick cache holds packed indices into each brick's
  /// palette instead of 32-bit labels, several times more bricks in the same memory, at the cost
  /// of one more read per voxel. 0 off, 1 on, 2 automatic (default): on once the cache of labels
  /// runs full. Volumes whose palettes are too large for two indices to share a word keep labels.
  vtkSetMacro(CachePaletting, int); // toViewSettings holds it (CSGVProperties.def), saying so
  vtkGetMacro(CachePaletting, int);
  /// Voxel box drawn, inclusive: xmin xmax ymin ymax zmin zmax (clamped to the volume; default
  /// the whole volume).
  vtkSetVector6Macro(ClipBox, int);
  vtkGetVector6Macro(ClipBox, int);
  /// Seconds a still render may take where the application renders again until the volume
  /// converges (ParaView's GUI); 0: the whole StillRenderTimeBudget (default 0).
  vtkSetMacro(RefinementSlice, double); // toViewSettings holds it (CSGVProperties.def), saying so
  vtkGetMacro(RefinementSlice, double);
  /// The material document of MATERIALS.md ("": the default document); ParaView preset names
  /// are resolved here. A malformed document is reported and nothing is drawn.
  void SetMaterials(const char* json);

  /// Per-label attributes besides the input's own (the `_csgv.db3` columns the reader puts in
  /// the FieldData): tables read on the rendering process (CSV, whitespace tables such as
  /// MRIcron's `aal.nii.txt`, SQLite), computed attributes (voxel_count, surface_area, bbox_*,
  /// centroid_*; computed once per volume) and derived attributes (name = SQL expression over the
  /// others). Materials may name any of them.
  void AddAttributeFile(const char* path);
  void ClearAttributeFiles();
  void AddDerivedAttribute(const char* name, const char* expression);
  void ClearDerivedAttributes();
  /// Under MPI with pieces of a .csgv, the ranks compute them together (whole-volume values).
  void SetComputedAttributes(int on);
  vtkGetMacro(ComputedAttributes, int);

  /// Answers vtkCSGVQuery's requests (the commands: CSGVQueryProtocol.h); the text stays valid
  /// until the next call.
  const char* Query(const char* request);

  /// Frames the last render accumulated and the fewest samples of any pixel after it (valid on
  /// the rendering process).
  int GetFramesLastRender();
  int GetMinSamples();
  /// This view's brick cache and its whole device memory in MiB (the views of one volume split
  /// CacheSizeMiB and share one upload of the encoding).
  double GetCacheMiB();
  double GetDeviceMiB();
  /// This view's device-memory budget in MiB (its share of DeviceMemoryMiB or the automatic one).
  double GetDeviceBudgetMiB();
  /// Bits per voxel of this view's brick cache: 32 (labels) or fewer (cache paletting); 0 before
  /// the first render.
  int GetCacheBits();
  /// 1 when the device holds the encoding without its finest level (detail separation: the
  /// encoding would take more than half of DeviceMemoryMiB): with GPU decoding its streams are
  /// uploaded as views need them (detail streaming), host decoding reads them in host memory.
  int GetDetailSeparated();
  /// MiB of finest-level streams this view uploaded to the device (detail streaming, GPU
  /// decoding of a separated volume) since its renderer was made.
  double GetDetailStreamedMiB();
  /// Where the encoding is read from (HostMemoryMiB): 0 all in host memory, 1 the coarse levels
  /// in memory and the finest level from the file, 2 every level from the file.
  int GetLevelsOnDisk();
  /// MiB this volume read from its file on demand (levels on disk), since they were split.
  double GetFileReadMiB();
  /// Bricks this view failed to decode (a corrupt or cut-short file): drawn empty, reported once.
  int GetBadBricks();
  /// The last render's first-hit labels and their order (csgvrep::hitOrder; vtkCSGVQuery combines
  /// ranks with them).
  bool LastLabels(uint32_t& width, uint32_t& height, std::vector<uint32_t>& labels, std::vector<float>& depths);

protected:
  vtkCSGVRepresentation();
  ~vtkCSGVRepresentation() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  /// With several MPI ranks, an input that does not hand out pieces itself (the CSGV reader does:
  /// whole bricks of its file) is asked for this rank's whole bricks of its whole extent
  /// (csgvvtk::brickPieceExtent with the encoder's brick size, exactly: a source that makes more
  /// is cropped), so that each rank compresses its bricks and draws them in the whole image's
  /// index space.
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  bool AddToView(vtkView* view) override;
  bool RemoveFromView(vtkView* view) override;

private:
  vtkCSGVRepresentation(const vtkCSGVRepresentation&) = delete;
  void operator=(const vtkCSGVRepresentation&) = delete;

  void PushAttributes();
  /// Resolves the input once per (image, modification time, label array) and, when `report`,
  /// reports a failure once; returns true when there is something to draw. A query does not
  /// report: its answer holds the error, and a display shown as something else (an Outline of a
  /// float image, whose hidden Segmentation Volume the GUI's panels ask) has nothing to report.
  bool ResolveInput(vtkImageData* image, bool report = true);
  /// Reports the input's error once (each new one; none again until it changes).
  void ReportInputError();
  /// Under MPI, what the ranks holding pieces of one volume share, once per data update
  /// (collective; `resolved`: this rank has a volume): the ids of a plain image relabelled piece
  /// by piece (VolumeCache::resolveAgreed), the labels beyond each piece (ghost faces) and, when
  /// asked for, the computed attributes summed over the ranks.
  void ShareAcrossRanks(bool resolved);

  vtkSmartPointer<vtkImageData> Cache;
  vtkCSGVVolumeProp* Prop;
  std::string LabelArray;
  // Initialised from CSGVProperties.def's defaults in the constructor.
  int Shading;
  double ShadingBlend;
  int FramesPerStillRender;
  double StillRenderTimeBudget;
  double LODBias;
  int Subsampling;
  int Denoise;
  double LightDirection[3];
  int CacheSizeMiB;
  int DeviceMemoryMiB;
  int HostMemoryMiB;
  int Decoding;
  int DecodeStepsPerFrame;
  int CachePaletting;
  int ClipBox[6];
  double RefinementSlice;
  std::vector<std::string> AttributeFiles;
  std::vector<std::string> DerivedAttributes; ///< name, expression, name, expression...
  int ComputedAttributes;
  std::string QueryResult;
  std::string SettingsNotes; ///< the last settings warned about (toViewSettings' notes)

  struct vtkInternals;
  vtkInternals* Internals;
};

#endif
