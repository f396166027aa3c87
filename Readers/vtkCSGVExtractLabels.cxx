// SPDX-License-Identifier: MIT
#include "vtkCSGVExtractLabels.h"

#include "CSGVHeldValue.h"

#include "CSGVAdapter.h"

#include "csgv/codec/Extract.h"

#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkDiscreteFlyingEdges3D.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkImageData.h>
#include <vtkMultiBlockDataSet.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkStreamingDemandDrivenPipeline.h>
#include <vtkStringArray.h>
#include <vtkTypeInt64Array.h>
#include <vtkTypeUInt32Array.h>
#include <vtkUnsignedCharArray.h>
#include <vtkQuadricDecimation.h>
#include <vtkWindowedSincPolyDataFilter.h>
#include <vtkSmartPointer.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <set>

vtkStandardNewMacro(vtkCSGVExtractLabels);
csgvHeldSetter(vtkCSGVExtractLabels, OutputType, int, MESHES, LABEL_IMAGE)
csgvHeldSetter(vtkCSGVExtractLabels, Level, int, 0, 7)
csgvHeldSetter(vtkCSGVExtractLabels, Smoothing, int, 0, 200)
csgvHeldSetter(vtkCSGVExtractLabels, Decimation, double, 0.0, 0.95)
csgvHeldSetter(vtkCSGVExtractLabels, MaxLabels, int, 1, VTK_INT_MAX)
csgvHeldSetter(vtkCSGVExtractLabels, MaxOutputMiB, int, 1, VTK_INT_MAX)

class vtkCSGVExtractLabels::vtkInternals
{
public:
  csgvvtk::EncodingMemo Encoding;
};

