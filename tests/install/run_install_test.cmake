# Driver of the install_find_package test (cmake -P). Inputs: BUILD_DIR, TEST_SOURCE_DIR
# (tests/install), LIBDIR, WORK_DIR, GENERATOR, CXX_COMPILER, INTREE_CONSUMER, VERSION,
# PKG_CONFIG, LIBRARIES (the public libraries, comma-separated: sim,rollback,transport),
# HEADER_DIRS (each one's directory under include/lockroll, in the same order).
foreach(var BUILD_DIR TEST_SOURCE_DIR LIBDIR WORK_DIR GENERATOR CXX_COMPILER INTREE_CONSUMER VERSION PKG_CONFIG LIBRARIES
        HEADER_DIRS)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "run_install_test.cmake: ${var} not set")
  endif()
endforeach()

string(REPLACE "," ";" LIBRARIES "${LIBRARIES}")
string(REPLACE "," ";" HEADER_DIRS "${HEADER_DIRS}")
list(TRANSFORM LIBRARIES PREPEND lockroll:: OUTPUT_VARIABLE expected_targets)
set(prefix ${WORK_DIR}/prefix)
set(consumer_source ${TEST_SOURCE_DIR}/consumer)
set(consumer_build ${WORK_DIR}/consumer-build)
get_filename_component(source_root ${TEST_SOURCE_DIR}/../.. ABSOLUTE)
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

# Every target and the pkg-config file are there.
foreach(f ${LIBDIR}/cmake/lockroll/lockrollConfig.cmake ${LIBDIR}/cmake/lockroll/lockrollConfigVersion.cmake
          ${LIBDIR}/pkgconfig/lockroll.pc)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "install test: ${f} was not installed")
  endif()
endforeach()
foreach(lib dir IN ZIP_LISTS LIBRARIES HEADER_DIRS)
  if(NOT EXISTS ${prefix}/${LIBDIR}/liblockroll_${lib}.a OR NOT IS_DIRECTORY ${prefix}/include/lockroll/${dir})
    message(FATAL_ERROR "install test: lockroll::${lib} (library or headers) was not installed")
  endif()
endforeach()

# The installed surface, exactly (cmake/PublicHeaders.cmake): one header more or less fails.
# Only the API: no header is installed just because a surface header includes it (the sessions
# and the builder hide their members behind pointers), and the match (lockroll::match) is in-tree.
set(expected_headers
  version.h lockroll.h
  sim/fixed.h sim/vec3.h sim/scene.h sim/world.h
  rollback/simulation.h rollback/world_simulation.h rollback/session.h rollback/relay_session.h
  rollback/sync_test.h rollback/events.h rollback/session_types.h rollback/replay.h
  transport/transport.h transport/enet_transport.h
  net/session_builder.h net/update_result.h)
