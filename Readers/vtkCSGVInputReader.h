// SPDX-License-Identifier: MIT
/**
 * @class vtkCSGVInputReader
 * @brief Opens any segmentation Core reads (HDF5, TIFF, Zarr, Neuroglancer precomputed, NRRD,
 * NIfTI, `.vraw`) by compressing it once to a cached `.csgv` in bounded memory and reading that
 * file with vtkCSGVReader, so the output is exactly a `.csgv` reader's (image data, labels as cell
 * data, the encoding in FieldData; see vtkCSGVReader.h) and a volume larger than memory opens like
 * a small one.
 *
 * Its family in ParaView is every input without a reader of its own: `.vraw` belongs to
 * vtkCSGVReader and NIfTI to vtkCSGVNIfTIReader, so CanReadFile refuses those two (the reader
 * factory then offers one reader per file); a script that names one here still gets it compressed.
 * Where inputs and caches live and the stamp are in CSGVInputCache.h; this class is the pipeline.
 *
 * FileName takes every form csgv::openInput() takes (`FILE.h5[:/dataset]`, `DIR.zarr[/path]`, a
 * precomputed or TIFF folder, a slice glob...). ParaView's file dialog picks files, not folders, so
 * a `.zarray`, `.zgroup` or `.zattrs` file stands for its Zarr folder and a precomputed `info` file
 * for its folder.
 *
 * File series (FileNames; why: ParaView's file dialog groups `slice_0000.tif` ... `slice_0127.tif`
 * into one entry and hands the whole group to the reader's repeatable file-name property, see
 * CSGVReaders.xml): one name is read as FileName would be. Several names are, as in ParaView's
 * own TIFF Series Reader:
 * - an image stack when ReadAsImageStack is on (default) and the first file is a single-page (2D)
 *   TIFF: file i is slice z = i of one volume, in the order given (csgv::openTiffSlices; every
 *   slice must match the first one's size and type, and an error names the one that differs);
 * - a time series otherwise (the first file is a 3D volume: a multi-page TIFF, HDF5, NRRD...; or
 *   ReadAsImageStack is off): file i is time step i (TIME_STEPS 0, 1, ..., N - 1), each compressed
 *   to its own cache when its time is first shown.
 * FileName and FileNames are not merged: FileName beside several FileNames is an error, so that
 * no file is silently left out; beside one (OpenDataFile's, then a script's FileName), FileName
 * is read (CSGVFileSeries.h).
 *
 * Cache (why: compressing a large volume takes minutes; opening the `.csgv` takes seconds):
 * - Where: with CacheDirectory empty (default), beside the input as `<input>.csgv` when the input's
 *   folder is writable (for a path inside a `.zarr` store, beside the store, `<store>_<path>.csgv`;
 *   for `FILE.h5:/dataset`, `FILE.h5_dataset.csgv`; for a stack `slice_0000.tif` ..
 *   `slice_0127.tif`, `slice_0000-0127.csgv` beside the first slice), otherwise in `$XDG_CACHE_HOME` (or
 *   `~/.cache`) `/csgv-paraview/<hash of the absolute input path>.csgv`. A non-empty
 *   CacheDirectory always holds the hashed name. Sidecars `.csgv.json` and `_csgv.db3` go with it.
 * - Reuse: `<cache>.stamp` records the input path, the options that shape the encoding (Relabel,
 *   BrickSize) and the input's state: size and modification time of a file, or for a folder the
 *   number of files under it, their total size and the newest modification time (for a stack,
 *   the same over its slice files, whose list the stamp records in order); and the
 *   identity (inode, size, modification time) of the `.csgv` it was written for, so that with two
 *   writers racing a stamp never vouches for the other writer's `.csgv`. The cache is reused while
 *   the stamp matches the input and the `.csgv`; otherwise the input is compressed again. A
 *   folder's state is gathered once per update (RequestData reuses RequestInformation's while the
 *   reader and the folder's own stat are unchanged). The stamp is written only after a successful compression, and Core writes
 *   every file under a temporary name first, so an interrupted or failed compression never leaves
 *   a `.csgv` that looks valid.
 *
 * When things run: RequestInformation reads only the input's header (csgv::openInput) or, with a
 * valid cache, the `.csgv`, so that ParaView knows extent and geometry before Apply;
 * RequestData compresses when needed (this is what the progress bar shows: 0..0.9 compression,
 * 0.9..1 reading the `.csgv`) and then reads the `.csgv`. Setting AbortExecute (a progress
 * observer may) cancels the compression cleanly.
 *
 * Errors (unsupported or malformed input, unwritable cache, cancellation) are reported with
 * vtkErrorMacro carrying Core's message, and the output is empty; the session goes on.
 *
 * Limitations: with several MPI ranks and no valid cache, every rank compresses (to the same
 * names; Core's renames keep each file whole). Open the input once in a serial session first.
 * The cache is never deleted by the reader.
 */
#ifndef vtkCSGVInputReader_h
#define vtkCSGVInputReader_h

#include "CSGVReadersModule.h"
#include "vtkImageAlgorithm.h"

#include <string> // for ChooseInputs