namespace
{

/// "3, 17 40" -> {3, 17, 40}; false with the first word that is not an integer.
bool parseLabels(const std::string& text, std::vector<int64_t>& out, std::string& bad)
{
  std::string word;
  auto flush = [&]() {
    if (word.empty())
    {
      return true;
    }
    char* end = nullptr;
    errno = 0;
    const long long v = std::strtoll(word.c_str(), &end, 10);
    if (errno != 0 || !end || *end != '\0')
    {
      bad = word;
      return false;
    }
    out.push_back(int64_t(v));
    word.clear();
    return true;
  };
  for (char c : text)
  {
    if (std::isspace(static_cast<unsigned char>(c)) || c == ',' || c == ';')
    {
      if (!flush())
      {
        return false;
      }
    }
    else
    {
      word += c;
    }
  }
  return flush();
}

/// Labels extracted one by one (each in its own bounding box) up to this many; more at once.
constexpr size_t kLabelsOneByOne = 256;

/// Appends the surfaces of an extracted label image to `points`/`polys`/`labels`: discrete flying
/// edges over the voxel centres (one voxel of background around, so the surfaces close at the
/// crop), in world coordinates (the extracted image's corner geometry), the original label per
/// triangle.
/// Smoothing and decimation of the meshes (0: none).
struct MeshFinish
{
  int smoothing = 0;     ///< windowed-sinc iterations
  double decimation = 0; ///< quadric decimation's target reduction, [0, 0.95]
};

void appendMeshes(const csgv::ExtractResult& r, const csgv::CsgvFile& file, const csgv::Geometry& volume,
  const MeshFinish& finish, vtkPoints* points, vtkCellArray* polys, vtkTypeInt64Array* labels)
{
  // In the output's corner index space (node (i,j,k) covers [i, i+1] x ...), padded point p is
  // node p - 1, centred at p - 0.5.
  const std::array<uint32_t, 3> d = r.dim;
  vtkNew<vtkImageData> image;
  image->SetDimensions(int(d[0]) + 2, int(d[1]) + 2, int(d[2]) + 2);
  image->SetOrigin(-0.5, -0.5, -0.5);
  image->SetSpacing(1, 1, 1);
  vtkNew<vtkTypeUInt32Array> scalars;
  scalars->SetName("Label");
  scalars->SetNumberOfValues(vtkIdType(d[0] + 2) * (d[1] + 2) * (d[2] + 2));
  // Stored ids where labels are wider than 32 bits (others: kInvalidLabel), shifted by one so
  // that the background is 0; labels as they are otherwise (label 0 is the background).
  const bool wide = file.wideLabels;
  std::set<uint32_t> values;
  uint32_t* s = scalars->GetPointer(0);
  std::fill(s, s + scalars->GetNumberOfValues(), 0u);
  for (uint32_t z = 0; z < d[2]; ++z)
  {
    for (uint32_t y = 0; y < d[1]; ++y)
    {
      const uint32_t* row = r.labels.data() + size_t(d[0]) * (y + size_t(d[1]) * z);
      uint32_t* to = s + 1 + size_t(d[0] + 2) * ((y + 1) + size_t(d[1] + 2) * (z + 1));
      for (uint32_t x = 0; x < d[0]; ++x)
      {
        const uint32_t v = wide ? (row[x] == csgv::kInvalidLabel ? 0u : row[x] + 1) : row[x];
        to[x] = v;
        if (v)
        {
          values.insert(v);
        }
      }
    }
  }
  image->GetPointData()->SetScalars(scalars);
  vtkNew<vtkDiscreteFlyingEdges3D> contour;
  contour->SetInputData(image);
  contour->ComputeScalarsOn();
  contour->ComputeNormalsOff();
  contour->ComputeGradientsOff();
  int n = 0;
  for (uint32_t v : values)
  {
    contour->SetValue(n++, double(v));
  }
  contour->Update();
  vtkSmartPointer<vtkPolyData> mesh = contour->GetOutput();
  if (finish.smoothing > 0 && mesh->GetNumberOfPolys() > 0)
  {
    // Windowed sinc keeps the triangles and the point labels; vertices leave the voxel faces.
    vtkNew<vtkWindowedSincPolyDataFilter> smooth;
    smooth->SetInputData(mesh);
    smooth->SetNumberOfIterations(finish.smoothing);
    smooth->SetPassBand(0.1);
    smooth->BoundarySmoothingOff();
    smooth->FeatureEdgeSmoothingOff();
    smooth->NonManifoldSmoothingOn();
    smooth->NormalizeCoordinatesOn();
    smooth->Update();
    mesh = smooth->GetOutput();
  }
  // Decimation makes new triangles without point labels: one label per mesh only (the caller
  // meshes labels one by one when it decimates).
  if (finish.decimation > 0 && values.size() == 1 && mesh->GetNumberOfPolys() > 0)
  {
    vtkNew<vtkQuadricDecimation> decimate;
    decimate->SetInputData(mesh);
    decimate->SetTargetReduction(finish.decimation);
    decimate->VolumePreservationOn();
    decimate->Update();
    mesh = decimate->GetOutput();
  }

  const csgv::Geometry g = csgv::extractGeometry(volume, r.lod, r.offset);
  const vtkIdType first = points->GetNumberOfPoints();
  for (vtkIdType i = 0; i < mesh->GetNumberOfPoints(); ++i)
  {
    double p[3];
    mesh->GetPoint(i, p);
    double w[3];
    for (int row = 0; row < 3; ++row)
    {
      w[row] = g.origin[size_t(row)];
      for (int c = 0; c < 3; ++c)
      {
        w[row] += g.direction[size_t(3 * row + c)] * g.spacing[size_t(c)] * p[c];
      }
    }
    points->InsertNextPoint(w);
  }
  vtkDataArray* pointLabels = mesh->GetPointData()->GetScalars();
  vtkCellArray* cells = mesh->GetPolys();
  cells->InitTraversal();
  vtkIdType npts = 0;
  const vtkIdType* pts = nullptr;
  std::vector<vtkIdType> shifted;
  while (cells->GetNextCell(npts, pts))
  {
    shifted.assign(pts, pts + npts);
    for (vtkIdType& id : shifted)
    {
      id += first;
    }
    polys->InsertNextCell(npts, shifted.data());
    const uint32_t v = values.size() == 1 ? *values.begin()
      : pointLabels && npts > 0           ? uint32_t(pointLabels->GetComponent(pts[0], 0))
                                          : 0u;
    labels->InsertNextValue(wide ? file.originalLabel(v - 1) : int64_t(v));
  }
}

/// The extracted image as cell data of `image`, in the volume's geometry at the result's level:
/// "Mask" (uint8) or "Label" (the original labels: uint32, or int64 where the file's labels are
/// wider than 32 bits; 0 where no selected label is).
void fillImage(const csgv::ExtractResult& r, const csgv::CsgvFile& file, const csgv::Geometry& volume, vtkImageData* image)
{
  int ext[6];
  for (int a = 0; a < 3; ++a)
  {
    ext[2 * a] = int(r.offset[size_t(a)]);
    ext[2 * a + 1] = int(r.offset[size_t(a)] + r.dim[size_t(a)]);
  }
  image->SetExtent(ext);
  csgvvtk::applyGeometry(image, volume, r.lod);
  const vtkIdType n = vtkIdType(r.dim[0]) * r.dim[1] * r.dim[2];
  if (!r.mask.empty())
  {
    vtkNew<vtkUnsignedCharArray> mask;
    mask->SetName("Mask");
    mask->SetNumberOfValues(n);
    std::copy(r.mask.begin(), r.mask.end(), mask->GetPointer(0));
    image->GetCellData()->SetScalars(mask);
    return;
  }
  if (file.wideLabels)
  {
    const std::vector<int64_t> original = csgv::originalLabels(r, file);
    vtkNew<vtkTypeInt64Array> labels;
    labels->SetName("Label");
    labels->SetNumberOfValues(n);
    std::copy(original.begin(), original.end(), labels->GetPointer(0));
    image->GetCellData()->SetScalars(labels);
    return;
  }
  vtkNew<vtkTypeUInt32Array> labels;
  labels->SetName("Label");
  labels->SetNumberOfValues(n);
  std::copy(r.labels.begin(), r.labels.end(), labels->GetPointer(0));
  image->GetCellData()->SetScalars(labels);
}

} // namespace

