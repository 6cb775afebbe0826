// json_reader.h -- reading JSON files with messages that name the file and the JSON
// pointer of the value at fault (or its line and column for a syntax error), unknown keys
// reported pbrt-style (ReportUnused) with "did you mean", duplicate keys found while
// parsing. Scene files and bench matrices are read with it.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <set>
#include <string>
#include <string_view>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "lightmesh/settings/render_settings.h"
#include "lightmesh/util/error.h"
#include "lightmesh/util/log.h"

namespace lm {

// A std::map-backed json: key lookup is O(log n) (ordered_json looks keys up linearly, so a
// 300,000-key object took a minute to parse). The file's key order, which messages and the
// "materials" list follow, is recorded by the parser callback (KeyOrder).
using Json = nlohmann::json;

/// The keys of every object of the file in file order, by a hash of the object's JSON
/// pointer (json::PointerHash): a key per object, not the pointer's whole text, so a file
/// of long keys or deep paths costs memory in proportion to its size.
using KeyOrder = std::unordered_map<uint64_t, std::vector<std::string>>;

namespace json {

/// The deepest nesting of arrays and objects a JSON file (a scene, a bench matrix) may
/// have: deeper is refused with the file and the pointer where it happens. A scene file
/// nests five levels at most; the limit keeps a hostile file's bookkeeping small.
inline constexpr size_t kMaxJsonDepth = 256;

/// 64-bit FNV-1a of a JSON pointer ("/lights/0"), the key of KeyOrder.
uint64_t PointerHash(std::string_view pointer);

std::string Lower(std::string s);
/// A key as a JSON-pointer token (RFC 6901: "~" → "~0", "/" → "~1").
std::string PointerToken(std::string_view key);
std::string Quoted(std::string_view s);
/// "a string ("abc")", "an array of 2", ... for "expected X, got Y" messages.
std::string Describe(const Json& j);
std::string JoinQuoted(const std::vector<std::string>& items);
size_t EditDistance(std::string_view a, std::string_view b);
/// The candidate nearest to `word` within edit distance 2 (and less than its length), or
/// "": the "did you mean" of the CLI's options and the Python module's keywords.
std::string Nearest(const std::string& word, const std::vector<std::string>& candidates);

class Reader {
  public:
    /// strict: unknown and duplicate keys are errors (else warnings); warnings go to
    /// *warnings, or to the log if it is null.
    Reader(std::string file, bool strict, std::vector<std::string>* warnings)
        : file_(std::move(file)), strict_(strict), warnings_(warnings) {}

    const std::string& File() const { return file_; }
    void SetKeyOrder(KeyOrder order) { order_ = std::move(order); }
    /// The keys of object `j` at `path` in the file's order (sorted if unknown), each once.
    std::vector<std::string> KeysInOrder(const std::string& path, const Json& j) const {
        std::vector<std::string> keys;
        if (auto it = order_.find(PointerHash(path)); it != order_.end()) {
            std::unordered_set<std::string> seen;
            for (const std::string& k : it->second)
                if (j.contains(k) && seen.insert(k).second) keys.push_back(k);
            if (keys.size() == j.size()) return keys;
            keys.clear();
        }
        for (const auto& item : j.items()) keys.push_back(item.key());
        return keys;
    }
    /// "scene.json /lights/0/position" (or just the file for the root).
    std::string Where(const std::string& path) const { return SourceLoc{file_, 0, 0, path}.Format(); }

    [[noreturn]] void Fail(const std::string& path, const std::string& message) const {
        throw Error(SourceLoc{file_, 0, 0, path}, message);
    }
    void Warn(const std::string& message) const {
        if (warnings_)
            warnings_->push_back(message);
        else
            LogWarning(message);
    }
    /// A problem that is a warning normally and an error in strict mode.
    void Lenient(const std::string& path, const std::string& asError,
                 const std::string& asWarning) const {
        if (strict_) Fail(path, asError);
        Warn(Where(path) + ": " + asWarning);
    }

