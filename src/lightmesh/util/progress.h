// progress.h -- a progress bar with the time remaining, on stderr when it is a terminal.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

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
    /// The work proper starts now, after its set-up (timed apart, and added whole to the
    /// estimate), and its first `sampleUnits` units are a sample spread over all of it
    /// (`sampleWhat`: "tiles spread over the image"), so the estimate is made when the
    /// sample is done (or after kMeasureSeconds, from the part of it done), from the sample
    /// alone, rather than from whatever came first (a frame whose first tiles are sky would
    /// announce nothing; one tile after a 3 GiB image's set-up, extrapolated a million
    /// times, would give 72 days for 6 minutes). Without it the estimate is the share done
    /// after kMeasureSeconds, set-up included.
    void BeginWork(int64_t sampleUnits, std::string sampleWhat);
    /// When the estimate passes `limitSeconds`, the work is to stop (Stopped()), and
    /// StopReason() says why: "about 3 h 12 min in all (measured on ...), more than the limit
    /// of 1 h 0 min<more>". Call before the first Update.
    void RefuseIfLonger(double limitSeconds, std::string more);
    /// Whether the work should stop (RefuseIfLonger's limit passed); cheap, thread-safe.
    bool Stopped() const { return stopped_.load(std::memory_order_relaxed); }
    const std::string& StopReason() const { return stopReason_; }
    /// Asks the work to stop (Stopped()) for `reason`, from any thread, unless it was
    /// stopped already: the Python module's KeyboardInterrupt. The renderers that check
    /// Stopped() leave their remaining tiles undone.
    void Stop(std::string reason);
    /// The units reported done so far (Update's sum), from any thread.
    int64_t UnitsDone() const { return done_.load(std::memory_order_relaxed); }
    int64_t Total() const { return total_; }
    /// The whole work's estimated seconds (set-up included), once made; -1 before.
    double EstimatedSeconds() const { return estimate_.load(); }
    /// Seconds after the start at which the estimate was made; -1 before.
    double EstimatedAfterSeconds() const { return estimatedAfter_.load(); }
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
    double refuseAfter_ = -1;    ///< seconds; < 0: no limit
    std::string howToForce_, stopReason_;
    std::atomic<bool> stopped_{false};
    std::string announceWhat_;
    int64_t sample_ = 0;  ///< BeginWork's sample (0: none)
    std::string sampleWhat_;
    double setupSeconds_ = 0;
    std::atomic<double> sampleSeconds_{-1};  ///< the work's seconds when the sample was done
    std::atomic<double> estimate_{-1}, estimatedAfter_{-1};
    std::atomic<bool> announced_{false};
    std::atomic<int64_t> done_{0};
    std::atomic<bool> finished_{false};
    std::mutex drawMutex_;
    std::chrono::steady_clock::time_point start_, lastDraw_, workStart_;
};

/// The bar's "time left" is shown once the work (set-up apart) has run this long and done
/// this share: the first tiles of a frame (sky, or a sample spread over it) are not its
/// average, and an estimate from a tenth of a second promised 0.5 s for a 5 s render.
inline constexpr double kProgressEstimateSeconds = 1.0, kProgressEstimateShare = 0.05;
/// The seconds left of a work that has run `workSeconds` (set-up apart) and done `fraction`
/// of itself, at its measured rate; -1 (not shown: "estimating") before
/// kProgressEstimateSeconds and kProgressEstimateShare; 0 when done.
double ProgressSecondsLeft(double workSeconds, double fraction);

/// `n` cells of a cols × rows grid (index row·cols + col) spread over it in both directions:
/// the centre cell of each of about n strata of the grid's shape, ordered so that every
/// prefix is spread too (the strata in bit-reversed order). All cells if n ≥ cols × rows.
/// The samples a long job's estimate is made from (WhittedRenderer's tiles).
std::vector<int64_t> SpreadOverGrid(int64_t cols, int64_t rows, int64_t n);

}  // namespace lm