vtkCSGVExtractLabels::vtkCSGVExtractLabels()
  : Internals(new vtkInternals)
{
}

vtkCSGVExtractLabels::~vtkCSGVExtractLabels()
{
  delete this->Internals;
}

void vtkCSGVExtractLabels::SetLabels(const char* labels)
{
  const std::string v = labels ? labels : "";
  if (v != this->Labels)
  {
    this->Labels = v;
    this->Modified();
  }
}

void vtkCSGVExtractLabels::SetQuery(const char* query)
{
  const std::string v = query ? query : "";
  if (v != this->Query)
  {
    this->Query = v;
    this->Modified();
  }
}

int vtkCSGVExtractLabels::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

int vtkCSGVExtractLabels::FillOutputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkDataObject::DATA_TYPE_NAME(), "vtkDataObject"); // meshes or an image: OutputType
  return 1;
}

int vtkCSGVExtractLabels::RequestDataObject(vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* info = outputVector->GetInformationObject(0);
  vtkDataObject* output = info->Get(vtkDataObject::DATA_OBJECT());
  const bool image = this->OutputType != MESHES;
  if (!output || (image ? !vtkMultiBlockDataSet::SafeDownCast(output) : !vtkPolyData::SafeDownCast(output)))
  {
    vtkSmartPointer<vtkDataObject> made;
    if (image)
      made = vtkSmartPointer<vtkMultiBlockDataSet>::New();
    else
      made = vtkSmartPointer<vtkPolyData>::New();
    info->Set(vtkDataObject::DATA_OBJECT(), made);
  }
  return 1;
}

int vtkCSGVExtractLabels::RequestUpdateExtent(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  csgvvtk::requestWholeVolume(outputVector->GetInformationObject(0), inputVector[0]->GetInformationObject(0));
  return 1;
}

