#include "lightmesh/util/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "lightmesh/util/error.h"
#include "lightmesh/util/log.h"
#include "lightmesh/util/system.h"

namespace lm {

ProgressReporter::ProgressReporter(int64_t total, std::string title, bool enabled)
    : total_(total > 0 ? total : 1), title_(std::move(title)), enabled_(enabled),
      start_(std::chrono::steady_clock::now()), lastDraw_(start_), workStart_(start_) {}

void ProgressReporter::RefuseIfLonger(double limitSeconds, std::string more) {
    refuseAfter_ = limitSeconds;
    howToForce_ = std::move(more);
}

void ProgressReporter::BeginWork(int64_t sampleUnits, std::string sampleWhat) {
    workStart_ = std::chrono::steady_clock::now();
    setupSeconds_ = std::chrono::duration<double>(workStart_ - start_).count();
    sample_ = std::clamp<int64_t>(sampleUnits, 0, total_);
    sampleWhat_ = std::move(sampleWhat);
}

std::vector<int64_t> SpreadOverGrid(int64_t cols, int64_t rows, int64_t n) {
    std::vector<int64_t> cells;
    if (cols < 1 || rows < 1 || n < 1) return cells;
    if (n >= cols * rows) {
        for (int64_t i = 0; i < cols * rows; ++i) cells.push_back(i);
        return cells;
    }
    // Strata of the grid's aspect, sc across and sr down, sc·sr at most n; the centre cell
    // of each, ordered by their column and row numbers bit-reversed and interleaved, so the
    // first four lie in the four quadrants, the first sixteen in the sixteen, and so on.
    const double aspect = static_cast<double>(cols) / static_cast<double>(rows);
    const int64_t sc = std::clamp<int64_t>(std::llround(std::sqrt(static_cast<double>(n) * aspect)), 1, std::min(cols, n));
    const int64_t sr = std::clamp<int64_t>(n / sc, 1, rows);
    auto bitsFor = [](int64_t count) {
        int bits = 0;
        while ((int64_t(1) << bits) < count) ++bits;
        return bits;
    };
    auto reversed = [](int64_t v, int bits) {
        int64_t r = 0;
        for (int b = 0; b < bits; ++b) r |= ((v >> b) & 1) << (bits - 1 - b);
        return r;
    };
    const int bc = bitsFor(sc), br = bitsFor(sr);
    std::vector<std::pair<uint64_t, int64_t>> keyed;  // (order key, cell)
    for (int64_t r = 0; r < sr; ++r)
        for (int64_t c = 0; c < sc; ++c) {
            const int64_t rc = reversed(c, bc), rr = reversed(r, br);
            uint64_t key = 0;
            for (int b = 0; b < std::max(bc, br); ++b)
                key |= static_cast<uint64_t>((rc >> b) & 1) << (2 * b) | static_cast<uint64_t>((rr >> b) & 1) << (2 * b + 1);
            const int64_t row = (2 * r + 1) * rows / (2 * sr), col = (2 * c + 1) * cols / (2 * sc);
            keyed.push_back({key, row * cols + col});
        }
    std::sort(keyed.begin(), keyed.end());
    for (const auto& [key, cell] : keyed) cells.push_back(cell);
    return cells;
}

double ProgressSecondsLeft(double workSeconds, double fraction) {
    if (!(fraction >= kProgressEstimateShare) || !(workSeconds >= kProgressEstimateSeconds) || !(fraction < 1))
        return fraction >= 1 ? 0.0 : -1.0;
    return workSeconds * (1.0 - fraction) / fraction;
}

ProgressReporter::~ProgressReporter() { Done(); }

bool ProgressReporter::StderrIsTerminal() { return isatty(STDERR_FILENO) == 1; }

double ProgressReporter::ElapsedSeconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void ProgressReporter::AnnounceIfLong(double thresholdSeconds, std::string what) {
    announceAfter_ = thresholdSeconds;
    announceWhat_ = std::move(what);
}

void ProgressReporter::Update(int64_t units) {
    const int64_t done = done_.fetch_add(units, std::memory_order_relaxed) + units;
    // The moment the sample is done, whichever thread gets there (the lock below may skip).
    if (sample_ > 0 && done >= sample_ && done - units < sample_)
        sampleSeconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - workStart_).count();
    if (!enabled_ &&
        (announced_.load(std::memory_order_relaxed) || (announceAfter_ < 0 && refuseAfter_ < 0 && sample_ == 0)))
        return;
    std::unique_lock<std::mutex> lock(drawMutex_, std::try_to_lock);
    if (!lock.owns_lock()) return;  // another thread is drawing; skip this update
    if (!announced_.load(std::memory_order_relaxed)) {
        const double elapsed = ElapsedSeconds();
        const double sampleSeconds = sampleSeconds_.load();
        const bool sampled = sample_ > 0;
        // kMeasureSeconds of the work itself when its set-up is apart.
        if ((sampled ? elapsed - setupSeconds_ : elapsed) >= kMeasureSeconds || done >= total_ || sampleSeconds >= 0) {
            announced_ = true;
            // From the sample (or the part of it done), its time without the set-up; else
            // from the share done, set-up included.
            const double measured = static_cast<double>(sampled ? std::min(done, sample_) : done);
            const double fraction = std::min(1.0, measured / static_cast<double>(total_));
            const double workSeconds = sampled ? (sampleSeconds >= 0 ? sampleSeconds : elapsed - setupSeconds_) : elapsed;
            const double whole = (sampled ? setupSeconds_ : 0.0) + workSeconds / fraction;
            estimate_ = whole;
            estimatedAfter_ = elapsed;
            const std::string on =
                sampled ? StringPrintf("%s %s (%.2g %%) in %.2g s, after %.2g s of set-up",
                                       FormatCount(static_cast<uint64_t>(measured)).c_str(), sampleWhat_.c_str(),
                                       100.0 * fraction, workSeconds, setupSeconds_)
                        : StringPrintf("the first %.2g %% in %.1f s", 100.0 * fraction, elapsed);
            if (refuseAfter_ >= 0 && whole > refuseAfter_) {
                // Said by the caller, once the work has stopped: one line, an error.
                stopReason_ = StringPrintf("about %s in all (measured on %s), more than the limit of %s%s",
                                           FormatDuration(whole).c_str(), on.c_str(),
                                           FormatDuration(refuseAfter_).c_str(), howToForce_.c_str());
                stopped_ = true;
            } else if (announceAfter_ >= 0 && whole > announceAfter_) {
                if (enabled_) {
                    std::fprintf(stderr, "\r%70s\r", "");  // the bar's line
                    SetInterruptLineOpen(false);
                }
                LogInfo(StringPrintf("%s: about %s in all, %s left (measured on %s%s%s)", title_.c_str(),
                                     FormatDuration(whole).c_str(), FormatDuration(std::max(0.0, whole - elapsed)).c_str(),
                                     on.c_str(), announceWhat_.empty() ? "" : "; ", announceWhat_.c_str()));
            }
        }
        if (!enabled_) return;
    }
    const auto now = std::chrono::steady_clock::now();
    if (now - lastDraw_ < std::chrono::milliseconds(100)) return;
    lastDraw_ = now;
    Draw(done, false);
}

