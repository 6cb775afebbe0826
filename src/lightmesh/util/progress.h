// progress.h -- a progress bar with the time remaining, on stderr when it is a terminal.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>

namespace lm {

/// Reports progress of `total` units of work (pbrt's ProgressReporter). Update() is
/// thread-safe and cheap; the bar is redrawn at most ten times a second. Nothing is
/// printed when disabled (--quiet, or stderr is not a terminal).
class ProgressReporter {
  public:
    ProgressReporter(int64_t total, std::string title, bool enabled);
    ~ProgressReporter();
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
    std::atomic<int64_t> done_{0};
    std::atomic<bool> finished_{false};
    std::mutex drawMutex_;
    std::chrono::steady_clock::time_point start_, lastDraw_;
};

}  // namespace lm
