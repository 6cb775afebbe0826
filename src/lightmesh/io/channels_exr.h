// channels_exr.h -- an EXR of any number of named float channels (the per-light
// visibility of `lightmesh render --visibility`), written atomically as WriteImage writes.
#pragma once

#include <string>
#include <vector>

namespace lm {

/// Writes `values` (width × height pixels, names.size() floats per pixel, interleaved, row
/// by row from the top) to `path` (.exr) as one 32-bit float channel per name. Throws Error
/// naming the file; an existing file is left as it was on failure. At least one channel.
void WriteChannelsExr(const std::string& path, int width, int height, const std::vector<std::string>& names,
                      const std::vector<float>& values);

/// The channel names of per-light values: "light0", "light1", … zero-padded to the same
/// width ("light07" among 12 lights), so that readers sorting them by name keep the lights'
/// order.
std::vector<std::string> LightChannelNames(size_t lights);

}  // namespace lm
