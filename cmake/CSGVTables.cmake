# SPDX-License-Identifier: MIT
# Tables that C++ and the server-manager XML share, read once here and written into the XML:
# - Representation/CSGVProperties.def: each setting's default values (CSGV_DEFAULT_<Name>);
# - VulkanBackend/include/csgv/gpu/ShadingModes.h: the shading modes' rows (the CSGVShading
#   enumeration's entries, the GUI's labels and the modes' one-line documentation).
# A row that does not match its form stops the configuration (a table edited out of form would
# otherwise leave an XML default or a mode behind).

function(csgv_write_representation_xml template output)
  set(defs "${PROJECT_SOURCE_DIR}/Representation/CSGVProperties.def")
  set(modes "${PROJECT_SOURCE_DIR}/VulkanBackend/include/csgv/gpu/ShadingModes.h")
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS "${defs}" "${modes}" "${template}")

  file(STRINGS "${defs}" rows REGEX "^CSGV_PROPERTY")
  foreach(row IN LISTS rows)
    if(NOT row MATCHES "^CSGV_PROPERTY\\(([A-Za-z]+), [A-Za-z]+, (int|double), ([0-9]+), \\(([-0-9., ]+)\\)\\)$")
      message(FATAL_ERROR "${defs}: a row out of form: ${row}")
    endif()
    set(name "${CMAKE_MATCH_1}")
    set(count "${CMAKE_MATCH_3}")
    string(REPLACE ", " " " values "${CMAKE_MATCH_4}")
    separate_arguments(items UNIX_COMMAND "${values}")
    list(LENGTH items n)
    if(NOT n EQUAL count)
      message(FATAL_ERROR "${defs}: ${name} has ${n} default values, not ${count}")
    endif()
    set(CSGV_DEFAULT_${name} "${values}")
  endforeach()

  file(STRINGS "${modes}" rows REGEX "^    \\{Shading::")
  set(CSGV_SHADING_ENTRIES "")
  set(CSGV_SHADING_LABELS "")
  set(CSGV_SHADING_SUMMARY "")
  set(value 0)
  foreach(row IN LISTS rows)
    if(NOT row MATCHES "^    \\{Shading::[A-Za-z]+, \"([a-z]+)\", \"([^\"]+)\", \"([^\"]+)\", kShading[A-Za-z]+, [0-9.]+, (true|false)\\},$")
      message(FATAL_ERROR "${modes}: a shading mode row out of form: ${row}")
    endif()
    if(value GREATER 0)
      string(APPEND CSGV_SHADING_ENTRIES "\n")
      string(APPEND CSGV_SHADING_LABELS "\n")
      string(APPEND CSGV_SHADING_SUMMARY "; ")
    endif()
    string(APPEND CSGV_SHADING_ENTRIES "          <Entry value=\"${value}\" text=\"${CMAKE_MATCH_1}\"/>")
    string(APPEND CSGV_SHADING_LABELS "          <CSGVEntryLabel text=\"${CMAKE_MATCH_1}\" label=\"${CMAKE_MATCH_2}\"/>")
    string(APPEND CSGV_SHADING_SUMMARY "${CMAKE_MATCH_1}: ${CMAKE_MATCH_3}")
    math(EXPR value "${value} + 1")
  endforeach()
  if(value EQUAL 0)
    message(FATAL_ERROR "${modes}: no shading mode rows found")
  endif()
  configure_file("${template}" "${output}" @ONLY)
endfunction()
