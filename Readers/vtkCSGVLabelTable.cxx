// SPDX-License-Identifier: MIT
#include "vtkCSGVLabelTable.h"

#include "CSGVHeldValue.h"

#include "CSGVAdapter.h"

#include "csgv/attributes/Attributes.h"

#include <vtkDoubleArray.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkStringArray.h>
#include <vtkTable.h>
#include <vtkTypeInt64Array.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

vtkStandardNewMacro(vtkCSGVLabelTable);
csgvHeldSetter(vtkCSGVLabelTable, MaxRows, int, 1, VTK_INT_MAX)

class vtkCSGVLabelTable::vtkInternals
{
public:
  csgvvtk::EncodingMemo Encoding;
};

namespace
{

/// The labels of a volume that is not relabelled: every palette entry, each once, ascending
/// (the reader's palette summary when it lists them all; else one sweep that gives a mapped
/// file's pages back as it goes).
std::vector<int64_t> paletteLabels(const csgvvtk::EncodedInput& enc)
{
  std::shared_ptr<const csgv::PaletteSummary> palettes = enc.palettes;
  if (!palettes || !palettes->labelsComplete)
  {
    palettes = std::make_shared<const csgv::PaletteSummary>(
      csgv::summarizePalettes(enc.volume, std::numeric_limits<size_t>::max()));
  }
  return std::vector<int64_t>(palettes->labels.begin(), palettes->labels.end());
}

/// A table column as a VTK array: columns of whole numbers (labels, ids, counts, a database's
/// INTEGER columns) as 64-bit integers, so that a CSV export writes them whole (ParaView's CSV
/// writer gave a double 928090 as 9.2809e+05; docs pass 11), other numbers as doubles (NaN where
/// missing), text as strings.
vtkSmartPointer<vtkAbstractArray> toArray(const csgv::AttributeColumn& c)
{
  if (!c.numeric)
  {
    auto s = vtkSmartPointer<vtkStringArray>::New();
    s->SetNumberOfValues(vtkIdType(c.text.size()));
    for (size_t i = 0; i < c.text.size(); ++i)
    {
      s->SetValue(vtkIdType(i), c.text[i]);
    }
    s->SetName(c.name.c_str());
    return s;
  }
  const bool integral = std::all_of(c.values.begin(), c.values.end(),
    [](double v) { return std::isfinite(v) && v == std::floor(v) && std::fabs(v) < 9.0e15; });
  if (integral && !c.values.empty())
  {
    auto a = vtkSmartPointer<vtkTypeInt64Array>::New();
    a->SetNumberOfValues(vtkIdType(c.values.size()));
    for (size_t i = 0; i < c.values.size(); ++i)
    {
      a->SetValue(vtkIdType(i), int64_t(c.values[i]));
    }
    a->SetName(c.name.c_str());
    return a;
  }
  auto d = vtkSmartPointer<vtkDoubleArray>::New();
  d->SetNumberOfValues(vtkIdType(c.values.size()));
  std::copy(c.values.begin(), c.values.end(), d->GetPointer(0));
  d->SetName(c.name.c_str());
  return d;
}

} // namespace

vtkCSGVLabelTable::vtkCSGVLabelTable()
  : Internals(new vtkInternals)
{
}

vtkCSGVLabelTable::~vtkCSGVLabelTable()
{
  delete this->Internals;
}

void vtkCSGVLabelTable::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "ComputedAttributes: " << this->ComputedAttributes << "\n";
  os << indent << "MaxRows: " << this->MaxRows << "\n";
}

int vtkCSGVLabelTable::FillInputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

int vtkCSGVLabelTable::RequestUpdateExtent(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  csgvvtk::requestWholeVolume(outputVector->GetInformationObject(0), inputVector[0]->GetInformationObject(0));
  return 1;
}

int vtkCSGVLabelTable::RequestData(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkImageData* input = vtkImageData::GetData(inputVector[0], 0);
  vtkTable* output = vtkTable::GetData(outputVector, 0);
  if (!input || !output)
  {
    return 0;
  }
  output->Initialize();
  if (!csgvvtk::makesWholeOutput(outputVector->GetInformationObject(0), false))
  {
    return 1; // under MPI piece 0 makes the whole table (requestWholeVolume); this rank's is empty
  }
  std::string error;
  std::shared_ptr<const csgvvtk::EncodedInput> parsed = this->Internals->Encoding.get(input->GetFieldData(), error);
  if (!parsed)
  {
    vtkErrorMacro(<< error << this->Internals->Encoding.advice("CSGV Label Table"));
    return 1; // reported once; the output stays empty
  }
  const csgv::CsgvFile file = csgvvtk::fileOfInput(*parsed, input->GetFieldData());
  // The rows: the attribute database's labels (with csgv_id) or the palettes' labels.
  csgv::Result<csgv::AttributeTable> table = file.hasAttributes
    ? csgv::attributesFromDatabase(file.attributes)
    : csgv::AttributeTable::fromLabels(paletteLabels(*parsed));
  if (!table)
  {
    vtkErrorMacro(<< "the label table: " << table.message());
    return 1;
  }
  if (table->rowCount() > size_t(this->MaxRows))
  {
    vtkErrorMacro(<< "the volume holds " << table->rowCount() << " labels, more than MaxRows ("
                  << this->MaxRows << "); raise MaxRows to list them");
    return 1;
  }
  if (this->ComputedAttributes)
  {
    csgv::ComputeAttributesOptions o;
    if (file.hasAttributes)
    {
      o.idToLabel = &file.attributes.labels;
    }
    o.progress = [this](double f) {
      this->UpdateProgress(f);
      return !this->GetAbortExecute();
    };
    csgv::Result<csgv::AttributeTable> computed = csgv::computeAttributes(file.volume, o);
    if (!computed)
    {
      vtkErrorMacro(<< "computing the attributes: " << computed.message());
      return 1;
    }
    csgv::Status s = table->merge(*computed, csgv::AttributeTable::OnConflict::Keep);
    if (!s)
    {
      vtkErrorMacro(<< "computing the attributes: " << s.message());
      return 1;
    }
  }
  for (const csgv::AttributeColumn& c : table->columns())
  {
    output->AddColumn(toArray(c));
  }
  return 1;
}
