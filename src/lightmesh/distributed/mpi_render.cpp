// mpi_render.cpp -- tiles over MPI ranks: a shared counter for dynamic scheduling, one
// gather of the tiles on rank 0 (see mpi_render.h).
#include "lightmesh/distributed/mpi_render.h"

#include <mpi.h>
#include <sched.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <exception>
#include <new>
#include <type_traits>

#include "lightmesh/util/error.h"
#include "lightmesh/util/parallel.h"
#include "lightmesh/util/system.h"

namespace lm {
namespace {

// RenderCounters is a plain run of uint64_t counters (the renderer's, then the shadow
// method's slots): it travels as such.
constexpr int kCounterWords = static_cast<int>(sizeof(RenderCounters) / sizeof(uint64_t));
static_assert(sizeof(RenderCounters) == kCounterWords * sizeof(uint64_t), "RenderCounters must be uint64_t only");
static_assert(std::is_trivially_copyable_v<RenderCounters>, "RenderCounters travels by memcpy");

// A rank's figures as one fixed-size message: tiles, batches, seconds and fetch seconds
// (their bits), nodes evaluated, then the counters.
constexpr int kReportWords = 5 + kCounterWords;

void Check(int code, const char* what) {
    if (code == MPI_SUCCESS) return;
    char text[MPI_MAX_ERROR_STRING];
    int length = 0;
    MPI_Error_string(code, text, &length);
    ThrowError("MPI: %s failed: %.*s", what, length, text);
}

// Test hooks (tests/mpi): LIGHTMESH_MPI_TEST_FAIL_RANK=k makes rank k fail as an
// out-of-memory would, once it has fetched its first batch of tiles (whether or not any were
// left: under load the other ranks may have taken them all); LIGHTMESH_MPI_TEST_KILL_RANK=k
// kills rank k there.
bool RankIs(const char* variable, int rank) {
    const char* v = std::getenv(variable);
    return v && *v && std::atoi(v) == rank;
}

// The tiles in Z order (Morton: the bits of tx and ty interleaved), so that a batch of
// consecutive ones is a compact patch of the image rather than a band of rows: fewer
// patch borders, so fewer light-mesh nodes that two ranks both evaluate.
std::vector<int> TilesInZOrder(int tilesX, int tiles) {
    auto spread = [](uint64_t v) {
        uint64_t r = 0;
        for (int b = 0; b < 32; ++b) r |= ((v >> b) & 1) << (2 * b);
        return r;
    };
    std::vector<std::pair<uint64_t, int>> keyed(static_cast<size_t>(tiles));
    for (int t = 0; t < tiles; ++t)
        keyed[static_cast<size_t>(t)] = {spread(static_cast<uint64_t>(t % tilesX)) | (spread(static_cast<uint64_t>(t / tilesX)) << 1), t};
    std::sort(keyed.begin(), keyed.end());
    std::vector<int> order(static_cast<size_t>(tiles));
    for (int i = 0; i < tiles; ++i) order[static_cast<size_t>(i)] = keyed[static_cast<size_t>(i)].second;
    return order;
}

}  // namespace

MpiSession::MpiSession(int* argc, char*** argv) {
    int provided = 0;
    Check(MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
    // Errors are returned, not fatal, so they become our messages.
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
}

MpiSession::~MpiSession() { MPI_Finalize(); }

bool MpiSession::AllSucceeded(const std::string& myError, std::string* message, int* failedRank) const {
    const int mine = myError.empty() ? size_ : rank_;
    int first = size_;
    Check(MPI_Allreduce(&mine, &first, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD), "MPI_Allreduce");
    if (first == size_) return true;
    *failedRank = first;
    if (first == 0) {
        if (rank_ == 0) *message = myError;
        return false;
    }
    if (rank_ == first) {
        Check(MPI_Send(myError.data(), static_cast<int>(myError.size()), MPI_CHAR, 0, 1, MPI_COMM_WORLD), "MPI_Send");
    } else if (rank_ == 0) {
        MPI_Status status;
        Check(MPI_Probe(first, 1, MPI_COMM_WORLD, &status), "MPI_Probe");
        int length = 0;
        MPI_Get_count(&status, MPI_CHAR, &length);
        message->assign(static_cast<size_t>(length), '\0');
        Check(MPI_Recv(message->data(), length, MPI_CHAR, first, 1, MPI_COMM_WORLD, MPI_STATUS_IGNORE), "MPI_Recv");
    }
    return false;
}

int MpiSession::DefaultThreads() const {
    cpu_set_t mine;
    CPU_ZERO(&mine);
    // A rank that cannot read its mask still takes part in the collectives below (an
    // empty mask: it shares with nobody and gets 1 thread), so no other rank waits for it.
    const bool known = sched_getaffinity(0, sizeof(mine), &mine) == 0;
    if (!known) CPU_ZERO(&mine);
    MPI_Comm node;
    Check(MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, rank_, MPI_INFO_NULL, &node),
          "MPI_Comm_split_type");
    int nodeSize = 1;
    MPI_Comm_size(node, &nodeSize);
    std::vector<cpu_set_t> masks(static_cast<size_t>(nodeSize));
    const int code = MPI_Allgather(&mine, sizeof(cpu_set_t), MPI_BYTE, masks.data(), sizeof(cpu_set_t), MPI_BYTE, node);
    MPI_Comm_free(&node);
    Check(code, "MPI_Allgather");
    int sharers = 0;
    for (cpu_set_t& other : masks) {
        cpu_set_t both;
        CPU_AND(&both, &mine, &other);
        if (CPU_COUNT(&both) > 0) ++sharers;
    }
    return known ? std::max(1, CPU_COUNT(&mine) / std::max(1, sharers)) : 1;
}

// Rank 0 collects every rank's figures and the tiles the others rendered into its own
// image (its tiles are there already): their indices, then their pixels, each tile's rows
// clipped to the image, in the order the rank rendered them.
static void GatherOnRankZero(int rank, int size, int tilesX, const RankReport& report, const std::vector<int>& mine,
                             Image* image, DistributedRender* out) {
    constexpr int T = WhittedRenderer::kTileSize;
    const int width = image->width, height = image->height;
    uint64_t words[kReportWords];
    words[0] = static_cast<uint64_t>(report.tiles);
    words[1] = static_cast<uint64_t>(report.batches);
    static_assert(sizeof(double) == sizeof(uint64_t));
    std::memcpy(&words[2], &report.seconds, sizeof(double));
    std::memcpy(&words[3], &report.fetchSeconds, sizeof(double));
    words[4] = report.nodesEvaluated;
    std::memcpy(&words[5], &report.counters, sizeof(RenderCounters));
    std::vector<uint64_t> all(rank == 0 ? static_cast<size_t>(kReportWords) * size : 0);
    Check(MPI_Gather(words, kReportWords, MPI_UINT64_T, all.data(), kReportWords, MPI_UINT64_T, 0, MPI_COMM_WORLD),
          "MPI_Gather");

    auto tileBox = [&](int t, int* x0, int* y0, int* w, int* h) {
        *x0 = (t % tilesX) * T;
        *y0 = (t / tilesX) * T;
        *w = std::min(T, width - *x0);
        *h = std::min(T, height - *y0);
    };
    std::vector<float> pixels;
    if (rank != 0) {
        pixels.reserve(mine.size() * T * T * 3);
        for (int t : mine) {
            int x0, y0, w, h;
            tileBox(t, &x0, &y0, &w, &h);
            for (int y = y0; y < y0 + h; ++y)
                for (int x = x0; x < x0 + w; ++x) {
                    const Color& c = image->At(x, y);
                    pixels.insert(pixels.end(), {c.r, c.g, c.b});
                }
        }
    }
    const int myTiles = rank == 0 ? 0 : static_cast<int>(mine.size()), myFloats = static_cast<int>(pixels.size());
    std::vector<int> tileCounts(rank == 0 ? size : 0), floatCounts(rank == 0 ? size : 0);
    Check(MPI_Gather(&myTiles, 1, MPI_INT, tileCounts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD), "MPI_Gather");
    Check(MPI_Gather(&myFloats, 1, MPI_INT, floatCounts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD), "MPI_Gather");
    std::vector<int> tileOffsets(rank == 0 ? size : 0), floatOffsets(rank == 0 ? size : 0);
    std::vector<int> allTiles;
    std::vector<float> allPixels;
    if (rank == 0) {
        int64_t nt = 0, nf = 0;
        for (int r = 0; r < size; ++r) {
            tileOffsets[r] = static_cast<int>(nt);
            floatOffsets[r] = static_cast<int>(nf);
            nt += tileCounts[r];
            nf += floatCounts[r];
        }
        if (nf > INT32_MAX) ThrowError("the other ranks' pixels (%lld floats) exceed one MPI message", static_cast<long long>(nf));
        allTiles.resize(static_cast<size_t>(nt));
        allPixels.resize(static_cast<size_t>(nf));
    }
    Check(MPI_Gatherv(mine.data(), myTiles, MPI_INT, allTiles.data(), tileCounts.data(), tileOffsets.data(), MPI_INT, 0,
                      MPI_COMM_WORLD),
          "MPI_Gatherv");
    Check(MPI_Gatherv(pixels.data(), myFloats, MPI_FLOAT, allPixels.data(), floatCounts.data(), floatOffsets.data(),
                      MPI_FLOAT, 0, MPI_COMM_WORLD),
          "MPI_Gatherv");
    if (rank != 0) return;

    size_t f = 0;
    for (int t : allTiles) {
        int x0, y0, w, h;
        tileBox(t, &x0, &y0, &w, &h);
        for (int y = y0; y < y0 + h; ++y)
            for (int x = x0; x < x0 + w; ++x, f += 3) image->At(x, y) = Color(allPixels[f], allPixels[f + 1], allPixels[f + 2]);
    }
    int64_t rendered = 0;
    for (int r = 0; r < size; ++r) {
        const uint64_t* w = &all[static_cast<size_t>(r) * kReportWords];
        RankReport rr;
        rr.rank = r;
        rr.tiles = static_cast<int>(w[0]);
        rr.batches = static_cast<int>(w[1]);
        std::memcpy(&rr.seconds, &w[2], sizeof(double));
        std::memcpy(&rr.fetchSeconds, &w[3], sizeof(double));
        rr.nodesEvaluated = w[4];
        std::memcpy(static_cast<void*>(&rr.counters), &w[5], sizeof(RenderCounters));
        rendered += rr.tiles;
        out->result.counters += rr.counters;
        out->ranks.push_back(rr);
    }
    if (rendered != int64_t(tilesX) * ((height + T - 1) / T))
        ThrowError("the ranks rendered %lld tiles, the image has %lld", static_cast<long long>(rendered),
                   static_cast<long long>(int64_t(tilesX) * ((height + T - 1) / T)));
    out->result.image = std::move(*image);
}

/// The end of a distributed render, on every rank: whether all ranks succeeded (the lowest
/// failing rank's message goes to rank 0, and nobody sends tiles), then the gathers. A
/// failure in a gather (out of memory on rank 0, an MPI error) would leave the other ranks
/// waiting in a collective, so it ends the whole job at once.
static DistributedRender Conclude(const MpiSession& session, int tilesX, const RankReport& report,
                                  const std::vector<int>& mine, const std::string& error,
                                  std::chrono::steady_clock::time_point start, Image* image) {
    const int rank = session.Rank(), size = session.Size();
    DistributedRender out;
    std::string message;
    int failedRank = -1;
    if (!session.AllSucceeded(error, &message, &failedRank)) {
        out.error = message;
        out.errorRank = failedRank;
        return out;
    }
    try {
        GatherOnRankZero(rank, size, tilesX, report, mine, image, &out);
    } catch (...) {
        std::fprintf(stderr, "lightmesh: error: %s (rank %d of %d, gathering the image)\n",
                     CurrentExceptionLine().c_str(), rank, size);
        MPI_Abort(MPI_COMM_WORLD, 1);
    }
    out.result.seconds = SecondsSince(start);
    return out;
}

DistributedRender RenderDistributed(const MpiSession& session, const WhittedRenderer& renderer,
                                    const std::function<uint64_t()>& nodesEvaluated,
                                    ProgressReporter* progress) {
    const int rank = session.Rank(), size = session.Size();
    const int64_t tiles = renderer.TileCount();
    const int tilesX = renderer.TilesX();

    // The counter of tiles handed out (in TilesInZOrder's order), on rank 0, advanced by
    // every rank.
    int64_t* counter = nullptr;
    MPI_Win window;
    Check(MPI_Win_allocate(rank == 0 ? sizeof(int64_t) : 0, sizeof(int64_t), MPI_INFO_NULL, MPI_COMM_WORLD, &counter,
                           &window),
          "MPI_Win_allocate");
    if (rank == 0) {
        MPI_Win_lock(MPI_LOCK_EXCLUSIVE, 0, 0, window);
        *counter = 0;
        MPI_Win_unlock(0, window);
    }
    Check(MPI_Barrier(MPI_COMM_WORLD), "MPI_Barrier");
    MPI_Win_lock_all(0, window);

    const int width = renderer.Width(), height = renderer.Height();
    Image image;
    std::vector<int> mine;  // the tiles this rank rendered, in the order it rendered them
    RankReport report;
    report.rank = rank;
    std::string error;
    const auto start = std::chrono::steady_clock::now();
    try {
        image = Image(width, height);
        const std::vector<int> order = TilesInZOrder(tilesX, static_cast<int>(tiles));
        std::vector<RenderCounters> tileCounters;
        int64_t seen = 0;      // the counter's value when this rank last read it
        int64_t reported = 0;  // tiles the progress bar shows as handed out
        for (;;) {
            // Guided batches: big while much is left, down to one tile at the end, so the
            // ranks finish together; the counter is read once per batch.
            int64_t batch = std::max<int64_t>(1, (tiles - seen) / (4 * int64_t(size)));
            int64_t first = 0;
            const auto fetchStart = std::chrono::steady_clock::now();
            Check(MPI_Fetch_and_op(&batch, &first, MPI_INT64_T, 0, 0, MPI_SUM, window), "MPI_Fetch_and_op");
            Check(MPI_Win_flush(0, window), "MPI_Win_flush");
            report.fetchSeconds += SecondsSince(fetchStart);
            const int64_t last = std::min(tiles, first + batch);
            if (progress && last > reported) {
                progress->Update(last - reported);
                reported = last;
            }
            if (RankIs("LIGHTMESH_MPI_TEST_KILL_RANK", rank)) std::raise(SIGKILL);
            if (RankIs("LIGHTMESH_MPI_TEST_FAIL_RANK", rank)) throw std::bad_alloc();
            if (first >= tiles) break;
            seen = last;
            tileCounters.assign(static_cast<size_t>(last - first), RenderCounters{});
            ParallelFor(tbb::blocked_range<int64_t>(first, last, 1), [&](const tbb::blocked_range<int64_t>& r) {
                for (int64_t i = r.begin(); i != r.end(); ++i)
                    renderer.RenderTile(order[static_cast<size_t>(i)], &image, tileCounters[static_cast<size_t>(i - first)]);
            });
            for (const RenderCounters& c : tileCounters) report.counters += c;
            for (int64_t i = first; i < last; ++i) mine.push_back(order[static_cast<size_t>(i)]);
            ++report.batches;
        }
    } catch (...) {
        error = CurrentExceptionLine();
    }
    report.seconds = SecondsSince(start);
    report.tiles = static_cast<int>(mine.size());
    if (nodesEvaluated) report.nodesEvaluated = nodesEvaluated();
    MPI_Win_unlock_all(window);
    MPI_Win_free(&window);

    return Conclude(session, tilesX, report, mine, error, start, &image);
}

DistributedRender RenderDistributedBands(const MpiSession& session, const WhittedRenderer& renderer,
                                         const BandRenderer& bands, ProgressReporter* progress) {
    const int rank = session.Rank(), size = session.Size();
    const int tilesX = renderer.TilesX(), tileRows = renderer.TileCount() / tilesX;
    constexpr int T = WhittedRenderer::kTileSize;
    // Rank r: tile rows [rows·r/size, rows·(r+1)/size).
    const int row0 = static_cast<int>(int64_t(tileRows) * rank / size);
    const int row1 = static_cast<int>(int64_t(tileRows) * (rank + 1) / size);
    Image image;
    std::vector<int> mine;
    RankReport report;
    report.rank = rank;
    std::string error;
    const auto start = std::chrono::steady_clock::now();
    try {
        image = Image(renderer.Width(), renderer.Height());
        if (row1 > row0) {
            bands.RenderRows(row0 * T, std::min(row1 * T, renderer.Height()), &image, report.counters, progress);
            report.batches = 1;
        }
        for (int t = row0 * tilesX; t < row1 * tilesX; ++t) mine.push_back(t);
        if (RankIs("LIGHTMESH_MPI_TEST_KILL_RANK", rank)) std::raise(SIGKILL);
        if (RankIs("LIGHTMESH_MPI_TEST_FAIL_RANK", rank)) throw std::bad_alloc();
    } catch (...) {
        error = CurrentExceptionLine();
    }
    report.seconds = SecondsSince(start);
    report.tiles = static_cast<int>(mine.size());

    return Conclude(session, tilesX, report, mine, error, start, &image);
}

}  // namespace lm
