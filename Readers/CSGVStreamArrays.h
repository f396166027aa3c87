// SPDX-License-Identifier: MIT
/**
 * @file CSGVStreamArrays.h
 * @brief Vectors through vtkMultiProcessStream, empty ones included (its Push refuses a null
 * array): the MPI exchanges of the writer (vtkCSGVWriter) and the representation's pieces.
 */
#ifndef CSGVStreamArrays_h
#define CSGVStreamArrays_h

#include <vtkMultiProcessStream.h>

#include <vector>

namespace csgvvtk
{

/// Appends the element count and the elements (T: a type vtkMultiProcessStream pushes arrays of).
template <class T>
void pushArray(vtkMultiProcessStream& s, const std::vector<T>& v)
{
  s << static_cast<unsigned int>(v.size());
  if (!v.empty())
  {
    s.Push(const_cast<T*>(v.data()), static_cast<unsigned int>(v.size()));
  }
}

/// Reads what pushArray<T> wrote, as a vector of U.
template <class T, class U = T>
std::vector<U> popArray(vtkMultiProcessStream& s)
{
  unsigned int n = 0;
  s >> n;
  std::vector<U> v;
  if (n > 0)
  {
    T* data = nullptr;
    s.Pop(data, n);
    v.assign(data, data + n);
    delete[] data;
  }
  return v;
}

} // namespace csgvvtk

#endif
