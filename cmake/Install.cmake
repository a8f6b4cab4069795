# The public libraries as another project sees them. Each lockroll_<name> built from <name>/
# becomes lockroll::<name>, with the headers cmake/PublicHeaders.cmake lists (and no others)
# reachable as <lockroll/<dir>/<header>>:
#  - in this build tree through per-file links in <build>/include/lockroll/ (a parent project
#    using add_subdirectory gets the same spelling, and an unlisted header is not reachable so),
#  - after `cmake --install`: find_package(lockroll) (versioned, SameMajorVersion) and lockroll.pc.
# Only <build>/include and <prefix>/include are include dirs of the package: installed headers
# include each other as <lockroll/...>, so a consumer's own sim/world.h or net/clock.h on its
# include path never replaces ours.
#
# Adding a library: append its name to LOCKROLL_PUBLIC_LIBRARIES (top-level CMakeLists.txt), after
# the libraries it links (static linking wants dependents first; lockroll.pc lists them in
# reverse), and list its headers in cmake/PublicHeaders.cmake. Its target must give
# its source include dir as $<BUILD_INTERFACE:...> (CMake refuses to export a raw source path),
# and every imported target it links must be one this file knows how to find again (below).
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

# <lockroll/version.h>: generated into the build tree's include dir (every target's interface
# includes it) and installed beside the libraries' header folders.
configure_file(${PROJECT_SOURCE_DIR}/cmake/version.h.in ${PROJECT_BINARY_DIR}/include/lockroll/version.h @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/include/lockroll/version.h DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/lockroll)