void ProgressReporter::Stop(std::string reason) {
    std::lock_guard<std::mutex> lock(drawMutex_);
    if (stopped_) return;
    stopReason_ = std::move(reason);
    stopped_ = true;
}

void ProgressReporter::Done() {
    if (finished_.exchange(true) || !enabled_) return;
    std::lock_guard<std::mutex> lock(drawMutex_);
    if (stopped_) {  // no finished bar: the work was refused; the bar's line is cleared
        std::fprintf(stderr, "\r%70s\r", "");
        SetInterruptLineOpen(false);
        return;
    }
    Draw(total_, true);
}

void ProgressReporter::Draw(int64_t done, bool final) {
    const double fraction = std::min(1.0, static_cast<double>(done) / static_cast<double>(total_));
    const double elapsed = ElapsedSeconds();
    constexpr int kWidth = 30;
    char bar[kWidth + 1];
    const int filled = static_cast<int>(fraction * kWidth);
    for (int i = 0; i < kWidth; ++i) bar[i] = i < filled ? '=' : (i == filled ? '>' : ' ');
    bar[kWidth] = '\0';
    if (final) {
        std::fprintf(stderr, "\r%s [%s] 100%% %.1fs        \n", title_.c_str(), bar, elapsed);
        SetInterruptLineOpen(false);
    } else {
        SetInterruptLineOpen(true);
        // The time left from the work's own rate, set-up apart (it is behind us), and only
        // once enough is done for the rate to mean something.
        const double work = std::chrono::duration<double>(std::chrono::steady_clock::now() - workStart_).count();
        const double left = ProgressSecondsLeft(work, fraction);
        std::fprintf(stderr, "\r%s [%s] %3d%% %.1fs, %s   ", title_.c_str(), bar, static_cast<int>(fraction * 100),
                     elapsed, left < 0 ? "estimating the time left" : (FormatDuration(left) + " left").c_str());
    }
    std::fflush(stderr);
}

}  // namespace lm
