# Driver of the install_find_package test (cmake -P). Inputs: BUILD_DIR, CONSUMER_SOURCE_DIR,
# LIBDIR, WORK_DIR, GENERATOR, CXX_COMPILER, INTREE_CONSUMER.
foreach(var BUILD_DIR CONSUMER_SOURCE_DIR LIBDIR WORK_DIR GENERATOR CXX_COMPILER INTREE_CONSUMER)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "run_install_test.cmake: ${var} not set")
  endif()
endforeach()

set(prefix ${WORK_DIR}/prefix)
set(consumer_build ${WORK_DIR}/consumer-build)
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})

function(step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "install test: ${what} failed (${rc}):\n${out}\n${err}")
  endif()
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

step("cmake --install" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})

# The package must be usable from the prefix alone: point find_package at exactly that config
# and keep CMake from consulting the user package registry or the system.
step("configuring the consumer"
     ${CMAKE_COMMAND} -S ${CONSUMER_SOURCE_DIR} -B ${consumer_build} -G ${GENERATOR}
     -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_BUILD_TYPE=Release
     -Dlockroll_DIR=${prefix}/${LIBDIR}/cmake/lockroll
     -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF)
step("building the consumer" ${CMAKE_COMMAND} --build ${consumer_build})

# Nothing of the source tree may leak into the installed package's usage requirements.
file(READ ${prefix}/${LIBDIR}/cmake/lockroll/lockrollTargets.cmake targets_file)
get_filename_component(source_root ${CONSUMER_SOURCE_DIR}/../../.. ABSOLUTE)
string(FIND "${targets_file}" "${source_root}" leak)
if(NOT leak EQUAL -1)
  message(FATAL_ERROR "install test: lockrollTargets.cmake refers to the source tree ${source_root}")
endif()

step("running the installed consumer" ${consumer_build}/consumer)
set(installed "${step_output}")
step("running the in-tree consumer" ${INTREE_CONSUMER})
set(intree "${step_output}")
message(STATUS "installed: ${installed}")
if(NOT installed STREQUAL intree)
  message(FATAL_ERROR "install test: the consumer built against the installed package printed\n  ${installed}"
                      "but built in-tree it printed\n  ${intree}")
endif()
if(NOT installed MATCHES "^lockroll consumer: .* checksum [0-9a-f]+\n$")
  message(FATAL_ERROR "install test: unexpected consumer output: ${installed}")
endif()