int vtkCSGVExtractLabels::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkImageData* input = vtkImageData::GetData(inputVector[0], 0);
  vtkDataObject* output = vtkDataObject::GetData(outputVector, 0);
  if (!input || !output)
  {
    return 0;
  }
  output->Initialize();
  this->BricksDecoded = this->BricksTotal = 0;
  if (!csgvvtk::makesWholeOutput(outputVector->GetInformationObject(0), false))
  {
    return 1; // under MPI piece 0 extracts from the whole volume (requestWholeVolume); this rank makes nothing
  }
  std::string error;
  std::shared_ptr<const csgvvtk::EncodedInput> parsed = this->Internals->Encoding.get(input->GetFieldData(), error);
  if (!parsed)
  {
    vtkErrorMacro(<< error << this->Internals->Encoding.advice("CSGV Extract Labels"));
    return 1; // reported once; the output stays empty
  }
  const csgv::CsgvFile file = csgvvtk::fileOfInput(*parsed, input->GetFieldData());

  csgv::ExtractOptions o;
  const bool byLabels = this->Labels.find_first_not_of(" \t\r\n,;") != std::string::npos;
  const bool byQuery = this->Query.find_first_not_of(" \t\r\n") != std::string::npos;
  if (byLabels == byQuery)
  {
    vtkErrorMacro(<< (byLabels ? "give Labels or a Query, not both" : "no labels selected: give Labels (e.g. \"3 17 40\") or a Query"));
    return 1;
  }
  if (byLabels)
  {
    std::string bad;
    if (!parseLabels(this->Labels, o.labels, bad))
    {
      vtkErrorMacro(<< "Labels: '" << bad << "' is not an integer label");
      return 1;
    }
  }
  else
  {
    csgv::Result<std::vector<int64_t>> matched = csgv::labelsMatchingQuery(file, this->Query);
    if (!matched)
    {
      vtkErrorMacro(<< matched.message());
      return 1;
    }
    if (matched->empty())
    {
      vtkWarningMacro(<< "the query selects no label");
      return 1;
    }
    o.labels = std::move(*matched);
  }
  const std::array<uint32_t, 3>& dim = parsed->volume.dim;
  o.hasBox = true;
  for (int a = 0; a < 3; ++a)
  {
    const int lo = std::min(std::max(this->VOI[2 * a], 0), int(dim[size_t(a)]) - 1);
    const int hi = std::min(std::max(this->VOI[2 * a + 1], lo), int(dim[size_t(a)]) - 1);
    o.box.min[a] = uint32_t(lo);
    o.box.max[a] = uint32_t(hi) + 1;
  }
  o.lod = uint32_t(std::min<int>(this->Level, int(parsed->volume.levels()) - 1));
  o.maxLabels = uint64_t(this->MaxLabels);
  o.maxOutputBytes = uint64_t(this->MaxOutputMiB) << 20;
  // One extraction per label while there are few (each label's own bounding box: scattered
  // labels do not make one box of the whole volume), else one for all.
  const std::vector<int64_t> selected = o.labels;
  std::vector<std::vector<int64_t>> groups;
  if (o.labels.size() <= kLabelsOneByOne)
  {
    std::set<int64_t> distinct(o.labels.begin(), o.labels.end());
    for (int64_t l : distinct)
    {
      groups.push_back({ l });
    }
  }
  else
  {
    groups.push_back(o.labels);
  }
  if (selected.size() > uint64_t(this->MaxLabels))
  {
    vtkErrorMacro(<< selected.size() << " labels selected, more than MaxLabels (" << this->MaxLabels << ")");
    return 1;
  }
  if (groups.size() > 1)
  {
    // The selection whole first: an unknown label is counted and named among all selected (each
    // label's own extraction said "1 of the 1 selected labels").
    o.labels = selected;
    o.checkOnly = true;
    const csgv::Result<csgv::ExtractResult> checked = csgv::extractLabels(file, o);
    o.checkOnly = false;
    if (!checked)
    {
      vtkErrorMacro(<< checked.message());
      return 1;
    }
  }
  this->BricksTotal = int(std::min<uint64_t>(parsed->volume.brickCount(), VTK_INT_MAX));
  if (auto* blocks = vtkMultiBlockDataSet::SafeDownCast(output))
  {
    // The image is a block of its own: its extent (the selection's bounding box) is known only
    // here, while an image output's whole extent is fixed in the information pass (the input
    // volume's), and ParaView's Surface representation draws the faces of the whole extent (a
    // cropped image output showed nothing). A block's extent is its own.
    vtkNew<vtkImageData> image;
    // One image of the selection's bounding box (memory bounded by it: MaxOutputMiB).
    o.labels = selected;
    o.mask = this->OutputType == MASK;
    o.progress = [this](double f) {
      this->UpdateProgress(f);
      return !this->GetAbortExecute();
    };
    csgv::Result<csgv::ExtractResult> r = csgv::extractLabels(file, o);
    if (!r)
    {
      vtkErrorMacro(<< r.message());
      return 1;
    }
    this->BricksDecoded = int(std::min<uint64_t>(r->bricksDecoded, VTK_INT_MAX));
    if (r->empty())
    {
      vtkWarningMacro(<< "no voxel of the selected labels lies in the box");
      return 1;
    }
    fillImage(*r, file, parsed->geometry, image);
    blocks->SetNumberOfBlocks(1);
    blocks->SetBlock(0, image);
    blocks->GetMetaData(0u)->Set(vtkCompositeDataSet::NAME(), this->OutputType == MASK ? "Mask" : "Label");
    this->UpdateProgress(1.0);
    return 1;
  }
  vtkPolyData* meshes = vtkPolyData::SafeDownCast(output);
  vtkNew<vtkPoints> points;
  points->SetDataTypeToDouble();
  vtkNew<vtkCellArray> polys;
  vtkNew<vtkTypeInt64Array> cellLabels;
  cellLabels->SetName("Label");
  uint64_t decoded = 0;
  bool any = false;
  MeshFinish finish;
  finish.smoothing = this->Smoothing;
  finish.decimation = this->Decimation;
  if (finish.decimation > 0 && groups.size() == 1 && selected.size() > 1)
  {
    vtkWarningMacro(<< "Decimation applies to selections of at most " << kLabelsOneByOne
                    << " labels (meshed one by one); these meshes are not decimated");
  }
  for (size_t gi = 0; gi < groups.size(); ++gi)
  {
    o.labels = groups[gi];
    const double from = double(gi) / double(groups.size()), width = 1.0 / double(groups.size());
    o.progress = [this, from, width](double f) {
      this->UpdateProgress(from + width * f);
      return !this->GetAbortExecute();
    };
    // Where the group lies, box by box: a label in two far corners of the volume is two small
    // boxes, never one of the whole volume.
    const csgv::Status s = csgv::extractByBoxes(file, o, [&](csgv::ExtractResult& r) {
      any = true;
      appendMeshes(r, file, parsed->geometry, finish, points, polys, cellLabels);
      return csgv::Status::ok();
    }, &decoded);
    if (!s)
    {
      vtkErrorMacro(<< s.message());
      output->Initialize();
      return 1;
    }
  }
  this->BricksDecoded = int(std::min<uint64_t>(decoded, VTK_INT_MAX));
  if (!any)
  {
    vtkWarningMacro(<< "no voxel of the selected labels lies in the box");
    return 1;
  }
  if (!file.wideLabels && std::find(selected.begin(), selected.end(), 0) != selected.end())
  {
    vtkWarningMacro(<< "label 0 is the background of the meshes: it gets no surface");
  }
  meshes->SetPoints(points);
  meshes->SetPolys(polys);
  meshes->GetCellData()->AddArray(cellLabels);
  meshes->GetCellData()->SetActiveScalars("Label");
  this->UpdateProgress(1.0);
  return 1;
}

void vtkCSGVExtractLabels::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Labels: " << this->Labels << "\n";
  os << indent << "Query: " << this->Query << "\n";
  os << indent << "VOI: " << this->VOI[0] << " " << this->VOI[1] << " " << this->VOI[2] << " "
     << this->VOI[3] << " " << this->VOI[4] << " " << this->VOI[5] << "\n";
  os << indent << "Level: " << this->Level << "\n";
  os << indent << "OutputType: " << this->OutputType << "\n";
  os << indent << "Smoothing: " << this->Smoothing << "\n";
  os << indent << "Decimation: " << this->Decimation << "\n";
  os << indent << "BricksDecoded: " << this->BricksDecoded << " of " << this->BricksTotal << "\n";
}
