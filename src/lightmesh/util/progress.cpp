#include "lightmesh/util/progress.h"

#include <unistd.h>

#include <cstdio>

#include "lightmesh/util/error.h"
#include "lightmesh/util/log.h"
#include "lightmesh/util/system.h"

namespace lm {

ProgressReporter::ProgressReporter(int64_t total, std::string title, bool enabled)
    : total_(total > 0 ? total : 1), title_(std::move(title)), enabled_(enabled),
      start_(std::chrono::steady_clock::now()), lastDraw_(start_) {}

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
    if (!enabled_ && (announceAfter_ < 0 || announced_.load(std::memory_order_relaxed))) return;
    std::unique_lock<std::mutex> lock(drawMutex_, std::try_to_lock);
    if (!lock.owns_lock()) return;  // another thread is drawing; skip this update
    if (announceAfter_ >= 0 && !announced_.load(std::memory_order_relaxed)) {
        const double elapsed = ElapsedSeconds();
        if (elapsed >= kMeasureSeconds || done >= total_) {
            announced_ = true;
            const double fraction = std::min(1.0, static_cast<double>(done) / static_cast<double>(total_));
            const double whole = elapsed / fraction;
            if (whole > announceAfter_) {
                if (enabled_) {
                    std::fprintf(stderr, "\r%70s\r", "");  // the bar's line
                    SetInterruptLineOpen(false);
                }
                LogInfo(StringPrintf("%s: about %s in all, %s left (measured on the first %.2g %% in %.1f s%s%s)",
                                     title_.c_str(), FormatDuration(whole).c_str(),
                                     FormatDuration(whole - elapsed).c_str(), 100.0 * fraction, elapsed,
                                     announceWhat_.empty() ? "" : "; ", announceWhat_.c_str()));
            }
        }
        if (!enabled_) return;
    }
    const auto now = std::chrono::steady_clock::now();
    if (now - lastDraw_ < std::chrono::milliseconds(100)) return;
    lastDraw_ = now;
    Draw(done, false);
}

void ProgressReporter::Done() {
    if (finished_.exchange(true) || !enabled_) return;
    std::lock_guard<std::mutex> lock(drawMutex_);
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
        const double left = fraction > 0 ? elapsed * (1.0 - fraction) / fraction : 0.0;
        std::fprintf(stderr, "\r%s [%s] %3d%% %.1fs, %s left   ", title_.c_str(), bar,
                     static_cast<int>(fraction * 100), elapsed, FormatDuration(left).c_str());
    }
    std::fflush(stderr);
}

}  // namespace lm
