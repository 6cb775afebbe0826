#include "lightmesh/shadow/sphere_templates.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "lightmesh/util/error.h"
#include "lightmesh/util/log.h"
#include "lightmesh/util/system.h"

namespace lm {

namespace {

void CheckParameters(int ns, float ki) {
    if (ns < 1 || ns > 64) ThrowError("templates: ns must be between 1 and 64, got %d", ns);
    if (!(ki > 0 && ki <= 16)) ThrowError("templates: kI must be in (0, 16], got %g", ki);
}

/// One sub-position's template: its boundary nodes and its inner nodes, each in (dk, dj, di)
/// order. Membership is decided exactly in units of h/ns, where sub-positions and nodes have
/// integer coordinates: |node·ns - (a, b, c)|² <= (kI·ns)². A lattice row (dj, dk) meets the
/// sphere in an interval of di (the squared distance is exact and convex in di), found from
/// the square root and settled by the exact test, so the work follows the nodes listed
/// rather than the cube around them (20 times faster at kI 16 than testing every
/// node of the cube and its six neighbours); a node is on the boundary when it ends its
/// row or its neighbour in one of the four adjacent rows is outside.
class SubPositionBuilder {
  public:
    SubPositionBuilder(int ns, float ki)
        : ns_(ns),
          limit2_(static_cast<double>(ki) * ns * static_cast<double>(ki) * ns),
          reach_(static_cast<int>(std::ceil(ki)) + 1),
          side_(2 * reach_ + 3),
          lo_(static_cast<size_t>(side_) * side_),
          hi_(lo_.size()) {}

    void Build(int a, int b, int c, std::vector<std::array<int8_t, 3>>* boundary,
               std::vector<std::array<int8_t, 3>>* inner) {
        boundary->clear();
        inner->clear();
        // Every row from -reach-1 to reach+1: the rows just outside are neighbours.
        for (int dk = -reach_ - 1; dk <= reach_ + 1; ++dk)
            for (int dj = -reach_ - 1; dj <= reach_ + 1; ++dj) Row(a, b, c, dj, dk);
        for (int dk = -reach_; dk <= reach_; ++dk)
            for (int dj = -reach_; dj <= reach_; ++dj) {
                const size_t r = RowIndex(dj, dk);
                const int lo = std::max(lo_[r], -reach_), hi = std::min(hi_[r], reach_);
                for (int di = lo; di <= hi; ++di) {
                    const bool shell = di == lo_[r] || di == hi_[r] || !In(dj - 1, dk, di) || !In(dj + 1, dk, di) ||
                                       !In(dj, dk - 1, di) || !In(dj, dk + 1, di);
                    (shell ? boundary : inner)
                        ->push_back({static_cast<int8_t>(di), static_cast<int8_t>(dj), static_cast<int8_t>(dk)});
                }
            }
    }

  private:
    bool Inside(int a, int b, int c, int di, int dj, int dk) const {
        const double x = di * ns_ - a, y = dj * ns_ - b, z = dk * ns_ - c;
        return x * x + y * y + z * z <= limit2_;
    }
    size_t RowIndex(int dj, int dk) const {
        return static_cast<size_t>(dk + reach_ + 1) * side_ + static_cast<size_t>(dj + reach_ + 1);
    }
    bool In(int dj, int dk, int di) const {
        const size_t r = RowIndex(dj, dk);
        return di >= lo_[r] && di <= hi_[r];
    }
    void Row(int a, int b, int c, int dj, int dk) {
        const size_t r = RowIndex(dj, dk);
        const double y = dj * ns_ - b, z = dk * ns_ - c;
        const double rest = limit2_ - y * y - z * z;
        int lo = 1, hi = 0;  // empty
        if (rest >= 0) {
            const double w = std::sqrt(rest);
            lo = static_cast<int>(std::ceil((a - w) / ns_));
            hi = static_cast<int>(std::floor((a + w) / ns_));
            // Settle the square root's rounding with the exact test.
            while (Inside(a, b, c, lo - 1, dj, dk)) --lo;
            while (lo <= hi && !Inside(a, b, c, lo, dj, dk)) ++lo;
            while (Inside(a, b, c, hi + 1, dj, dk)) ++hi;
            while (hi >= lo && !Inside(a, b, c, hi, dj, dk)) --hi;
            if (lo > hi) lo = 1, hi = 0;
        }
        lo_[r] = lo;
        hi_[r] = hi;
    }

