# Compiler flags shared by every target of the project (pbrt's pbrt_warnings pattern).
add_library(lightmesh_flags INTERFACE)
target_compile_options(lightmesh_flags INTERFACE
  -Wall -Wextra -Wno-unused-parameter
  # The watertight triangle test relies on a shared edge's edge functions being exact
  # negations in the two triangles; fused multiply-adds would break that.
  -ffp-contract=off)
