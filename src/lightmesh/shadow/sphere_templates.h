// sphere_templates.h -- precomputed interpolation-sphere node sets (paper §3.1, "Ш"), with
// their boundary shells (§3.2, "У"), cached on disk.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace lm {

/// For every sub-position of a light-mesh cell, the nodes within the interpolation sphere.
///
/// A cell [LM0, LM0 + h]³ is split into ns steps per side, giving (ns+1)³ sub-positions
/// s = LM0 + (a, b, c)·h/ns, 0 <= a, b, c <= ns. For each, the template lists the node
/// offsets (di, dj, dk) relative to LM0 with |(di, dj, dk) - (a, b, c)/ns| <= kI, in units
/// of h — so a template depends only on (ns, kI), never on the scene. At render time P
/// snaps to its nearest sub-position and the list replaces the cube loop and its distance
/// tests. Each list starts with its boundary nodes: those with at least one of their six
/// lattice neighbours outside the set (the outer shell of the discrete sphere).
struct SphereTemplates {
    int ns = 0;
    float ki = 0;
    /// Entries of sub-position s are offsets[begin[s] .. begin[s+1]); the first
    /// boundaryCount[s] of them are its boundary nodes.
    std::vector<uint32_t> begin;
    std::vector<uint32_t> boundaryCount;
    std::vector<std::array<int8_t, 3>> offsets;

    int SubPositionsPerSide() const { return ns + 1; }
    int SubPositionCount() const { return (ns + 1) * (ns + 1) * (ns + 1); }
    /// Index of sub-position (a, b, c).
    int SubPosition(int a, int b, int c) const { return (c * (ns + 1) + b) * (ns + 1) + a; }
    bool operator==(const SphereTemplates&) const = default;

    /// Builds the templates. Throws Error for ns outside [1, 64] or kI outside (0, 16], or
    /// beyond the 32-bit index (CheckSphereTemplateBudget says so before building).
    static SphereTemplates Build(int ns, float ki);
};

/// The size and build time of the templates for (ns, kI), estimated before anything is
/// built: the nodes of 5 × 5 × 5 sub-positions spread over the cell (all of them for ns < 4)
/// are counted and their build timed, and both scaled to the (ns + 1)³ sub-positions. The
/// count is within a per cent or two (a template's size varies only by its surface).
struct TemplateEstimate {
    uint64_t subPositions = 0;
    double entriesPerSubPosition = 0;
    uint64_t entries = 0;     ///< all sub-positions' nodes
    uint64_t bytes = 0;       ///< the templates' memory: 3 per entry + 8 per sub-position
    double buildSeconds = 0;  ///< measured on the sample, + 1 s per GB of memory touched
};
TemplateEstimate EstimateSphereTemplates(int ns, float ki);

/// The estimate, or an Error before anything is allocated when the templates for (ns, kI)
/// would need more than half the memory budget (PhysicalMemoryBytes: the machine's, a
/// container's or LIGHTMESH_MEMORY_LIMIT) at `bytesPerEntry` (the templates' 3; the light
/// mesh's copy for its kernels adds 8), or more entries than their 32-bit index holds: the
/// message names `what`, says what they would need, and which ns at this kI and which kI at
/// this ns fit (ns 32, kI 16: 616 M entries, 1.7 GiB; ns 64, kI 16: 4.7 G entries, too many
/// for the index).
TemplateEstimate CheckSphereTemplateBudget(int ns, float ki, uint64_t bytesPerEntry = 3,
                                           const char* what = "templates");

/// Builds estimated to take longer than this are announced (LogInfo) with the estimate.
inline constexpr double kAnnouncedTemplateSeconds = 5.0;

/// Writes templates to a file atomically (temporary file + rename): concurrent writers of
/// the same templates never leave a corrupt file. Format: a header (magic "LMSPHTPL",
/// format version, ns, kI, counts), the arrays, and a 64-bit FNV-1a checksum of all that.
void WriteSphereTemplates(const std::string& path, const SphereTemplates& t);

/// Reads and validates a template file: magic, version, ns and kI as expected, sizes
/// consistent with the header and with the file's length, checksum, and every offset in
/// range. Throws Error with a one-line reason otherwise.
SphereTemplates ReadSphereTemplates(const std::string& path, int ns, float ki);

/// The validation of ReadSphereTemplates on a file's bytes already in memory; `name` is
/// used in messages. The entry point of the template-file fuzzer (fuzz/).
SphereTemplates ParseSphereTemplates(std::string_view bytes, const std::string& name, int ns,
                                     float ki);

/// Where templates are cached: $XDG_CACHE_HOME/lightmesh/templates, else
/// $HOME/.cache/lightmesh/templates; empty if neither is set.
std::string DefaultTemplateDir();

/// The cache file for (ns, kI) in `dir`.
std::string TemplateFileName(const std::string& dir, int ns, float ki);

/// Templates for (ns, kI): read from the cache in `dir` (DefaultTemplateDir() if empty)
/// when a valid file is there, else built and written there. A missing, truncated,
/// corrupt or foreign file is reported in `note` (one line), rebuilt and replaced; a cache
/// that cannot be written is reported and the templates are used from memory. Checked
/// first against the memory budget (CheckSphereTemplateBudget); a build estimated over
/// kAnnouncedTemplateSeconds is announced with its size and time.
struct TemplateLoad {
    SphereTemplates templates;
    bool loaded = false;   ///< read from disk (else built)
    bool written = false;  ///< built and written to disk
    double seconds = 0;    ///< time to read, or to build and write
    std::string path;      ///< the cache file
    std::string note;      ///< why a file was rebuilt or not written; empty if all went well
};
TemplateLoad LoadOrBuildSphereTemplates(int ns, float ki, const std::string& dir);

/// What snapping P to the nearest of the (ns+1)³ sub-positions costs (`templates
/// --measure`, how the default ns was chosen): for `samples` points P uniform in a cell
/// (a fixed xorshift sequence, so the figures repeat), the nodes where the snapped
/// template's set and the exact set |x − P| ≤ kI·h differ.
struct TemplateSnapError {
    size_t entries = 0;          ///< the templates' entries (all sub-positions)
    double mismatchedPerPoint = 0;
    double mismatchedShare = 0;  ///< of the exact sets' nodes
    double buildSeconds = 0;
};
TemplateSnapError MeasureTemplateSnapping(int ns, float ki, int samples = 20000);

/// The default ns (sub-steps per cell side), chosen by measurement: see the README.
inline constexpr int kDefaultTemplateSubsteps = 8;

}  // namespace lm
