# SPDX-License-Identifier: MIT
# Fails when a layer includes headers it must not see (DESIGN.md, "The parts and how data flows"):
# Core: no VTK, Vulkan, glslang or Qt; VulkanBackend and shaders: no VTK or Qt; only Plugin has Qt.
function(check_layer dir regex what)
  file(GLOB_RECURSE files "${SOURCE_DIR}/${dir}/*.h" "${SOURCE_DIR}/${dir}/*.hpp" "${SOURCE_DIR}/${dir}/*.cpp"
       "${SOURCE_DIR}/${dir}/*.cxx" "${SOURCE_DIR}/${dir}/*.glsl" "${SOURCE_DIR}/${dir}/*.comp")
  foreach(f IN LISTS files)
    file(STRINGS "${f}" hits REGEX "^[ \t]*#[ \t]*include[ \t]*[<\"](${regex})")
    if(hits)
      list(APPEND bad "${f}: ${hits}")
    endif()
  endforeach()
  if(bad)
    string(REPLACE ";" "\n  " bad "${bad}")
    message(SEND_ERROR "${dir}/ must not include ${what}:\n  ${bad}")
  endif()
endfunction()

check_layer(Core "vtk|vulkan/|Vk|Q[A-Z]|qt|pq|glslang|SPIRV|paraview" "VTK, Vulkan, glslang, ParaView or Qt headers")
check_layer(VulkanBackend "vtk|Q[A-Z]|qt|pq|paraview" "VTK, ParaView or Qt headers")
check_layer(shaders "vtk|Q[A-Z]|pq" "VTK or Qt headers")
check_layer(Readers "Q[A-Z]|qt|pq|vulkan/" "Qt or Vulkan headers")
check_layer(Representation "Q[A-Z]|qt|pq" "Qt headers")

# The plugin's GUI reaches the representation only through its server-manager properties, which
# work in client/server sessions too: no header of Representation/ (the renderer's classes live
# on the rendering process) and none of VulkanBackend/.
check_layer(Plugin "vtkCSGVVolumeProp|vtkCSGVRepresentation|CSGVViewRenderer|CSGVVolumeCache|csgv/gpu/" "headers of Representation/ or VulkanBackend/")

# The representation uses the readers' public adapter (CSGVAdapter.h) through its module
# dependency: no private header of Readers/ (the former vtkCSGVInternals.h) and no path into it.
check_layer(Representation "vtkCSGVInternals|[^\">]*Readers/" "private headers of Readers/")
if(EXISTS "${SOURCE_DIR}/Representation/CMakeLists.txt")
  file(READ "${SOURCE_DIR}/Representation/CMakeLists.txt" rep_cmake_text)
  if(rep_cmake_text MATCHES "vtk_module_include[^)]*Readers")
    message(SEND_ERROR "Representation/ must use CSGV::Readers through its module dependency, not an include path into Readers/")
  endif()
endif()
