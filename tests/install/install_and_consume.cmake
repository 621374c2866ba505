file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed: ${ARGN}\n${out}\n${err}")
  endif()
endfunction()
# Configure binpick alone (library only), install it into a prefix.
run(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/binpick -G ${GENERATOR} -DBUILD_TESTING=OFF
    -DBINPICK_BUILD_BENCHMARKS=OFF -DBINPICK_BUILD_EXAMPLES=OFF -DBINPICK_BUILD_TOOLS=OFF
    -DCMAKE_INSTALL_PREFIX=${WORK_DIR}/prefix)
run(${CMAKE_COMMAND} --install ${WORK_DIR}/binpick)
# The downstream project finds the installed package.
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/install/downstream -B ${WORK_DIR}/downstream -G ${GENERATOR}
    -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/downstream)
run(${WORK_DIR}/downstream/downstream)
