# install/export so that find_package(shatter) works from another CMake project.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)
add_library(shatter_all INTERFACE)
add_library(shatter::shatter ALIAS shatter_all)
set_target_properties(shatter_all PROPERTIES EXPORT_NAME shatter)
target_link_libraries(shatter_all INTERFACE ${SHATTER_MODULES})
install(TARGETS ${SHATTER_MODULES} shatter_all EXPORT shatterTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR})
# Only the public headers (include/shatter/); the internal ones under src/ stay private.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/shatter DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
  FILES_MATCHING PATTERN "*.h")
install(EXPORT shatterTargets NAMESPACE shatter:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/shatter)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/shatterConfig.cmake.in
  ${PROJECT_BINARY_DIR}/shatterConfig.cmake INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/shatter)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/shatterConfigVersion.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/shatterConfig.cmake ${PROJECT_BINARY_DIR}/shatterConfigVersion.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/shatter)
if(SHATTER_BUILD_APPS)
  install(TARGETS shatter_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  # The bundled scenes and the meshes they name, at the same relative paths (`shatter run` finds
  # share/shatter/scenes/vase_drop.json beside an installed binary).
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/scenes DESTINATION ${CMAKE_INSTALL_DATADIR}/shatter)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/assets/meshes DESTINATION ${CMAKE_INSTALL_DATADIR}/shatter/assets)
endif()
