// progress.h -- a progress bar with the time remaining, on stderr when it is a terminal.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace lm {

/// Reports progress of `total` units of work (pbrt's ProgressReporter). Update() is
/// thread-safe and cheap; the bar, with the time left, is redrawn at most ten times a
/// second. The bar is not drawn when disabled (--quiet, or stderr is not a terminal).
class ProgressReporter {
  public:
    ProgressReporter(int64_t total, std::string title, bool enabled);
    ~ProgressReporter();
    /// Once the work has run kMeasureSeconds, if the whole is then estimated (from the share
    /// done) to take more than `thresholdSeconds`, one line says so, bar or no bar: "<title>:
    /// about 3 h 12 min in all, 3 h 11 min left (measured on the first 1.1 % in 2.0 s;
    /// <what>)". Call before the first Update.
    void AnnounceIfLong(double thresholdSeconds, std::string what);
    static constexpr double kMeasureSeconds = 2.0;
    void Update(int64_t units = 1);
    /// Draws the finished bar and ends the line (called by the destructor if need be).
    void Done();
    double ElapsedSeconds() const;

    /// True when stderr is a terminal.
    static bool StderrIsTerminal();

  private:
    void Draw(int64_t done, bool final);
    const int64_t total_;
    const std::string title_;
    const bool enabled_;
    double announceAfter_ = -1;  ///< seconds; < 0: no announcement
    std::string announceWhat_;
    std::atomic<bool> announced_{false};
    std::atomic<int64_t> done_{0};
    std::atomic<bool> finished_{false};
    std::mutex drawMutex_;
    std::chrono::steady_clock::time_point start_, lastDraw_;
};

}  // namespace lm
