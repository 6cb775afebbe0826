#include "lightmesh/shadow/sphere_templates.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "lightmesh/util/error.h"
#include "lightmesh/util/system.h"

namespace lm {

SphereTemplates SphereTemplates::Build(int ns, float ki) {
    if (ns < 1 || ns > 64) ThrowError("templates: ns must be between 1 and 64, got %d", ns);
    if (!(ki > 0 && ki <= 16)) ThrowError("templates: kI must be in (0, 16], got %g", ki);
    SphereTemplates t;
    t.ns = ns;
    t.ki = ki;
    // Work in units of h/ns, where sub-positions and nodes have integer coordinates, so
    // membership is decided exactly: |node·ns - (a, b, c)|² <= (kI·ns)².
    const double limit2 = static_cast<double>(ki) * ns * static_cast<double>(ki) * ns;
    const int reach = static_cast<int>(std::ceil(ki)) + 1;
    auto inside = [&](int a, int b, int c, int di, int dj, int dk) {
        const double x = di * ns - a, y = dj * ns - b, z = dk * ns - c;
        return x * x + y * y + z * z <= limit2;
    };
    std::vector<std::array<int8_t, 3>> boundary, inner;
    for (int c = 0; c <= ns; ++c) {
        for (int b = 0; b <= ns; ++b) {
            for (int a = 0; a <= ns; ++a) {
                boundary.clear();
                inner.clear();
                for (int dk = -reach; dk <= reach; ++dk)
                    for (int dj = -reach; dj <= reach; ++dj)
                        for (int di = -reach; di <= reach; ++di) {
                            if (!inside(a, b, c, di, dj, dk)) continue;
                            const bool shell = !inside(a, b, c, di - 1, dj, dk) || !inside(a, b, c, di + 1, dj, dk) ||
                                               !inside(a, b, c, di, dj - 1, dk) || !inside(a, b, c, di, dj + 1, dk) ||
                                               !inside(a, b, c, di, dj, dk - 1) || !inside(a, b, c, di, dj, dk + 1);
                            const std::array<int8_t, 3> o{static_cast<int8_t>(di), static_cast<int8_t>(dj),
                                                          static_cast<int8_t>(dk)};
                            (shell ? boundary : inner).push_back(o);
                        }
                t.begin.push_back(static_cast<uint32_t>(t.offsets.size()));
                t.boundaryCount.push_back(static_cast<uint32_t>(boundary.size()));
                t.offsets.insert(t.offsets.end(), boundary.begin(), boundary.end());
                t.offsets.insert(t.offsets.end(), inner.begin(), inner.end());
            }
        }
    }
    t.begin.push_back(static_cast<uint32_t>(t.offsets.size()));
    return t;
}

namespace {

constexpr char kMagic[8] = {'L', 'M', 'S', 'P', 'H', 'T', 'P', 'L'};
constexpr uint32_t kVersion = 1;

struct Header {
    char magic[8];
    uint32_t version;
    int32_t ns;
    float ki;
    uint32_t subPositions;
    uint32_t entries;
    uint32_t reserved;
};
static_assert(sizeof(Header) == 32);

uint64_t Fnv1a(const unsigned char* data, size_t n, uint64_t h = 0xcbf29ce484222325ull) {
    for (size_t i = 0; i < n; ++i) h = (h ^ data[i]) * 0x100000001b3ull;
    return h;
}

template <typename T>
void Append(std::string* out, const T* data, size_t count) {
    out->append(reinterpret_cast<const char*>(data), count * sizeof(T));
}

}  // namespace

void WriteSphereTemplates(const std::string& path, const SphereTemplates& t) {
    Header h{};
    std::memcpy(h.magic, kMagic, 8);
    h.version = kVersion;
    h.ns = t.ns;
    h.ki = t.ki;
    h.subPositions = static_cast<uint32_t>(t.SubPositionCount());
    h.entries = static_cast<uint32_t>(t.offsets.size());
    std::string bytes;
    Append(&bytes, &h, 1);
    Append(&bytes, t.begin.data(), t.begin.size());
    Append(&bytes, t.boundaryCount.data(), t.boundaryCount.size());
    Append(&bytes, t.offsets.data(), t.offsets.size());
    const uint64_t sum = Fnv1a(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size());
    Append(&bytes, &sum, 1);
    WriteFileAtomically(path, [&](const std::string& tmp) {
        std::ofstream out(tmp, std::ios::binary);
        out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        out.close();
        if (!out) ThrowErrorAt({path}, "cannot write: %s", std::strerror(errno));
    });
}

SphereTemplates ReadSphereTemplates(const std::string& path, int ns, float ki) {
    if (ns < 1 || ns > 64 || !(ki > 0 && ki <= 16))
        ThrowErrorAt({path}, "cannot hold templates for ns %d, kI %g (out of range)", ns, ki);
    // Refuse a file larger than any template file for (ns, kI) before reading it.
    const uint64_t sideMax = static_cast<uint64_t>(std::clamp(ns, 1, 64)) + 1;
    const uint64_t reachMax = static_cast<uint64_t>(std::ceil(std::clamp(ki, 0.0f, 16.0f))) + 1;
    const uint64_t maxBytes = sizeof(Header) + 8 * (sideMax * sideMax * sideMax + 1) + 8 +
                              3 * sideMax * sideMax * sideMax * (2 * reachMax + 1) * (2 * reachMax + 1) * (2 * reachMax + 1);
    std::error_code ec;
    const uint64_t size = std::filesystem::file_size(path, ec);
    if (ec) ThrowErrorAt({path}, "cannot open: %s", ec.message().c_str());
    if (size > maxBytes)
        ThrowErrorAt({path}, "%llu bytes, more than templates for ns %d, kI %g can take",
                   static_cast<unsigned long long>(size), ns, ki);
    std::ifstream in(path, std::ios::binary);
    if (!in) ThrowErrorAt({path}, "cannot open: %s", std::strerror(errno));
    const std::string bytes{std::istreambuf_iterator<char>(in), {}};
    return ParseSphereTemplates(bytes, path, ns, ki);
}

// sphere_templates_check.cpp: every invariant of the geometry (issue 16).
void CheckSphereTemplateGeometry(const SphereTemplates& t, const std::string& path);

SphereTemplates ParseSphereTemplates(std::string_view bytes, const std::string& path, int ns,
                                     float ki) {
    if (ns < 1 || ns > 64 || !(ki > 0 && ki <= 16))
        ThrowErrorAt({path}, "cannot hold templates for ns %d, kI %g (out of range)", ns, ki);
    if (bytes.size() < sizeof(Header) + sizeof(uint64_t))
        ThrowErrorAt({path}, "truncated (%zu bytes)", bytes.size());
    Header h;
    std::memcpy(&h, bytes.data(), sizeof(Header));
    if (std::memcmp(h.magic, kMagic, 8) != 0) ThrowErrorAt({path}, "not a lightmesh template file");
    if (h.version != kVersion)
        ThrowErrorAt({path}, "format version %u, expected %u", h.version, kVersion);
    if (h.ns != ns || std::memcmp(&h.ki, &ki, sizeof(float)) != 0)
        ThrowErrorAt({path}, "holds templates for ns %d, kI %g, not ns %d, kI %g", h.ns, h.ki, ns, ki);
    const uint64_t side = static_cast<uint64_t>(ns) + 1;
    if (h.subPositions != side * side * side)
        ThrowErrorAt({path}, "%u sub-positions, expected %llu", h.subPositions,
                   static_cast<unsigned long long>(side * side * side));
    const uint64_t expected = sizeof(Header) + (h.subPositions + 1ull) * 4 + h.subPositions * 4ull +
                              h.entries * 3ull + sizeof(uint64_t);
    if (bytes.size() != expected)
        ThrowErrorAt({path}, "%zu bytes, expected %llu (truncated or corrupt)", bytes.size(),
                   static_cast<unsigned long long>(expected));
    uint64_t sum;
    std::memcpy(&sum, bytes.data() + bytes.size() - sizeof(uint64_t), sizeof(uint64_t));
    if (sum != Fnv1a(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size() - sizeof(uint64_t)))
        ThrowErrorAt({path}, "checksum mismatch (corrupt)");
    SphereTemplates t;
    t.ns = ns;
    t.ki = ki;
    const char* p = bytes.data() + sizeof(Header);
    t.begin.resize(h.subPositions + 1);
    std::memcpy(t.begin.data(), p, t.begin.size() * 4);
    p += t.begin.size() * 4;
    t.boundaryCount.resize(h.subPositions);
    std::memcpy(t.boundaryCount.data(), p, t.boundaryCount.size() * 4);
    p += t.boundaryCount.size() * 4;
    t.offsets.resize(h.entries);
    // A forged file may list no entries at all: memcpy from or to null is undefined even
    // for 0 bytes (found by fuzz_template_file).
    if (!t.offsets.empty()) std::memcpy(t.offsets.data(), p, t.offsets.size() * 3);
    // The checksum catches accidents; these checks make a forged file harmless too.
    if (t.begin.front() != 0 || t.begin.back() != h.entries)
        ThrowErrorAt({path}, "inconsistent index (corrupt)");
    const int reach = static_cast<int>(std::ceil(ki)) + 1;
    for (uint32_t s = 0; s < h.subPositions; ++s)
        if (t.begin[s] > t.begin[s + 1] || t.boundaryCount[s] > t.begin[s + 1] - t.begin[s])
            ThrowErrorAt({path}, "inconsistent index (corrupt)");
    for (const auto& o : t.offsets)
        for (int8_t v : o)
            if (v < -reach || v > reach) ThrowErrorAt({path}, "offset out of range (corrupt)");
    CheckSphereTemplateGeometry(t, path);
    return t;
}

std::string DefaultTemplateDir() { return CacheDir("templates"); }

std::string TemplateFileName(const std::string& dir, int ns, float ki) {
    // kI with 9 significant digits names a float uniquely.
    return (std::filesystem::path(dir) / StringPrintf("sphere-ns%d-ki%.9g.lmt", ns, ki)).string();
}

TemplateLoad LoadOrBuildSphereTemplates(int ns, float ki, const std::string& dirOption) {
    using Clock = std::chrono::steady_clock;
    const auto start = Clock::now();
    TemplateLoad load;
    const std::string dir = dirOption.empty() ? DefaultTemplateDir() : dirOption;
    if (!dir.empty()) {
        load.path = TemplateFileName(dir, ns, ki);
        std::error_code ec;
        if (std::filesystem::exists(load.path, ec)) {
            try {
                load.templates = ReadSphereTemplates(load.path, ns, ki);
                load.loaded = true;
            } catch (const Error& e) {
                load.note = std::string(e.what()) + "; rebuilding it";
            }
        }
    }
    if (!load.loaded) {
        load.templates = SphereTemplates::Build(ns, ki);
        if (dir.empty()) {
            load.note = "no cache folder (neither XDG_CACHE_HOME nor HOME is set): templates kept in memory";
        } else {
            try {
                std::filesystem::create_directories(dir);
                WriteSphereTemplates(load.path, load.templates);
                load.written = true;
            } catch (const std::exception& e) {
                load.note = (load.note.empty() ? "" : load.note + "; ") + "cannot cache templates: " + e.what();
            }
        }
    }
    load.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    return load;
}

TemplateSnapError MeasureTemplateSnapping(int ns, float ki, int samples) {
    const auto t0 = std::chrono::steady_clock::now();
    const SphereTemplates t = SphereTemplates::Build(ns, ki);
    TemplateSnapError e;
    e.buildSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    e.entries = t.offsets.size();
    uint64_t state = 0x9E3779B97F4A7C15ull;  // xorshift64: the same points every run
    auto uniform = [&state] {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        return static_cast<double>(state >> 11) * 0x1.0p-53;
    };
    const int reach = static_cast<int>(std::ceil(ki)) + 1;
    double mismatched = 0, exactTotal = 0;
    std::vector<std::array<int8_t, 3>> list;
    for (int s = 0; s < samples; ++s) {
        const double px = uniform(), py = uniform(), pz = uniform();
        const int a = static_cast<int>(std::lround(px * ns)), b = static_cast<int>(std::lround(py * ns)),
                  c = static_cast<int>(std::lround(pz * ns));
        const int sp = t.SubPosition(a, b, c);
        list.assign(t.offsets.begin() + t.begin[sp], t.offsets.begin() + t.begin[sp + 1]);
        std::sort(list.begin(), list.end());
        for (int dk = -reach; dk <= reach; ++dk)
            for (int dj = -reach; dj <= reach; ++dj)
                for (int di = -reach; di <= reach; ++di) {
                    const double dx = di - px, dy = dj - py, dz = dk - pz;
                    const bool exact = dx * dx + dy * dy + dz * dz <= static_cast<double>(ki) * ki;
                    const std::array<int8_t, 3> o{static_cast<int8_t>(di), static_cast<int8_t>(dj), static_cast<int8_t>(dk)};
                    const bool inTemplate = std::binary_search(list.begin(), list.end(), o);
                    exactTotal += exact;
                    mismatched += exact != inTemplate;
                }
    }
    e.mismatchedPerPoint = samples > 0 ? mismatched / samples : 0;
    e.mismatchedShare = exactTotal > 0 ? mismatched / exactTotal : 0;
    return e;
}

}  // namespace lm
