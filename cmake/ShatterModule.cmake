# shatter_add_module(NAME [DEPS targets...] [PRIVATE_DEPS targets...])
include(GNUInstallDirs)
# One library per layer: every .cpp below the calling folder is a source; the link list spells out
# which lower layers the module may use (design.md: core <- mesh <- fem <- solve/fracture <- ...).
set(SHATTER_MODULES "" CACHE INTERNAL "")
function(shatter_add_module name)
  cmake_parse_arguments(M "" "" "DEPS;PRIVATE_DEPS" ${ARGN})
  file(GLOB_RECURSE srcs CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.cpp)
  add_library(shatter_${name} ${srcs})
  add_library(shatter::${name} ALIAS shatter_${name})
  set_target_properties(shatter_${name} PROPERTIES EXPORT_NAME ${name} OUTPUT_NAME shatter_${name}
    POSITION_INDEPENDENT_CODE ON)
  # Public headers (installed) live in include/shatter/<layer>/, internal ones beside the sources in
  # src/shatter/<layer>/; both are included as "shatter/<layer>/<name>.h".
  target_include_directories(shatter_${name} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/include> $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/src>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(shatter_${name} PUBLIC ${M_DEPS} PRIVATE ${M_PRIVATE_DEPS} $<BUILD_INTERFACE:shatter_options>)
  target_compile_features(shatter_${name} PUBLIC cxx_std_20)
  target_compile_definitions(shatter_${name} PUBLIC EIGEN_MPL2_ONLY)
  set(SHATTER_MODULES ${SHATTER_MODULES} shatter_${name} CACHE INTERNAL "")
endfunction()
