// off_gil.h -- long work run off the Python thread: the GIL released while it runs, signals
// (Ctrl-C) and a progress callback served from the Python thread meanwhile.
#pragma once

#include <pybind11/pybind11.h>

#include <functional>

namespace lm::python {

/// Runs `work` on a worker thread, with the GIL released and at most `threads` TBB threads
/// (0: all). Every 50 ms the calling thread takes the GIL: a pending signal (the
/// KeyboardInterrupt) calls `stop(reason)`, and so does an exception from `tick()` (the
/// progress callback, called otherwise); the work is expected to end soon after. Once it
/// has ended, the Python error is raised, else the work's own exception is rethrown.
void RunOffPythonThread(int threads, const std::function<void()>& work,
                        const std::function<void(const char* reason)>& stop, const std::function<void()>& tick);

}  // namespace lm::python
