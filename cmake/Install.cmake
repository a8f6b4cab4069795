# `cmake --install` exports lockroll::sim so another project can find_package(lockroll).
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

install(TARGETS lockroll_sim EXPORT lockrollTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/sim/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/lockroll/sim
        FILES_MATCHING PATTERN "*.h")
install(EXPORT lockrollTargets NAMESPACE lockroll::
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/lockroll)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/lockrollConfig.cmake.in
  ${PROJECT_BINARY_DIR}/lockrollConfig.cmake INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/lockroll)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/lockrollConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/lockrollConfig.cmake ${PROJECT_BINARY_DIR}/lockrollConfigVersion.cmake
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/lockroll)
if(NOT LOCKROLL_SIM_ONLY)
  install(TARGETS lockroll RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/harness/scenes/ DESTINATION ${CMAKE_INSTALL_DATADIR}/lockroll/scenes)
endif()
if(NOT LOCKROLL_SIM_ONLY)
  # The plotting scripts lockroll compare/sweep/precision call (found beside the scenes).
  install(PROGRAMS ${PROJECT_SOURCE_DIR}/scripts/plot.py ${PROJECT_SOURCE_DIR}/scripts/plot_precision.py
          DESTINATION ${CMAKE_INSTALL_DATADIR}/lockroll/scripts)
endif()
