# Helpers shared by tests, benchmarks, tools and examples.
# binpick_warnings(target): strict warnings for the project's own code (not forced on integrators).
function(binpick_warnings tgt)
  target_compile_options(${tgt} PRIVATE -Wall -Wextra -Wpedantic -Wno-unknown-pragmas)
  if(BINPICK_SANITIZE)
    target_compile_options(${tgt} PRIVATE -fsanitize=address,undefined -fno-omit-frame-pointer
                                          -fno-sanitize-recover=undefined)
    target_link_options(${tgt} PRIVATE -fsanitize=address,undefined)
  endif()
endfunction()

# Adds every immediate subfolder of the current source dir that has a CMakeLists.txt (but common/ and
# sim_cell/, which the top level adds first), so modules can
# bring their own tests / benchmarks / tools without editing a shared list.
macro(binpick_add_subdirectories)
  file(GLOB _binpick_children LIST_DIRECTORIES true RELATIVE ${CMAKE_CURRENT_SOURCE_DIR}
       ${CMAKE_CURRENT_SOURCE_DIR}/*)
  list(SORT _binpick_children)
  foreach(_child ${_binpick_children})
    if(IS_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/${_child}
       AND EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/${_child}/CMakeLists.txt
       AND NOT _child STREQUAL "common" AND NOT _child STREQUAL "sim_cell")
      add_subdirectory(${_child})
    endif()
  endforeach()
endmacro()