set(lockroll_config_dependencies "")  # lockrollConfig.cmake: finding what the static libraries link
set(lockroll_pc_requires "")          # lockroll.pc: pkg-config modules they link
set(lockroll_pc_libs "")              # lockroll.pc: -l flags, dependents first
set(lockroll_installed "")
set(lockroll_companions "")
foreach(name IN LISTS LOCKROLL_PUBLIC_LIBRARIES)
  set(target lockroll_${name})
  if(NOT TARGET ${target})
    continue()  # LOCKROLL_SIM_ONLY builds only sim
  endif()
  list(APPEND lockroll_installed ${name})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name} POSITION_INDEPENDENT_CODE ON)
  lockroll_public_headers(${name} header_dir headers)  # cmake/PublicHeaders.cmake
  # One link per listed header (an older build tree may hold a link to the whole source folder,
  # or to a folder above it, in its place).
  set(link_dir ${PROJECT_BINARY_DIR}/include/lockroll/${header_dir})
  foreach(dir IN ITEMS ${link_dir} ${PROJECT_BINARY_DIR}/include/lockroll/harness)
    if(IS_SYMLINK ${dir})
      file(REMOVE ${dir})
    endif()
  endforeach()
  file(GLOB stale RELATIVE ${link_dir} ${link_dir}/*.h)
  list(REMOVE_ITEM stale ${headers})
  list(TRANSFORM stale PREPEND ${link_dir}/)
  file(REMOVE ${stale} ${link_dir}/.none)  # a header no longer listed must not stay reachable
  file(MAKE_DIRECTORY ${link_dir})
  foreach(h IN LISTS headers)
    file(CREATE_LINK ${PROJECT_SOURCE_DIR}/${header_dir}/${h} ${link_dir}/${h} SYMBOLIC)
  endforeach()
  # PUBLIC: the library's own sources include its public headers, which spell <lockroll/...>.
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_BINARY_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  install(TARGETS ${target} EXPORT lockrollTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
  list(TRANSFORM headers PREPEND ${PROJECT_SOURCE_DIR}/${header_dir}/)
  install(FILES ${headers} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/lockroll/${header_dir})
  list(PREPEND lockroll_pc_libs -l${target})

  # Static libraries pass their link dependencies on, private or not: the package must find each.
  get_target_property(links ${target} LINK_LIBRARIES)
  foreach(link IN LISTS links)
    if(link MATCHES "^lockroll_" AND TARGET ${link} AND NOT link IN_LIST lockroll_companions)
      # A companion built from the same folder (lockroll_relay_protocol of rollback/, which the
      # relay server links without the rest): installed and exported with it, linked after it.
      list(APPEND lockroll_companions ${link})
      string(REGEX REPLACE "^lockroll_" "" companion ${link})
      set_target_properties(${link} PROPERTIES EXPORT_NAME ${companion} POSITION_INDEPENDENT_CODE ON)
      target_include_directories(${link} PUBLIC
        $<BUILD_INTERFACE:${PROJECT_BINARY_DIR}/include>
        $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
      install(TARGETS ${link} EXPORT lockrollTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
      list(INSERT lockroll_pc_libs 1 -l${link})
      continue()
    elseif(link MATCHES "^(lockroll::|lockroll_)" OR NOT TARGET ${link})
      continue()
    elseif(link STREQUAL "PkgConfig::ENET")
      if(NOT "libenet" IN_LIST lockroll_pc_requires)
        list(APPEND lockroll_pc_requires libenet)
        string(APPEND lockroll_config_dependencies [=[
if(NOT TARGET PkgConfig::ENET)
  find_dependency(PkgConfig)
  pkg_check_modules(ENET QUIET IMPORTED_TARGET libenet)
  if(NOT ENET_FOUND)
    set(lockroll_FOUND FALSE)
    set(lockroll_NOT_FOUND_MESSAGE "lockroll needs ENet (Debian package libenet-dev, pkg-config module libenet)")
    return()
  endif()
endif()
]=])
      endif()
    elseif(link STREQUAL "Threads::Threads")
      if(NOT lockroll_config_dependencies MATCHES "Threads")
        string(APPEND lockroll_config_dependencies "find_dependency(Threads)\n")
        list(APPEND lockroll_pc_threads -pthread)
      endif()
    else()
      message(FATAL_ERROR "cmake/Install.cmake: ${target} links ${link}, which the installed lockroll "
                          "package does not know how to find; teach cmake/Install.cmake to find it")
    endif()
  endforeach()
endforeach()

install(EXPORT lockrollTargets NAMESPACE lockroll:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/lockroll)
list(TRANSFORM lockroll_installed PREPEND lockroll:: OUTPUT_VARIABLE LOCKROLL_INSTALLED_TARGETS)
string(REPLACE ";" " " LOCKROLL_INSTALLED_TARGETS "${LOCKROLL_INSTALLED_TARGETS}")
set(LOCKROLL_CONFIG_DEPENDENCIES "${lockroll_config_dependencies}")
# The shipped scenes (the match's load_scene finds them by name there): lockroll_SCENE_DIR.
set(LOCKROLL_SCENE_DIR ${CMAKE_INSTALL_DATADIR}/lockroll/scenes)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/lockrollConfig.cmake.in
  ${PROJECT_BINARY_DIR}/lockrollConfig.cmake INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/lockroll
  PATH_VARS LOCKROLL_SCENE_DIR)
# 0.x: every 0.y release is compatible with the 0.1 API until 1.0.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/lockrollConfigVersion.cmake
  COMPATIBILITY SameMajorVersion)
install(FILES ${PROJECT_BINARY_DIR}/lockrollConfig.cmake ${PROJECT_BINARY_DIR}/lockrollConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/lockroll)

# pkg-config: relocatable (the prefix is found from the .pc file's own place, so
# `cmake --install --prefix` anywhere works).
file(RELATIVE_PATH LOCKROLL_PC_PREFIX /${CMAKE_INSTALL_LIBDIR}/pkgconfig /)
string(REGEX REPLACE "/$" "" LOCKROLL_PC_PREFIX "${LOCKROLL_PC_PREFIX}")
string(REPLACE ";" " " LOCKROLL_PC_REQUIRES "${lockroll_pc_requires}")
string(REPLACE ";" " " LOCKROLL_PC_LIBS "${lockroll_pc_libs};${lockroll_pc_threads}")
configure_file(${PROJECT_SOURCE_DIR}/cmake/lockroll.pc.in ${PROJECT_BINARY_DIR}/lockroll.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/lockroll.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

# The C ABI (capi/): liblockroll.so as lockroll::c, <lockroll/lockroll.h>, and lockroll-c.pc
# (-llockroll). Shared, so nothing it links is the consumer's to find.
if(TARGET lockroll_c)
  install(TARGETS lockroll_c EXPORT lockrollTargets LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(FILES ${PROJECT_SOURCE_DIR}/capi/lockroll.h DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/lockroll)
  configure_file(${PROJECT_SOURCE_DIR}/cmake/lockroll-c.pc.in ${PROJECT_BINARY_DIR}/lockroll-c.pc @ONLY)
  install(FILES ${PROJECT_BINARY_DIR}/lockroll-c.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
endif()

if(TARGET lockroll_match)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/harness/scenes/ DESTINATION ${LOCKROLL_SCENE_DIR})
endif()
if(TARGET lockroll)  # not in LOCKROLL_SIM_ONLY or WebAssembly (LOCKROLL_ENET=OFF) builds
  install(TARGETS lockroll RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  # The plotting scripts lockroll compare/sweep/precision call (found beside the scenes).
  install(PROGRAMS ${PROJECT_SOURCE_DIR}/scripts/plot.py ${PROJECT_SOURCE_DIR}/scripts/plot_precision.py
          DESTINATION ${CMAKE_INSTALL_DATADIR}/lockroll/scripts)
endif()