    int ns_;
    double limit2_;
    int reach_, side_;
    std::vector<int> lo_, hi_;  ///< per row (dj, dk): the interval of di inside (lo > hi: none)
};

}  // namespace

SphereTemplates SphereTemplates::Build(int ns, float ki) {
    CheckParameters(ns, ki);
    SphereTemplates t;
    t.ns = ns;
    t.ki = ki;
    // Reserved from the estimate (a sample of sub-positions, a few per cent high), so the
    // offsets do not double their memory while they grow.
    const TemplateEstimate estimate = EstimateSphereTemplates(ns, ki);
    t.offsets.reserve(static_cast<size_t>(static_cast<double>(estimate.entries) * 1.03) + 1024);
    t.begin.reserve(static_cast<size_t>(t.SubPositionCount()) + 1);
    t.boundaryCount.reserve(static_cast<size_t>(t.SubPositionCount()));
    SubPositionBuilder builder(ns, ki);
    std::vector<std::array<int8_t, 3>> boundary, inner;
    for (int c = 0; c <= ns; ++c) {
        for (int b = 0; b <= ns; ++b) {
            for (int a = 0; a <= ns; ++a) {
                builder.Build(a, b, c, &boundary, &inner);
                if (t.offsets.size() + boundary.size() + inner.size() > UINT32_MAX)
                    ThrowError("templates ns %d, kI %g: more than 4,294,967,295 entries, more than their "
                               "32-bit index holds",
                               ns, ki);
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

TemplateEstimate EstimateSphereTemplates(int ns, float ki) {
    CheckParameters(ns, ki);
    // Up to 5 sub-positions per axis, spread over the cell corner to corner: a node count
    // varies little from one to the next (the sphere's surface), so their mean gives the
    // whole within a per cent or two, and their build time the whole's.
    const int perAxis = std::min(ns + 1, 5);
    std::vector<int> picks;
    for (int i = 0; i < perAxis; ++i)
        picks.push_back(perAxis == 1 ? 0 : static_cast<int>(std::lround(static_cast<double>(i) * ns / (perAxis - 1))));
    SubPositionBuilder builder(ns, ki);
    std::vector<std::array<int8_t, 3>> boundary, inner;
    uint64_t sampled = 0;
    const auto start = std::chrono::steady_clock::now();
    for (int c : picks)
        for (int b : picks)
            for (int a : picks) {
                builder.Build(a, b, c, &boundary, &inner);
                sampled += boundary.size() + inner.size();
            }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double samples = static_cast<double>(picks.size() * picks.size() * picks.size());
    const double subPositions = std::pow(static_cast<double>(ns) + 1, 3);
    TemplateEstimate e;
    e.subPositions = static_cast<uint64_t>(subPositions);
    e.entriesPerSubPosition = static_cast<double>(sampled) / samples;
    e.entries = static_cast<uint64_t>(e.entriesPerSubPosition * subPositions);
    e.bytes = 3 * e.entries + 8 * e.subPositions;
    // The sample's time scaled up, plus the first touch of the arrays' memory (about 1 GB/s
    // of page faults: ns 32, kI 16 estimated at 2.5 s without, built in 4.1).
    e.buildSeconds = seconds / samples * subPositions + static_cast<double>(e.bytes) / 1e9;
    return e;
}

namespace {

std::string FitsHint(int ns, float ki, const TemplateEstimate& e, double maxEntries) {
    // ns at this kI: (ns + 1)³ sub-positions of e.entriesPerSubPosition entries each.
    const int nsFit = std::min(64, static_cast<int>(std::floor(std::cbrt(maxEntries / e.entriesPerSubPosition))) - 1);
    // kI at this ns: the entries grow as kI³ (the sphere's volume), scaled by what the
    // sample measured at this kI; rounded down to two digits.
    const double perUnitVolume = e.entriesPerSubPosition / (4.0 / 3.0 * 3.14159265358979 * std::pow(double(ki), 3));
    double kiFit = std::cbrt(maxEntries / e.subPositions / perUnitVolume / (4.0 / 3.0 * 3.14159265358979));
    const double step = kiFit >= 10 ? 1.0 : (kiFit >= 1 ? 0.1 : 0.01);
    kiFit = std::floor(kiFit / step) * step;
    std::string hint;
    if (nsFit >= 1) hint += StringPrintf("with kI %g, ns up to %d fits", ki, nsFit);
    else hint += StringPrintf("no ns fits with kI %g", ki);
    if (kiFit >= 0.01) hint += StringPrintf("; with ns %d, kI up to %g", ns, kiFit);
    return hint;
}

}  // namespace

TemplateEstimate CheckSphereTemplateBudget(int ns, float ki, uint64_t bytesPerEntry, const char* what) {
    const TemplateEstimate e = EstimateSphereTemplates(ns, ki);
    const double need = static_cast<double>(e.entries) * static_cast<double>(bytesPerEntry) + 8.0 * e.subPositions;
    const uint64_t physical = PhysicalMemoryBytes();
    const double budget = physical ? static_cast<double>(physical / 2) : 0;
    // The file format and the arrays index entries with 32 bits.
    const double indexable = static_cast<double>(UINT32_MAX);
    const double byMemory = budget > 0 ? (budget - 8.0 * e.subPositions) / static_cast<double>(bytesPerEntry) : indexable;
    const double maxEntries = std::min(indexable, byMemory);
    if (static_cast<double>(e.entries) > indexable)
        ThrowError("%s ns %d, kI %g: about %s entries (%s sub-positions of %.0f nodes), more than the 4,294,967,295 "
                   "their 32-bit index holds (%s would be needed); %s",
                   what, ns, ki, FormatCount(e.entries).c_str(), FormatCount(e.subPositions).c_str(),
                   e.entriesPerSubPosition, FormatBytes(static_cast<uint64_t>(need)).c_str(),
                   FitsHint(ns, ki, e, maxEntries).c_str());
    if (budget > 0 && need > budget)
        ThrowError("%s ns %d, kI %g would need about %s (%s entries, %llu bytes each), more than half of this "
                   "machine's %s (LIGHTMESH_MEMORY_LIMIT); %s",
                   what, ns, ki, FormatBytes(static_cast<uint64_t>(need)).c_str(), FormatCount(e.entries).c_str(),
                   static_cast<unsigned long long>(bytesPerEntry), FormatBytes(physical).c_str(),
                   FitsHint(ns, ki, e, maxEntries).c_str());
    return e;
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

/// The file's parts in order: the header, begin, boundaryCount, offsets.
template <typename F>
void ForEachPart(const Header& h, const SphereTemplates& t, F&& f) {
    f(reinterpret_cast<const unsigned char*>(&h), sizeof h);
    f(reinterpret_cast<const unsigned char*>(t.begin.data()), t.begin.size() * sizeof(uint32_t));
    f(reinterpret_cast<const unsigned char*>(t.boundaryCount.data()), t.boundaryCount.size() * sizeof(uint32_t));
    f(reinterpret_cast<const unsigned char*>(t.offsets.data()), t.offsets.size() * 3);
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
    // Written part by part, not copied into one buffer first (that doubled the memory of
    // large templates).
    uint64_t sum = 0xcbf29ce484222325ull;
    ForEachPart(h, t, [&](const unsigned char* data, size_t n) { sum = Fnv1a(data, n, sum); });
    WriteFileAtomically(path, [&](const std::string& tmp) {
        std::ofstream out(tmp, std::ios::binary);
        ForEachPart(h, t, [&](const unsigned char* data, size_t n) {
            if (n) out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(n));
        });
        out.write(reinterpret_cast<const char*>(&sum), sizeof sum);
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
    // Mapped, not read into a buffer: the file's pages are the page cache's, so a large
    // cache costs its arrays' memory once.
    const int fd = open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) ThrowErrorAt({path}, "cannot open: %s", std::strerror(errno));
    struct stat st {};
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(fd);
        ThrowErrorAt({path}, "is not a regular file");
    }
    const size_t length = static_cast<size_t>(st.st_size);
    void* mapped = length ? mmap(nullptr, length, PROT_READ, MAP_PRIVATE, fd, 0) : nullptr;
    close(fd);
    if (mapped == MAP_FAILED) ThrowErrorAt({path}, "cannot read: %s", std::strerror(errno));
    struct Unmap {
        void* p;
        size_t n;
        ~Unmap() {
            if (p) munmap(p, n);
        }
    } unmap{mapped, length};
    return ParseSphereTemplates(std::string_view(static_cast<const char*>(mapped), length), path, ns, ki);
}

// sphere_templates_check.cpp: every invariant of the geometry.
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
    // Before any file is read or anything built: refused past the memory budget with what
    // would fit; a build that takes a while is announced with its estimate.
    const TemplateEstimate estimate = CheckSphereTemplateBudget(ns, ki);
    const std::string dir = dirOption.empty() ? DefaultTemplateDir() : dirOption;
    if (!dir.empty()) {
        load.path = TemplateFileName(dir, ns, ki);
        std::error_code ec;
        if (std::filesystem::exists(load.path, ec)) {
            // Reading and checking every invariant runs at about 300 MB/s.
            if (static_cast<double>(estimate.bytes) / 3e8 > kAnnouncedTemplateSeconds)
                LogInfo(StringPrintf("templates ns %d, kI %g: reading and checking %s of cached templates: about %.0f s",
                                     ns, ki, FormatBytes(estimate.bytes).c_str(),
                                     std::ceil(static_cast<double>(estimate.bytes) / 3e8)));
            try {
                load.templates = ReadSphereTemplates(load.path, ns, ki);
                load.loaded = true;
            } catch (const Error& e) {
                load.note = std::string(e.what()) + "; rebuilding it";
            }
        }
    }
    if (!load.loaded) {
        // Writing the cache at a few hundred MB/s comes on top (ns 32, kI 16: 1.7 GiB).
        const double seconds = estimate.buildSeconds + (dir.empty() ? 0.0 : static_cast<double>(estimate.bytes) / 3e8);
        if (seconds > kAnnouncedTemplateSeconds)
            LogInfo(StringPrintf("templates ns %d, kI %g: building about %s entries (%s)%s: about %.0f s", ns, ki,
                                 FormatCount(estimate.entries).c_str(), FormatBytes(estimate.bytes).c_str(),
                                 dir.empty() ? "" : " and caching them", std::ceil(seconds)));
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
    CheckSphereTemplateBudget(ns, ki);
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
    // The snapped template marked in a cube around the cell (a lookup per node, not a
    // search: at kI 16 a sphere has 17,000 nodes in a cube of 43,000).
    const int side = 2 * reach + 1;
    std::vector<uint32_t> mark(static_cast<size_t>(side) * side * side, 0);
    auto cube = [&](int di, int dj, int dk) {
        return (static_cast<size_t>(dk + reach) * side + static_cast<size_t>(dj + reach)) * side + static_cast<size_t>(di + reach);
    };
    for (int s = 0; s < samples; ++s) {
        const double px = uniform(), py = uniform(), pz = uniform();
        const int a = static_cast<int>(std::lround(px * ns)), b = static_cast<int>(std::lround(py * ns)),
                  c = static_cast<int>(std::lround(pz * ns));
        const int sp = t.SubPosition(a, b, c);
        const uint32_t stamp = static_cast<uint32_t>(s) + 1;
        for (uint32_t i = t.begin[sp]; i < t.begin[sp + 1]; ++i) mark[cube(t.offsets[i][0], t.offsets[i][1], t.offsets[i][2])] = stamp;
        for (int dk = -reach; dk <= reach; ++dk)
            for (int dj = -reach; dj <= reach; ++dj)
                for (int di = -reach; di <= reach; ++di) {
                    const double dx = di - px, dy = dj - py, dz = dk - pz;
                    const bool exact = dx * dx + dy * dy + dz * dz <= static_cast<double>(ki) * ki;
                    const bool inTemplate = mark[cube(di, dj, dk)] == stamp;
                    exactTotal += exact;
                    mismatched += exact != inTemplate;
                }
    }
    e.mismatchedPerPoint = samples > 0 ? mismatched / samples : 0;
    e.mismatchedShare = exactTotal > 0 ? mismatched / exactTotal : 0;
    return e;
}

}  // namespace lm
