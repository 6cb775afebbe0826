// isolated_child.h -- work a library does on untrusted input (a model's importer, an image
// decoder), run in a child process so that its crash, assertion, allocation bomb or endless
// loop becomes an error message instead of the renderer's end: the child (fork) gets an
// address-space limit and a deadline, and sends its result back through a memfd, which the
// parent maps. ChildWriter and ChildReader serialise that result; ChildFieldWriter and
// ChildFieldReader let one function list a record's fields for both directions.
#pragma once

#include <cstdint>
#include <cstring>
#include <deque>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace lm {

/// A child's limits.
struct ChildLimits {
    /// Bytes the child may map beyond what this process maps when it starts (RLIMIT_AS; at
    /// least 64 MiB for the library's own working set; 0: no limit; none under the
    /// sanitizers, which reserve terabytes of shadow memory).
    uint64_t memory = 0;
    /// The deadline in seconds: the child is killed (SIGKILL) past it.
    double seconds = 60;
};

/// How a child ended, and the result it wrote (mapped read-only until this is destroyed).
class ChildOutcome {
  public:
    enum class End {
        NotStarted,  ///< no memfd or no fork: the caller does the work itself
        Exited,      ///< exit status in `code`
        Signalled,   ///< killed by signal `code` (a crash)
        TimedOut,    ///< killed at the deadline
    };
    ChildOutcome() = default;
    ChildOutcome(const ChildOutcome&) = delete;
    ChildOutcome& operator=(const ChildOutcome&) = delete;
    ChildOutcome(ChildOutcome&& o) noexcept { *this = std::move(o); }
    ChildOutcome& operator=(ChildOutcome&& o) noexcept;
    ~ChildOutcome();

    End end = End::NotStarted;
    int code = 0;
    double seconds = 0;  ///< the deadline it had
    /// What the child wrote to its memfd (empty if nothing).
    std::string_view Bytes() const { return {static_cast<const char*>(map_), size_}; }
    /// Whether it exited with status 0.
    bool Clean() const { return end == End::Exited && code == 0; }
    /// The last line the child wrote to its standard error, which is kept from the user's
    /// (a library's "terminate called after throwing ...", an assertion's text), printable
    /// and at most 160 characters; "" if none. Not kept under the sanitizers, whose reports
    /// must reach the test logs.
    const std::string& LastErrorLine() const { return lastErrorLine_; }
    /// " (it said: \"LINE\")", or "" without one: for the crash's one line.
    std::string Said() const;

  private:
    std::string lastErrorLine_;
    friend ChildOutcome RunInChild(const char*, const ChildLimits&, const std::function<void(int)>&);
    void* map_ = nullptr;
    size_t size_ = 0;
};

/// Runs work(fd) in a forked child, fd being a memfd for its result, then _exit(0) (no atexit
/// handlers or destructors of this process's objects; an exception escaping `work` exits 3).
/// The child dies with this process (PR_SET_PDEATHSIG) and takes SIGINT/SIGTERM/SIGHUP's
/// default action. One child runs at a time in this process (another thread must not be
/// inside a library's global state when a child copies the process). `name` names the memfd.
ChildOutcome RunInChild(const char* name, const ChildLimits& limits, const std::function<void(int fd)>& work);

/// The most ChildDeadlineSeconds gives without LIGHTMESH_IMPORT_TIMEOUT.
inline constexpr double kMaxDefaultChildSeconds = 600;
/// A child's deadline for reading `bytes` of input: LIGHTMESH_IMPORT_TIMEOUT (seconds, any
/// value up to 1e7) when set, else 60 s + 2 s per MB (importers and decoders read tens of
/// MB a second), at most kMaxDefaultChildSeconds (a 20 GB file of zeros had 11 hours).
double ChildDeadlineSeconds(uint64_t bytes);

/// "SIGSEGV", "SIGKILL", … for a signal number ("signal N" for others).
std::string SignalName(int sig);

/// A child's result as it is written: small fields are copied, large arrays written in
/// place (writev-like), so arrays are copied once on their way to the parent.
class ChildWriter {
  public:
    template <typename T>
    void Pod(const T& v) {
        Bytes(&v, sizeof(T), true);
    }
    void Str(const std::string& s) {
        Pod<uint64_t>(s.size());
        Bytes(s.data(), s.size(), true);
    }
    /// `v` must outlive WriteTo.
    template <typename T>
    void Vec(const std::vector<T>& v) {
        Pod<uint64_t>(v.size());
        Bytes(v.data(), v.size() * sizeof(T), false);
    }
    void Bools(const std::vector<bool>& v);
    /// `n` bytes at `data`, which must outlive WriteTo (written in place, no length).
    void Raw(const void* data, size_t n) { Bytes(data, n, false); }
    /// Writes everything at offset 0 of `fd` (truncating it); false on failure.
    bool WriteTo(int fd) const;
    /// Writes everything at the end of `fd` (a record after the ones before it); false on
    /// failure.
    bool AppendTo(int fd) const;

  private:
    struct Piece {
        const char* data;
        size_t size;
        bool copied;
        size_t index;
    };
    void Bytes(const void* data, size_t size, bool copy);
    bool Write(int fd) const;
    std::vector<Piece> pieces_;
    std::deque<std::string> copies_;
};

