# Every dependency comes from Debian 12's packages (scripts/install-deps.sh installs them);
# nothing is downloaded at configure time. Each failure names the package to install.
function(lightmesh_require found package what)
  if(NOT ${found})
    message(FATAL_ERROR "lightmesh needs ${what}: run scripts/install-deps.sh "
                        "(or apt-get install ${package})")
  endif()
endfunction()

find_package(Threads REQUIRED)
find_package(TBB QUIET)
lightmesh_require(TBB_FOUND libtbb-dev "TBB (parallel loops)")
find_package(nlohmann_json 3 QUIET)
lightmesh_require(nlohmann_json_FOUND nlohmann-json3-dev "nlohmann-json (scene files)")
find_package(CLI11 QUIET)
lightmesh_require(CLI11_FOUND libcli11-dev "CLI11 (command line)")
find_package(OpenEXR 3 QUIET)
lightmesh_require(OpenEXR_FOUND libopenexr-dev "OpenEXR (EXR images)")
find_package(assimp QUIET)
lightmesh_require(assimp_FOUND libassimp-dev "Assimp (mesh import)")
find_package(tinyobjloader QUIET)
lightmesh_require(tinyobjloader_FOUND libtinyobjloader-dev "tinyobjloader (OBJ files)")
find_package(ZLIB QUIET)
lightmesh_require(ZLIB_FOUND zlib1g-dev "zlib (PNG compression)")

# Images: PNG by libpng, JPEG by libjpeg-turbo (maintained, patched by Debian, fuzzed by
# OSS-Fuzz); stb_image only for TGA and BMP textures.
find_package(PNG QUIET)
lightmesh_require(PNG_FOUND libpng-dev "libpng (PNG decoding)")
find_package(JPEG QUIET)
lightmesh_require(JPEG_FOUND libjpeg62-turbo-dev "libjpeg-turbo (JPEG decoding)")
find_package(PkgConfig REQUIRED)
pkg_check_modules(STB QUIET stb)
find_path(STB_IMAGE_DIR stb_image.h HINTS ${STB_INCLUDE_DIRS} PATH_SUFFIXES stb)
lightmesh_require(STB_IMAGE_DIR libstb-dev "stb_image (TGA and BMP textures)")

if(LIGHTMESH_ENABLE_EMBREE)
  find_package(embree 3 QUIET)
  if(NOT embree_FOUND)
    message(FATAL_ERROR "lightmesh needs Embree 3 for its embree back-end: run "
                        "scripts/install-deps.sh (or apt-get install libembree-dev), or "
                        "configure with -DLIGHTMESH_ENABLE_EMBREE=OFF")
  endif()
endif()

if(LIGHTMESH_BUILD_TESTS)
  find_package(GTest QUIET)
  lightmesh_require(GTest_FOUND "libgtest-dev libgmock-dev" "GoogleTest (tests)")
endif()
if(LIGHTMESH_BUILD_BENCHMARKS)
  find_package(benchmark QUIET)
  lightmesh_require(benchmark_FOUND libbenchmark-dev "Google Benchmark (benchmarks)")
endif()

# MPI (OpenMPI from libopenmpi-dev) is optional: without it lightmesh renders on one
# process and says so when started by mpirun. LIGHTMESH_HAS_MPI tells the code.
set(LIGHTMESH_HAS_MPI OFF)
if(LIGHTMESH_ENABLE_MPI)
  find_package(MPI QUIET COMPONENTS CXX)
  if(MPI_CXX_FOUND)
    set(LIGHTMESH_HAS_MPI ON)
  else()
    message(STATUS "lightmesh: MPI not found (apt-get install libopenmpi-dev openmpi-bin, or "
                   "scripts/install-deps.sh): building without `mpirun -np N lightmesh render`")
  endif()
endif()

# The Python module (python/): pybind11 (pybind11-dev) against Debian's python3 and NumPy
# (python3-dev, python3-numpy). Optional: without them it is left out, and said so.
# LIGHTMESH_HAS_PYTHON tells python/CMakeLists.txt.
set(LIGHTMESH_HAS_PYTHON OFF)
if(LIGHTMESH_BUILD_PYTHON)
  # Debian's interpreter, whose dist-packages hold python3-numpy, unless one is named
  # (-DPython3_EXECUTABLE=...): a pyenv or conda python3 first on the PATH has no NumPy.
  if(NOT DEFINED Python3_EXECUTABLE AND EXISTS /usr/bin/python3)
    set(Python3_EXECUTABLE /usr/bin/python3)
  endif()
  find_package(Python3 QUIET COMPONENTS Interpreter Development.Module NumPy)
  if(Python3_FOUND AND Python3_NumPy_FOUND)
    set(PYBIND11_FINDPYTHON ON)
    find_package(pybind11 CONFIG QUIET)
  endif()
  if(Python3_FOUND AND Python3_NumPy_FOUND AND pybind11_FOUND)
    set(LIGHTMESH_HAS_PYTHON ON)
  else()
    message(STATUS "lightmesh: the Python module is not built: it needs pybind11, Python 3 with its headers "
                   "and NumPy (apt-get install pybind11-dev python3-dev python3-numpy, or scripts/install-deps.sh)")
  endif()
endif()
