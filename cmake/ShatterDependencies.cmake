# Every dependency comes from a Debian package (scripts/setup.sh installs them).
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(PkgConfig REQUIRED)
pkg_check_modules(XXHASH REQUIRED IMPORTED_TARGET libxxhash)
if(SHATTER_THREADS)
  find_package(Threads REQUIRED)  # the worker pool of core/parallel.h
endif()
find_package(nlohmann_json 3.10 REQUIRED)  # shape, case and scene files
find_package(ZLIB REQUIRED)  # compressed VTU arrays (zlib1g-dev)
if(SHATTER_BUILD_APPS OR SHATTER_BUILD_TESTS)
  find_package(CLI11 REQUIRED)
  find_package(fmt REQUIRED)
endif()
if(SHATTER_BUILD_RENDER)
  pkg_check_modules(EPOXY REQUIRED IMPORTED_TARGET epoxy)  # libepoxy-dev: GL and EGL entry points
else()
  set(SHATTER_BUILD_VIEWER OFF)
endif()
if(SHATTER_BUILD_VIEWER)
  pkg_check_modules(GLFW REQUIRED IMPORTED_TARGET glfw3)  # libglfw3-dev
  # libimgui-dev: the library with its GLFW and OpenGL 3 back ends (its .pc names stb, which
  # libstb-dev provides).
  pkg_check_modules(IMGUI REQUIRED IMPORTED_TARGET imgui)
endif()
if(SHATTER_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(SHATTER_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()

# Compile options shared by every target of the project (not exported).
add_library(shatter_options INTERFACE)
target_compile_features(shatter_options INTERFACE cxx_std_20)
# Determinism: no fused multiply-add contraction, no fast-math.
target_compile_options(shatter_options INTERFACE -ffp-contract=off -fno-fast-math)
target_compile_options(shatter_options INTERFACE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
  -Wcast-align -Woverloaded-virtual
  -Wno-missing-field-initializers)  # designated initializers of "def" structs leave the rest defaulted
if(SHATTER_WERROR)
  target_compile_options(shatter_options INTERFACE -Werror)
endif()
target_compile_definitions(shatter_options INTERFACE EIGEN_MPL2_ONLY)
