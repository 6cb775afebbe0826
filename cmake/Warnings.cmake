# Compiler flags shared by every target of the project (pbrt's pbrt_warnings pattern).
add_library(lightmesh_flags INTERFACE)
target_compile_options(lightmesh_flags INTERFACE
  -Wall -Wextra -Wno-unused-parameter
  # The watertight triangle test relies on a shared edge's edge functions being exact
  # negations in the two triangles; fused multiply-adds would break that.
  -ffp-contract=off)

# Sanitizer builds (the asan and tsan presets of CMakePresets.json): every target of the
# project, tests included, is compiled and linked with -fsanitize=$LIGHTMESH_SANITIZE.
# Undefined behaviour is fatal, so a test run under UBSan fails on the first report.
if(LIGHTMESH_SANITIZE)
  target_compile_options(lightmesh_flags INTERFACE -fsanitize=${LIGHTMESH_SANITIZE}
                         -fno-omit-frame-pointer -g)
  target_link_options(lightmesh_flags INTERFACE -fsanitize=${LIGHTMESH_SANITIZE})
  if(LIGHTMESH_SANITIZE MATCHES "undefined")
    target_compile_options(lightmesh_flags INTERFACE -fno-sanitize-recover=undefined)
  endif()
  if(LIGHTMESH_SANITIZE MATCHES "thread" AND CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    # TBB's headers are not instrumented: see the list for why.
    target_compile_options(lightmesh_flags INTERFACE
      -fsanitize-ignorelist=${PROJECT_SOURCE_DIR}/tests/sanitizers/tsan-ignorelist.txt)
  endif()
endif()