file(GLOB_RECURSE headers RELATIVE ${prefix}/include/lockroll ${prefix}/include/lockroll/*)
set(unexpected ${headers})
list(REMOVE_ITEM unexpected ${expected_headers})
set(missing ${expected_headers})
list(REMOVE_ITEM missing ${headers})
list(LENGTH headers count)
message(STATUS "installed headers under include/lockroll: ${count}")
if(unexpected OR missing)
  message(FATAL_ERROR "install test: the installed surface changed (cmake/PublicHeaders.cmake):\n"
                      "  installed but not listed here: ${unexpected}\n  listed here but not installed: ${missing}")
endif()

# Installed headers include lockroll's own only as <lockroll/...> (never quoted: a quoted
# "sim/world.h" would find a consumer's own), each installed; besides those only standard C++
# headers (<name>, no extension, no directory) and the operating system's socket API
# (<sys/socket.h>, for net/'s addresses): never xxhash.h, ENet or the source tree.
foreach(h IN LISTS headers)
  file(STRINGS ${prefix}/include/lockroll/${h} includes REGEX "^[ \t]*#[ \t]*include")
  foreach(line IN LISTS includes)
    if(line MATCHES "\"([^\"]+)\"")
      message(FATAL_ERROR "install test: installed ${h} includes \"${CMAKE_MATCH_1}\"; spell it <lockroll/...>")
    elseif(line MATCHES "<lockroll/([^>]+)>")
      if(NOT EXISTS ${prefix}/include/lockroll/${CMAKE_MATCH_1})
        message(FATAL_ERROR "install test: installed ${h} includes <lockroll/${CMAKE_MATCH_1}>, which is not installed")
      endif()
    elseif(line MATCHES "<([^>]+)>")
      set(included ${CMAKE_MATCH_1})
      # lockroll.h, the C ABI, is C: it includes the C standard's <stddef.h> and <stdint.h>.
      if(included MATCHES "[./]" AND NOT included STREQUAL "sys/socket.h"
         AND NOT (h STREQUAL "lockroll.h" AND included MATCHES "^std(def|int)\\.h$"))
        message(FATAL_ERROR "install test: installed ${h} includes <${included}>, not a standard C++ "
                            "header; a private dependency must stay in the .cpp files")
      endif()
    endif()
  endforeach()
endforeach()

# The consumer's own net/clock.h, sim/world.h and rollback/session.h (consumer/own/) really are
# #errors on its include path: the builds below pass only because lockroll never reaches them.
file(WRITE ${WORK_DIR}/shadow_probe.cpp "#include <net/clock.h>\n")
execute_process(COMMAND ${CXX_COMPILER} -std=c++20 -fsyntax-only -I${consumer_source}/own ${WORK_DIR}/shadow_probe.cpp
                RESULT_VARIABLE rc OUTPUT_QUIET ERROR_VARIABLE err)
if(rc EQUAL 0 OR NOT err MATCHES "the consumer's own net/clock.h was included")
  message(FATAL_ERROR "install test: consumer/own/net/clock.h does not stop a build that includes it:\n${err}")
endif()

# Nothing of the source or build tree may leak into the installed package's usage requirements.
foreach(f ${LIBDIR}/cmake/lockroll/lockrollTargets.cmake ${LIBDIR}/cmake/lockroll/lockrollConfig.cmake
          ${LIBDIR}/pkgconfig/lockroll.pc)
  file(READ ${prefix}/${f} text)
  foreach(tree ${source_root} ${BUILD_DIR})
    string(FIND "${text}" "${tree}" leak)
    if(NOT leak EQUAL -1)
      message(FATAL_ERROR "install test: installed ${f} refers to ${tree}")
    endif()
  endforeach()
endforeach()

# CMake: the package must be usable from the prefix alone: point find_package at exactly that
# config and keep CMake from consulting the user package registry or the system.
set(isolated -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -Dlockroll_DIR=${prefix}/${LIBDIR}/cmake/lockroll
             -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF)
step("configuring the consumer"
     ${CMAKE_COMMAND} -S ${consumer_source} -B ${consumer_build} -G ${GENERATOR} -DCMAKE_BUILD_TYPE=Release ${isolated})
step("building the consumer, with its own net/clock.h first (and every installed header, together and alone)" ${CMAKE_COMMAND} --build ${consumer_build})
step("running the installed consumer" ${consumer_build}/consumer)
set(installed "${step_output}")
step("running the in-tree consumer" ${INTREE_CONSUMER})
set(intree "${step_output}")
message(STATUS "installed: ${installed}")
if(NOT installed STREQUAL intree)
  message(FATAL_ERROR "install test: the consumer built against the installed package printed\n  ${installed}"
                      "but built in-tree it printed\n  ${intree}")
endif()
if(NOT installed MATCHES "^lockroll consumer: world .* checksum [0-9a-f]+; session confirmed [0-9]+ agree, checksum [0-9a-f]+; enet bound; net builds\n$")
  message(FATAL_ERROR "install test: unexpected consumer output: ${installed}")
endif()

# pkg-config: a plain compiler command line, as a Makefile would write it.
step("pkg-config --cflags --libs lockroll"
     ${CMAKE_COMMAND} -E env PKG_CONFIG_PATH=${prefix}/${LIBDIR}/pkgconfig ${PKG_CONFIG} --cflags --libs lockroll)
string(STRIP "${step_output}" pc_flags)
message(STATUS "pkg-config: ${pc_flags}")
if(NOT pc_flags MATCHES "-I[^ ]*/include( |$)" OR pc_flags MATCHES "include/lockroll")
  message(FATAL_ERROR "install test: lockroll.pc must give exactly <prefix>/include: ${pc_flags}")
endif()
separate_arguments(pc_flags UNIX_COMMAND "${pc_flags}")
step("compiling the consumer with pkg-config's flags, its own net/clock.h first"
     ${CXX_COMPILER} -std=c++20 -O2 -I${consumer_source}/own ${consumer_source}/main.cpp ${pc_flags}
     -o ${WORK_DIR}/consumer-pkgconfig)
step("running the pkg-config consumer" ${WORK_DIR}/consumer-pkgconfig)
if(NOT step_output STREQUAL intree)
  message(FATAL_ERROR "install test: the consumer built with pkg-config printed\n  ${step_output}"
                      "but built in-tree it printed\n  ${intree}")
endif()
step("pkg-config --modversion lockroll"
     ${CMAKE_COMMAND} -E env PKG_CONFIG_PATH=${prefix}/${LIBDIR}/pkgconfig ${PKG_CONFIG} --modversion lockroll)
if(NOT step_output STREQUAL "${VERSION}\n")
  message(FATAL_ERROR "install test: lockroll.pc says version ${step_output}, the project is ${VERSION}")
endif()

# Versioning is SameMajorVersion: 0.1 and 0.0 are satisfied by 0.1.x; 1.0 and a newer 0.x are not.
string(REGEX MATCH "^[0-9]+\\.[0-9]+" major_minor "${VERSION}")
string(REGEX MATCH "^[0-9]+" major "${VERSION}")
string(REGEX MATCH "\\.([0-9]+)" minor "${VERSION}")
math(EXPR next_minor "${CMAKE_MATCH_1} + 1")
math(EXPR next_major "${major} + 1")
foreach(want_expect ${major_minor}=found ${major}.0=found ${next_major}.0=not ${major}.${next_minor}=not)
  string(REPLACE "=" ";" want_expect ${want_expect})
  list(GET want_expect 0 want)
  list(GET want_expect 1 expect)
  step("find_package(lockroll ${want})"
       ${CMAKE_COMMAND} -S ${TEST_SOURCE_DIR}/version_check -B ${WORK_DIR}/version-${want} -G ${GENERATOR} ${isolated}
       -DWANT=${want})
  if(expect STREQUAL "found" AND NOT step_output MATCHES "lockroll ${want}: found ${VERSION} targets ${expected_targets}\n")
    message(FATAL_ERROR "install test: find_package(lockroll ${want}) should find ${VERSION}:\n${step_output}")
  elseif(expect STREQUAL "not" AND NOT step_output MATCHES "lockroll ${want}: not found\n")
    message(FATAL_ERROR "install test: find_package(lockroll ${want}) should fail against ${VERSION}:\n${step_output}")
  endif()
endforeach()