class CSGVREADERS_EXPORT vtkCSGVInputReader : public vtkImageAlgorithm
{
public:
  static vtkCSGVInputReader* New();
  vtkTypeMacro(vtkCSGVInputReader, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  /// The input, in any form csgv::openInput() accepts (see the class comment).
  vtkSetStringMacro(FileName);
  vtkGetStringMacro(FileName);

  /// The inputs of a file series, in order (ParaView's repeatable FileNames property; see the
  /// class comment). Empty by default; when it holds several, FileName must be empty.
  void AddFileName(const char* fileName);
  void RemoveAllFileNames();
  int GetNumberOfFileNames();
  /// Entry `index` of FileNames (null outside [0, GetNumberOfFileNames())).
  const char* GetFileNameAt(int index);

  /// Several FileNames whose first is a single-page TIFF: on (default) reads them as the z slices
  /// of one volume; off reads every file as one time step (ParaView's ReadAsImageStack).
  vtkSetMacro(ReadAsImageStack, vtkTypeBool);
  vtkGetMacro(ReadAsImageStack, vtkTypeBool);
  vtkBooleanMacro(ReadAsImageStack, vtkTypeBool);

  /// How the last RequestInformation read its inputs: 0 nothing (no valid input), 1 one input,
  /// 2 an image stack of several TIFF slices, 3 a time series of several inputs.
  vtkGetMacro(SeriesMode, int);

  /// Relabel to dense ids even when the labels fit the format (default off; labels that do not
  /// fit, such as 64-bit or negative ones, are always relabelled).
  vtkSetMacro(Relabel, vtkTypeBool);
  vtkGetMacro(Relabel, vtkTypeBool);
  vtkBooleanMacro(Relabel, vtkTypeBool);

  /// Read files that the dataset names outside its own folder (an NRRD `data file:`, a precomputed
  /// scale key, an OME-Zarr path, HDF5 external storage); default off, so that a file cannot
  /// make ParaView read another one the user never chose (`csgv --allow-outside-paths`).
  vtkSetMacro(AllowOutsidePaths, vtkTypeBool);
  vtkGetMacro(AllowOutsidePaths, vtkTypeBool);
  vtkBooleanMacro(AllowOutsidePaths, vtkTypeBool);

  /// Brick size of the encoding, a power of two in [8, 128] (default 32).
  void SetBrickSize(int value); ///< held to [8, 128], with a warning (CSGVHeldValue.h)
  vtkGetMacro(BrickSize, int);

  /// Folder for cached `.csgv` files; empty (default) means beside the input when writable,
  /// otherwise `$XDG_CACHE_HOME/csgv-paraview` (or `~/.cache/csgv-paraview`).
  vtkSetStringMacro(CacheDirectory);
  vtkGetStringMacro(CacheDirectory);

  /// Passed to the internal vtkCSGVReader (same meaning and defaults there).
  vtkSetMacro(DecodeLabels, vtkTypeBool);
  vtkGetMacro(DecodeLabels, vtkTypeBool);
  vtkBooleanMacro(DecodeLabels, vtkTypeBool);
  void SetDecodeThreshold(vtkIdType value); ///< held to [0, VTK_ID_MAX], with a warning (CSGVHeldValue.h)
  vtkGetMacro(DecodeThreshold, vtkIdType);
  void SetLevel(int value); ///< held to [0, 7], with a warning (CSGVHeldValue.h)
  vtkGetMacro(Level, int);

  /// The `.csgv` the last request used or would use (empty before RequestInformation).
  const char* GetCachedFileName();

  /// 1 if the last RequestData compressed the input, 0 if it reused the cache.
  vtkGetMacro(Compressed, int);

  /// 1 when `fileName` is in a form Core opens (after mapping Zarr metadata and precomputed `info`
  /// files to their folders), exists and is neither `.vraw` nor NIfTI (their own readers' family);
  /// says nothing about whether its content is valid.
  virtual int CanReadFile(const char* fileName);

protected:
  vtkCSGVInputReader();
  ~vtkCSGVInputReader() override;

  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  /// A time series switches to the file of the requested time step here (announcing its extent).
  /// Time-dependent information, as vtkCSGVReader (SwitchStep there).
  vtkTypeBool ProcessRequest(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  /// A time series: the whole extent that holds every step, for consumers (RequestInformation).
  void AnnounceEveryStep(vtkInformation* outInfo);
  void SwitchStep(vtkInformation* outInfo);
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  char* FileName = nullptr;
  vtkTypeBool Relabel = 0;
  vtkTypeBool AllowOutsidePaths = 0;
  int BrickSize = 32;
  char* CacheDirectory = nullptr;
  vtkTypeBool DecodeLabels = 1;
  vtkIdType DecodeThreshold = vtkIdType(512) * 1024 * 1024;
  int Level = 0;
  int Compressed = 0;
  vtkTypeBool ReadAsImageStack = 1;
  int SeriesMode = 0;

private:
  vtkCSGVInputReader(const vtkCSGVInputReader&) = delete;
  void operator=(const vtkCSGVInputReader&) = delete;

  /// Compresses the input to the cache and stamps it; false (reported) on error or cancellation.
  bool Compress();
  /// Which inputs FileName and FileNames name and how they are read (SeriesMode); false with
  /// `error` set when they conflict, are empty, or the first one cannot be opened.
  bool ChooseInputs(std::string& error);
  /// Locates the current input (the one input, the stack, or the current time step's file),
  /// chooses its cache and announces its extent and geometry in `outInfo`; errors are reported
  /// and leave the extent empty.
  void PrepareInput(vtkInformation* outInfo);
  /// Remembers that the current request failed (see vtkInternals::FailedMTime).
  void RememberFailure();
  /// Reports a failure (vtkErrorMacro) and keeps its words: RequestData marks the empty output
  /// with them (csgvvtk::markReadError), so a Segmentation Volume's summary says why, under MPI
  /// with the failing rank.
  void ReportFailure(const std::string& message);

  class vtkInternals;
  vtkInternals* Internals;
};

#endif
