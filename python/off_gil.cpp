// off_gil.cpp -- see off_gil.h.
#include "off_gil.h"

#include <tbb/global_control.h>

#include <chrono>
#include <condition_variable>
#include <exception>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

namespace py = pybind11;

namespace lm::python {

void RunOffPythonThread(int threads, const std::function<void()>& work,
                        const std::function<void(const char* reason)>& stop, const std::function<void()>& tick) {
    std::mutex mutex;
    std::condition_variable finished;
    bool done = false;
    std::exception_ptr failure;
    std::optional<py::error_already_set> pythonError;  // created and destroyed with the GIL
    {
        py::gil_scoped_release release;
        std::thread worker([&] {
            try {
                std::unique_ptr<tbb::global_control> limit;
                if (threads > 0)
                    limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                                  static_cast<size_t>(threads));
                work();
            } catch (...) {
                failure = std::current_exception();
            }
            std::lock_guard<std::mutex> lock(mutex);
            done = true;
            finished.notify_all();
        });
        for (;;) {
            {
                std::unique_lock<std::mutex> lock(mutex);
                if (finished.wait_for(lock, std::chrono::milliseconds(50), [&] { return done; })) break;
            }
            if (pythonError) continue;
            py::gil_scoped_acquire acquire;
            if (PyErr_CheckSignals() != 0) {
                pythonError.emplace();  // fetches the KeyboardInterrupt
                stop("interrupted");
                continue;
            }
            try {
                tick();
            } catch (py::error_already_set& e) {
                pythonError.emplace(std::move(e));
                stop("the progress callback raised");
            }
        }
        worker.join();
    }
    if (pythonError) throw std::move(*pythonError);
    if (failure) std::rethrow_exception(failure);
}

}  // namespace lm::python