/// Reads what ChildWriter wrote; throws std::runtime_error("truncated result") past its end.
class ChildReader {
  public:
    explicit ChildReader(std::string_view bytes) : bytes_(bytes) {}
    template <typename T>
    T Pod() {
        T v{};
        Need(sizeof(T));
        std::memcpy(&v, bytes_.data() + at_, sizeof(T));
        at_ += sizeof(T);
        return v;
    }
    std::string Str() {
        const uint64_t n = Pod<uint64_t>();
        Need(n);
        std::string s(bytes_.substr(at_, n));
        at_ += n;
        return s;
    }
    template <typename T>
    std::vector<T> Vec() {
        const uint64_t n = Pod<uint64_t>();
        if (n > (bytes_.size() - at_) / sizeof(T)) Need(SIZE_MAX);
        std::vector<T> v(n);
        if (n) std::memcpy(v.data(), bytes_.data() + at_, n * sizeof(T));
        at_ += n * sizeof(T);
        return v;
    }
    std::vector<bool> Bools();
    /// The next `n` bytes, in place.
    std::string_view Raw(size_t n) {
        Need(n);
        const std::string_view v = bytes_.substr(at_, n);
        at_ += n;
        return v;
    }
    bool AtEnd() const { return at_ == bytes_.size(); }
    size_t Offset() const { return at_; }

  private:
    void Need(uint64_t n) const {
        if (n > bytes_.size() - at_) throw std::runtime_error("truncated result");
    }
    std::string_view bytes_;
    size_t at_ = 0;
};

/// A record's layout, listed once for both directions: a function
///     template <typename Archive, typename R> void Fields(Archive& a, R& record)
/// that calls a(field, ...) for the fields in their order, a.List(vector, visit) for a
/// vector of records (visit(element) lists one element's fields) and a.Array(array, n) for
/// n values without a length (their count known from the fields before). ChildFieldWriter
/// writes the fields (R const), ChildFieldReader reads them back. A std::string, a vector
/// of trivially copyable values, of bool or of strings goes with its length; a bool as one
/// byte; any other trivially copyable value as its bytes.
class ChildFieldWriter {
  public:
    explicit ChildFieldWriter(ChildWriter* w) : w_(*w) {}
    template <typename... T>
    void operator()(const T&... fields) {
        (Put(fields), ...);
    }
    template <typename T, typename Visit>
    void List(const std::vector<T>& records, Visit visit) {
        w_.Pod<uint64_t>(records.size());
        for (const T& r : records) visit(r);
    }
    /// `n` must be the array's size; written in place, so it must outlive WriteTo.
    template <typename Values>
    void Array(const Values& a, size_t n) {
        w_.Raw(a.data(), n * sizeof(a[0]));
    }
    /// A check of the fields so far, made when they are read back (a writer's are right).
    void Require(bool, const char*) {}

  private:
    void Put(const std::string& s) { w_.Str(s); }
    void Put(const std::vector<bool>& v) { w_.Bools(v); }
    void Put(const std::vector<std::string>& v) {
        w_.Pod<uint64_t>(v.size());
        for (const std::string& s : v) w_.Str(s);
    }
    template <typename T>
    void Put(const std::vector<T>& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        w_.Vec(v);  // in place: `v` must outlive WriteTo
    }
    void Put(bool b) { w_.Pod<uint8_t>(b ? 1 : 0); }
    template <typename T>
    void Put(const T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        w_.Pod(v);
    }
    ChildWriter& w_;
};

/// Reads back what ChildFieldWriter wrote, field by field (see there); throws
/// std::runtime_error on a record cut short or a failed Require.
class ChildFieldReader {
  public:
    explicit ChildFieldReader(ChildReader* r) : r_(*r) {}
    template <typename... T>
    void operator()(T&... fields) {
        (Get(fields), ...);
    }
    template <typename T, typename Visit>
    void List(std::vector<T>& records, Visit visit) {
        const uint64_t n = r_.Pod<uint64_t>();
        for (uint64_t i = 0; i < n; ++i) {
            T r;
            visit(r);
            records.push_back(std::move(r));
        }
    }
    template <typename Values>
    void Array(Values& a, size_t n) {
        const std::string_view bytes = r_.Raw(n * sizeof(a[0]));
        a.resize(n);
        if (n) std::memcpy(a.data(), bytes.data(), bytes.size());
    }
    void Require(bool ok, const char* what) {
        if (!ok) throw std::runtime_error(what);
    }

  private:
    void Get(std::string& s) { s = r_.Str(); }
    void Get(std::vector<bool>& v) { v = r_.Bools(); }
    void Get(std::vector<std::string>& v) {
        const uint64_t n = r_.Pod<uint64_t>();
        for (uint64_t i = 0; i < n; ++i) v.push_back(r_.Str());
    }
    template <typename T>
    void Get(std::vector<T>& v) {
        v = r_.Vec<T>();
    }
    void Get(bool& b) { b = r_.Pod<uint8_t>() != 0; }
    template <typename T>
    void Get(T& v) {
        static_assert(std::is_trivially_copyable_v<T>);
        v = r_.Pod<T>();
    }
    ChildReader& r_;
};

}  // namespace lm
