// SPDX-License-Identifier: MIT
#include "vtkCSGVQuery.h"

#include "vtkCSGVRepresentation.h"

#include <vtkObjectFactory.h>

vtkStandardNewMacro(vtkCSGVQuery);

vtkCSGVQuery::~vtkCSGVQuery()
{
  this->SetRequest(nullptr);
}

void vtkCSGVQuery::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Request: " << (this->Request ? this->Request : "") << "\n";
}

void vtkCSGVQuery::SetRepresentation(vtkCSGVRepresentation* representation)
{
  this->Representation = representation;
  this->Modified();
}

const char* vtkCSGVQuery::GetResult()
{
  if (!this->Representation)
  {
    this->Answer = "{\"error\": \"no Segmentation Volume representation\"}";
  }
  else
  {
    this->Answer = this->Representation->Query(this->Request ? this->Request : "summary");
  }
  return this->Answer.c_str();
}
