// isolated_child_test.cpp -- RunInChild: the result comes back; a crash, an endless loop and
// an allocation past the limit end the child, not this process, and say how; a record whose
// fields one function lists (ChildFieldWriter, ChildFieldReader) comes back as written.
#include "lightmesh/util/isolated_child.h"

#include <gtest/gtest.h>

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <string>
#include <unistd.h>
#include <vector>

namespace lm {
namespace isolated_child_test {
namespace {

TEST(IsolatedChild, ItsResultComesBackThroughTheMemfd) {
    const std::vector<float> big(100000, 2.5f);
    const ChildOutcome child = RunInChild("test", ChildLimits{}, [&](int fd) {
        ChildWriter w;
        w.Pod<int32_t>(7);
        w.Str("seven");
        w.Vec(big);
        w.Bools({true, false, true});
        if (!w.WriteTo(fd)) _exit(4);
        ChildWriter more;
        more.Pod<int32_t>(8);
        if (!more.AppendTo(fd)) _exit(4);
    });
    ASSERT_TRUE(child.Clean());
    ChildReader r(child.Bytes());
    EXPECT_EQ(r.Pod<int32_t>(), 7);
    EXPECT_EQ(r.Str(), "seven");
    EXPECT_EQ(r.Vec<float>(), big);
    EXPECT_EQ(r.Bools(), (std::vector<bool>{true, false, true}));
    EXPECT_EQ(r.Pod<int32_t>(), 8);
    EXPECT_TRUE(r.AtEnd());
    EXPECT_THROW(r.Pod<int32_t>(), std::runtime_error);  // past the end: "truncated result"
}

enum class Shape : uint8_t { Round, Square };
struct Part {
    std::string name;
    Shape shape = Shape::Round;
    bool hidden = false;
};
struct Record {
    int32_t count = 0;
    std::vector<float> values;
    std::vector<bool> flags;
    std::vector<std::string> notes;
    std::vector<Part> parts;
    std::vector<double> raw;  // count values, without a length
};

// The record's fields, once for both directions.
template <typename Archive, typename P>
void PartFields(Archive& a, P& p) {
    a(p.name, p.shape, p.hidden);
}
template <typename Archive, typename R>
void RecordFields(Archive& a, R& r) {
    a(r.count, r.values, r.flags, r.notes);
    a.List(r.parts, [&](auto& p) { PartFields(a, p); });
    a.Require(r.count >= 0, "negative count");
    a.Array(r.raw, static_cast<size_t>(r.count));
}

TEST(IsolatedChild, ARecordsFieldsListedOnceComeBackAsWritten) {
    Record sent;
    sent.count = 3;
    sent.values = {1.5f, -2};
    sent.flags = {false, true};
    sent.notes = {"one", "", "three"};
    sent.parts = {{"lid", Shape::Square, true}, {"", Shape::Round, false}};
    sent.raw = {0.25, 1e300, -0.0};
    const ChildOutcome child = RunInChild("test", ChildLimits{}, [&](int fd) {
        ChildWriter w;
        ChildFieldWriter out(&w);
        RecordFields(out, sent);
        if (!w.WriteTo(fd)) _exit(4);
    });
    ASSERT_TRUE(child.Clean());
    ChildReader r(child.Bytes());
    ChildFieldReader in(&r);
    Record got;
    RecordFields(in, got);
    EXPECT_TRUE(r.AtEnd());
    EXPECT_EQ(got.count, 3);
    EXPECT_EQ(got.values, sent.values);
    EXPECT_EQ(got.flags, sent.flags);
    EXPECT_EQ(got.notes, sent.notes);
    ASSERT_EQ(got.parts.size(), 2u);
    EXPECT_EQ(got.parts[0].name, "lid");
    EXPECT_EQ(got.parts[0].shape, Shape::Square);
    EXPECT_TRUE(got.parts[0].hidden);
    EXPECT_FALSE(got.parts[1].hidden);
    EXPECT_EQ(got.raw, sent.raw);
    // Cut short anywhere, the record is refused rather than read past its end.
    const std::string_view bytes = child.Bytes();
    for (size_t n = 0; n < bytes.size(); n += 7) {
        ChildReader cut(bytes.substr(0, n));
        ChildFieldReader cutIn(&cut);
        Record partial;
        EXPECT_THROW(RecordFields(cutIn, partial), std::runtime_error) << n << " bytes";
    }
}

TEST(IsolatedChild, ACrashIsASignalNotTheEndOfThisProcess) {
    const ChildOutcome child = RunInChild("test", ChildLimits{}, [](int) { std::abort(); });
    ASSERT_EQ(child.end, ChildOutcome::End::Signalled);
    EXPECT_EQ(child.code, SIGABRT);
    EXPECT_EQ(SignalName(child.code), "SIGABRT");
    EXPECT_TRUE(child.Bytes().empty());
}

TEST(IsolatedChild, AnEndlessLoopIsStoppedAtTheDeadline) {
    ChildLimits limits;
    limits.seconds = 0.3;
    const ChildOutcome child = RunInChild("test", limits, [](int) {
        volatile int spin = 0;
        for (;;) spin = spin + 1;
    });
    EXPECT_EQ(child.end, ChildOutcome::End::TimedOut);
    EXPECT_FALSE(child.Clean());
}

TEST(IsolatedChild, AnExceptionOutOfTheWorkIsExitStatusThree) {
    const ChildOutcome child = RunInChild("test", ChildLimits{}, [](int) { throw std::runtime_error("no"); });
    EXPECT_EQ(child.end, ChildOutcome::End::Exited);
    EXPECT_EQ(child.code, 3);
}

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define LIGHTMESH_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define LIGHTMESH_SANITIZED 1
#endif
#endif

#ifndef LIGHTMESH_SANITIZED  // (their reports must reach the logs: the child's stderr is kept)
// A library's last words before its abort ("terminate called after throwing ...", an
// assertion) would be a second line on the user's standard error, before lightmesh's one
// line; they are kept from it, and the crash's line quotes the last of them.
TEST(IsolatedChild, ItsStandardErrorIsKeptAndItsLastLineQuoted) {
    ::testing::internal::CaptureStderr();
    const ChildOutcome child = RunInChild("test", ChildLimits{}, [](int) {
        std::fprintf(stderr, "some noise\nterminate called after throwing an instance of 'std::out_of_range'\n");
        std::fflush(stderr);
        std::abort();
    });
    const std::string ours = ::testing::internal::GetCapturedStderr();
    ASSERT_EQ(child.end, ChildOutcome::End::Signalled);
    EXPECT_EQ(ours, "");
    EXPECT_EQ(child.LastErrorLine(), "terminate called after throwing an instance of 'std::out_of_range'");
    EXPECT_EQ(child.Said(), " (it said: \"terminate called after throwing an instance of 'std::out_of_range'\")");
    const ChildOutcome quiet = RunInChild("test", ChildLimits{}, [](int) { std::abort(); });
    EXPECT_EQ(quiet.Said(), "");
}
#endif

#ifndef LIGHTMESH_SANITIZED  // the sanitizers' shadow memory takes no address-space limit
TEST(IsolatedChild, AnAllocationPastTheLimitFailsInTheChild) {
    ChildLimits limits;
    limits.memory = uint64_t(64) << 20;
    const ChildOutcome child = RunInChild("test", limits, [](int fd) {
        ChildWriter w;
        try {
            std::vector<char> bomb(size_t(4) << 30, 1);
            w.Pod<uint8_t>(bomb[12345]);
        } catch (const std::bad_alloc&) {
            w.Pod<uint8_t>(42);
        }
        w.WriteTo(fd);
    });
    ASSERT_TRUE(child.Clean());
    ChildReader r(child.Bytes());
    EXPECT_EQ(r.Pod<uint8_t>(), 42);
}
#endif

}  // namespace
}  // namespace isolated_child_test
}  // namespace lm