  private:
    std::string file_;
    bool strict_;
    std::vector<std::string>* warnings_;
    KeyOrder order_;
};

/// A JSON object being read: remembers which keys were asked for, so the ones never asked
/// for can be reported as unknown (pbrt's ReportUnused).
class Object {
  public:
    Object(const Reader& r, const Json& j, std::string path)
        : r_(r), j_(j), path_(std::move(path)) {
        if (!j.is_object()) r.Fail(path_, "expected an object {...}, got " + Describe(j));
    }

    const std::string& Path() const { return path_; }
    std::string Child(std::string_view key) const { return path_ + "/" + PointerToken(key); }

    /// The value of `key`, or null if absent. Marks the key as known.
    const Json* Find(const std::string& key) {
        asked_.insert(key);
        auto it = j_.find(key);
        return it == j_.end() ? nullptr : &*it;
    }
    const Json& Require(const std::string& key, const char* why = nullptr) {
        if (const Json* v = Find(key)) return *v;
        // A near-miss in the object ("lookat" for look_at) is the likely cause: name it.
        std::string hint;
        size_t best = 3;
        for (const auto& item : j_.items()) {
            const size_t d = EditDistance(Lower(item.key()), Lower(key));
            if (d < best && d < std::max<size_t>(key.size(), 2)) {
                best = d;
                hint = "; " + Quoted(item.key()) + " is not a key: did you mean " + Quoted(key) + "?";
            }
        }
        r_.Fail(Child(key),
                (why ? StringPrintf("missing required key (%s)", why) : std::string("missing required key")) + hint);
    }

    /// Reports every key that was never asked for (the first ten one by one).
    void Finish() const {
        constexpr size_t kMaxReported = 10;
        size_t unknown = 0;
        std::string first;
        for (const std::string& key : r_.KeysInOrder(path_, j_)) {
            if (asked_.count(key)) continue;
            if (++unknown > kMaxReported) continue;
            if (unknown == 1) first = key;
            std::string hint;
            size_t best = 3;
            for (const auto& known : asked_) {
                const size_t d = EditDistance(Lower(key), Lower(known));
                if (d < best && d < std::max<size_t>(known.size(), 2)) {
                    best = d;
                    hint = "; did you mean " + Quoted(known) + "?";
                }
            }
            r_.Lenient(Child(key), "unknown key" + hint, "unknown key (ignored" + hint + ")");
        }
        if (unknown > kMaxReported)
            r_.Warn(r_.Where(path_) +
                    StringPrintf(": ... and %zu more unknown keys (ignored)", unknown - kMaxReported));
    }

  private:
    const Reader& r_;
    const Json& j_;
    std::string path_;
    std::set<std::string> asked_;
};

std::string Index(const std::string& path, size_t i);
/// A number as messages show it: as given, not as stored ("got 16.000001", not "got 16"
/// for a float that rounds to 16.000002): the shortest digits that read back as the
/// value, without an exponent from 1e-5 to 1e16.
std::string NumberText(double v);
std::string NumberText(const Json& j);
double Number(const Reader& r, const Json& j, const std::string& path);
float Float(const Reader& r, const Json& j, const std::string& path);
float NonNegative(const Reader& r, const Json& j, const std::string& path);
int Int(const Reader& r, const Json& j, const std::string& path, int lo, int hi);
std::string String(const Reader& r, const Json& j, const std::string& path);
std::string Enum(const Reader& r, const Json& j, const std::string& path,
                 const std::vector<std::string>& choices);
/// A string or a list of strings.
std::vector<std::string> StringList(const Reader& r, const Json& j, const std::string& path);

/// Line and column (1-based) of byte offset `pos` of `text`.
std::pair<size_t, size_t> LineColumn(const std::string& text, size_t pos);
Json ParseJson(Reader& r, const std::string& text);

/// A value for a row of the settings table, checked against its range (Int, Float) or its
/// choices: the scene file's "render" object and bench matrices read their knobs so.
int SettingInt(const Reader& r, const Json& j, const std::string& path, const RenderSetting& s);
float SettingFloat(const Reader& r, const Json& j, const std::string& path, const RenderSetting& s);
std::string SettingChoice(const Reader& r, const Json& j, const std::string& path, const RenderSetting& s);

}  // namespace json
}  // namespace lm
