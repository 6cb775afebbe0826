// fuzz_entry_points.h -- what the fuzzers run on one input. Shared by the libFuzzer targets
// (fuzz_scene_file.cpp, fuzz_template_file.cpp, fuzz_mesh_import.cpp, fuzz_image_decode.cpp) and by fuzz_regression_test.cpp, which
// replays the kept corpus and every crash found through the same code in the normal tests.
#pragma once

#include <cstddef>
#include <cstdint>

namespace lm::fuzz {

/// Loads the bytes as the text of a JSON scene file (its mesh files are small in-memory
/// meshes named box.obj, sphere.obj, quad.obj, dirty.obj, flat.obj; empty.obj and nan.obj
/// fail as such files do; any other name is missing), then, if it loads, renders it at a
/// few pixels with the scene's own shadow method and back-end (CC, kI and ns clamped so
/// that one input stays fast). Bad input must surface as lm::Error only: any other
/// exception escapes, and a broken invariant of a loaded scene aborts.
int FuzzSceneFile(const uint8_t* data, size_t size);

/// The bytes after the first are a sphere-template cache file, read for the (ns, kI) its
/// header names when in range (else ns 2, kI 1.5). If the first byte is odd, the file's
/// checksum is recomputed first, so the fuzzer also reaches the checks behind it. The
/// file must be rejected with lm::Error or give templates whose every index is in range.
int FuzzTemplateFile(const uint8_t* data, size_t size);

/// The first byte picks a mesh format (OBJ, PLY, OFF, glTF, GLB, COLLADA, AC3D, STL, NFF,
/// 3DS, by its value modulo 10); the rest is written to a file of that extension and
/// imported with ImportMeshInProcess under a small budget (Assimp's importers get
/// a target of their own). The import must end in lm::MeshFileError or give a mesh whose
/// every index is in range and every coordinate finite. `isolated` imports through
/// LoadMeshFile's child process instead (the FuzzRegression replay: inputs that crash
/// Assimp itself must come back as one MeshFileError).
int FuzzMeshImport(const uint8_t* data, size_t size, bool isolated = false);

/// The first byte picks the decoder: even, texture.h's DecodeImageBytes on the rest (PNG by
/// libpng, JPEG by libjpeg-turbo, TGA and BMP by stb_image, as a material's image is decoded); odd, the rest written to an .exr file and read by
/// OpenEXR. A decode must end in lm::Error or give as many texels as its size says. (The
/// renderer runs these decoders in a child process, texture_cache.h: a crash found here
/// costs one image, not the render; the target looks for them anyway.) `isolated` decodes
/// through TextureCache's child process instead (the FuzzRegression replay: inputs that
/// crash a decoder must come back as one warning).
int FuzzImageDecode(const uint8_t* data, size_t size, bool isolated = false);

}  // namespace lm::fuzz
