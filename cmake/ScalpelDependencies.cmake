# Every dependency is a Debian 12 package (scripts/setup.sh installs them); nothing is downloaded.
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(yaml-cpp REQUIRED)
find_package(CLI11 REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(Threads REQUIRED)
find_package(PkgConfig REQUIRED)
pkg_check_modules(HIDAPI REQUIRED IMPORTED_TARGET hidapi-hidraw)
pkg_check_modules(LIBUSB REQUIRED IMPORTED_TARGET libusb-1.0)
pkg_check_modules(GMP REQUIRED IMPORTED_TARGET gmp)


if(SCALPEL_BUILD_GUI)
  pkg_check_modules(GLFW REQUIRED IMPORTED_TARGET glfw3)
  # GLVND's libOpenGL (the GL entry points) and libEGL (offscreen contexts).
  find_package(OpenGL REQUIRED COMPONENTS OpenGL EGL)
  pkg_check_modules(IMGUI REQUIRED IMPORTED_TARGET imgui)
  pkg_check_modules(STB REQUIRED IMPORTED_TARGET stb)
endif()
if(SCALPEL_BUILD_TESTS OR SCALPEL_THREAD_TESTS)
  find_package(doctest REQUIRED)
endif()
if(SCALPEL_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()

# Teem's nrrd library reads scalar volumes (NRRD, attached or detached raw data) for the volume
# data scenarios (mesh/io/nrrd.cpp). Debian's libteem-dev ships no pkg-config file.
find_path(TEEM_INCLUDE_DIR teem/nrrd.h REQUIRED)
find_library(TEEM_LIBRARY teem REQUIRED)
add_library(scalpel_teem INTERFACE IMPORTED)
target_include_directories(scalpel_teem SYSTEM INTERFACE ${TEEM_INCLUDE_DIR})
target_link_libraries(scalpel_teem INTERFACE ${TEEM_LIBRARY})
