file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed: ${ARGN}\n${out}\n${err}")
  endif()
  set(run_output "${out}" PARENT_SCOPE)
endfunction()
# Twice: with OpenMP (the default when found) and without it (BINPICK_USE_OPENMP=OFF), which the
# library promises to build and run with. The downstream project compiles with -Wall -Wextra -Werror,
# so a header that warns in an integrator's build (e.g. a bare `#pragma omp` without OpenMP) fails here.
foreach(openmp ON OFF)
  set(dir ${WORK_DIR}/openmp_${openmp})
  # Configure binpick alone (library only), install it into a prefix.
  run(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${dir}/binpick -G ${GENERATOR} -DBUILD_TESTING=OFF
      -DBINPICK_BUILD_BENCHMARKS=OFF -DBINPICK_BUILD_EXAMPLES=OFF -DBINPICK_BUILD_TOOLS=OFF
      -DBINPICK_USE_OPENMP=${openmp} -DCMAKE_INSTALL_PREFIX=${dir}/prefix)
  run(${CMAKE_COMMAND} --install ${dir}/binpick)
  # The downstream project finds the installed package.
  run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/install/downstream -B ${dir}/downstream -G ${GENERATOR}
      -DCMAKE_PREFIX_PATH=${dir}/prefix -DCMAKE_BUILD_TYPE=Release "-DCMAKE_CXX_FLAGS=-Wall -Wextra -Werror")
  run(${CMAKE_COMMAND} --build ${dir}/downstream)
  run(${dir}/downstream/downstream)
  # Without OpenMP nothing may bring it in. (With it, the program says "on" only where the compiler
  # has OpenMP, so that pass is not checked.)
  if(openmp STREQUAL "OFF" AND NOT run_output MATCHES "openmp off")
    message(FATAL_ERROR "BINPICK_USE_OPENMP=OFF, yet the downstream program says: ${run_output}")
  endif()
  message(STATUS "BINPICK_USE_OPENMP=${openmp}: ${run_output}")
endforeach()
