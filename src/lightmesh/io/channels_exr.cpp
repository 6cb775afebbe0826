// channels_exr.cpp -- float channels to EXR (see the header).
#include "lightmesh/io/channels_exr.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>

#include <exception>

#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {

void WriteChannelsExr(const std::string& path, int width, int height, const std::vector<std::string>& names,
                      const std::vector<float>& values) {
    const size_t n = names.size();
    if (width <= 0 || height <= 0 || n == 0) ThrowErrorAt({path}, "empty image (no pixels or no channels)");
    if (values.size() != static_cast<size_t>(width) * static_cast<size_t>(height) * n)
        ThrowErrorAt({path}, "%zu values for %dx%d pixels of %zu channels", values.size(), width, height, n);
    WriteFileAtomically(path, [&](const std::string& tmp) {
        try {
            Imf::Header header(width, height);
            for (const std::string& name : names) header.channels().insert(name, Imf::Channel(Imf::FLOAT));
            Imf::OutputFile file(tmp.c_str(), header);
            Imf::FrameBuffer fb;
            char* base = reinterpret_cast<char*>(const_cast<float*>(values.data()));
            const size_t xs = sizeof(float) * n, ys = xs * static_cast<size_t>(width);
            for (size_t c = 0; c < n; ++c) fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys));
            file.setFrameBuffer(fb);
            file.writePixels(height);
        } catch (const Error&) {
            throw;
        } catch (const std::exception& e) {
            ThrowErrorAt({path}, "cannot write: %s", e.what());
        }
    });
}

std::vector<std::string> LightChannelNames(size_t lights) {
    const int digits = static_cast<int>(std::to_string(lights > 0 ? lights - 1 : 0).size());
    std::vector<std::string> names;
    names.reserve(lights);
    for (size_t l = 0; l < lights; ++l) names.push_back(StringPrintf("light%0*zu", digits, l));
    return names;
}

}  // namespace lm
