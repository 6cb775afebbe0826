#include "lightmesh/scene/json_reader.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <tuple>
#include <unordered_set>

namespace lm::json {

std::string Lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
    return s;
}

/// A key as a JSON-pointer token (RFC 6901: "~" → "~0", "/" → "~1").
std::string PointerToken(std::string_view key) {
    std::string out;
    for (char c : key) {
        if (c == '~')
            out += "~0";
        else if (c == '/')
            out += "~1";
        else
            out += c;
    }
    return out;
}

std::string Quoted(std::string_view s) {
    return "\"" + std::string(s) + "\"";
}

/// "a string ("abc")", "an array of 2", ... for "expected X, got Y" messages.
std::string Describe(const Json& j) {
    switch (j.type()) {
        case Json::value_t::null: return "null";
        case Json::value_t::boolean: return j.get<bool>() ? "true" : "false";
        case Json::value_t::string: {
            std::string s = j.get<std::string>();
            if (s.size() > 24) s = s.substr(0, 21) + "...";
            return "a string (" + Quoted(s) + ")";
        }
        case Json::value_t::array: return StringPrintf("an array of %zu", j.size());
        case Json::value_t::object: return "an object";
        case Json::value_t::number_integer:
        case Json::value_t::number_unsigned:
        case Json::value_t::number_float: return "the number " + NumberText(j);
        default: return "an unsupported value";
    }
}

std::string JoinQuoted(const std::vector<std::string>& items) {
    std::string out;
    for (const auto& s : items) out += (out.empty() ? "" : ", ") + Quoted(s);
    return out;
}

size_t EditDistance(std::string_view a, std::string_view b) {
    std::vector<size_t> row(b.size() + 1);
    for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (size_t i = 1; i <= a.size(); ++i) {
        size_t diag = row[0];
        row[0] = i;
        for (size_t j = 1; j <= b.size(); ++j) {
            const size_t up = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] != b[j - 1])});
            diag = up;
        }
    }
    return row[b.size()];
}

std::string Nearest(const std::string& word, const std::vector<std::string>& candidates) {
    std::string best;
    size_t bestDistance = 3;
    for (const std::string& c : candidates) {
        const size_t d = EditDistance(word, c);
        if (d < bestDistance && d < std::max<size_t>(word.size(), 2)) {
            bestDistance = d;
            best = c;
        }
    }
    return best;
}

std::string NumberText(double v) {
    // The shortest digits that read back as v (std::to_chars), so 16.000001 is not "16";
    // integers and everyday magnitudes without an exponent, as a person writes them.
    char buf[400];
    const double a = std::abs(v);
    const bool fixed = std::isfinite(v) && (a == 0 || (a >= 1e-5 && a < 1e16));
    const auto r = fixed ? std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed)
                         : std::to_chars(buf, buf + sizeof buf, v);
    if (r.ec != std::errc()) return StringPrintf("%.17g", v);
    return std::string(buf, r.ptr);
}

std::string NumberText(const Json& j) {
    if (j.is_number_unsigned()) return std::to_string(j.get<uint64_t>());
    if (j.is_number_integer()) return std::to_string(j.get<int64_t>());
    return NumberText(j.get<double>());
}

std::string Index(const std::string& path, size_t i) {
    return path + "/" + std::to_string(i);
}

double Number(const Reader& r, const Json& j, const std::string& path) {
    if (!j.is_number()) r.Fail(path, "expected a number, got " + Describe(j));
    return j.get<double>();
}

float Float(const Reader& r, const Json& j, const std::string& path) {
    const double v = Number(r, j, path);
    const float f = static_cast<float>(v);
    if (!std::isfinite(f)) r.Fail(path, "number out of range, got " + NumberText(j));
    return f;
}

float NonNegative(const Reader& r, const Json& j, const std::string& path) {
    const float v = Float(r, j, path);
    if (v < 0) r.Fail(path, "must not be negative, got " + NumberText(j));
    return v;
}

int Int(const Reader& r, const Json& j, const std::string& path, int lo, int hi) {
    if (!j.is_number()) r.Fail(path, "expected an integer, got " + Describe(j));
    const double v = j.get<double>();
    if (v != std::floor(v)) r.Fail(path, "expected an integer, got " + NumberText(j));
    if (v < lo || v > hi) r.Fail(path, StringPrintf("must be between %d and %d, got ", lo, hi) + NumberText(j));
    return static_cast<int>(v);
}

std::string String(const Reader& r, const Json& j, const std::string& path) {
    if (!j.is_string()) r.Fail(path, "expected a string, got " + Describe(j));
    return j.get<std::string>();
}

std::string Enum(const Reader& r, const Json& j, const std::string& path,
                 const std::vector<std::string>& choices) {
    const std::string s = String(r, j, path);
    if (std::find(choices.begin(), choices.end(), s) == choices.end())
        r.Fail(path, "must be one of " + JoinQuoted(choices) + "; got " + Quoted(s));
    return s;
}

/// A string or a list of strings.
std::vector<std::string> StringList(const Reader& r, const Json& j, const std::string& path) {
    if (j.is_string()) return {j.get<std::string>()};
    if (!j.is_array()) r.Fail(path, "expected a list of strings, got " + Describe(j));
    std::vector<std::string> out;
    for (size_t i = 0; i < j.size(); ++i) out.push_back(String(r, j[i], Index(path, i)));
    return out;
}

// ---------------------------------------------------------------------------------------
// Parsing, with JSON paths for errors inside the parser and duplicate-key detection

uint64_t PointerHash(std::string_view pointer) {
    uint64_t h = 0xcbf29ce484222325ull;
    for (unsigned char c : pointer) h = (h ^ c) * 0x100000001b3ull;
    return h;
}

/// Follows the parser's position as a JSON pointer (nlohmann's SAX events report
/// structure, not locations), records each object's keys in file order and collects
/// duplicate keys on the way -- in time and memory linear in the file: the pointer of the
/// value being parsed is one string, extended by a token when a key or an array element
/// starts and cut back when its value ends (its FNV-1a hash likewise), so no event copies
/// a whole pointer (building each object's pointer from scratch and keeping it takes 9.6 s
/// and 1.75 GB for 40,000 nested objects). Nesting deeper than kMaxJsonDepth is
/// refused.
class PathTracker {
  public:
    explicit PathTracker(const Reader& r) : r_(r) {}

    void StartContainer(bool array) {
        if (frames_.size() >= kMaxJsonDepth)
            throw Error(SourceLoc(r_.File()), StringPrintf("nesting deeper than %zu levels at ", kMaxJsonDepth) +
                                                  Abbreviated(Path()) + " (the most a JSON file may nest)");
        const uint64_t hash = EnterValue();
        frames_.emplace_back(array, path_.size(), hash);
        if (!array) frames_.back().order = &order_[hash];
    }
    void Key(const std::string& key) {
        Frame& f = frames_.back();
        path_.resize(f.base);
        const size_t tokenStart = path_.size();
        path_ += '/';
        path_ += PointerToken(key);
        f.childHash = Extend(f.hash, std::string_view(path_).substr(tokenStart));
        f.hasKey = true;
        if (!f.keys.insert(key).second) {
            if (duplicates_.size() < kMaxDuplicates) duplicates_.push_back(path_);
            ++duplicateCount_;
        } else if (f.order) {
            f.order->push_back(key);
        }
    }
    void EndContainer() {
        path_.resize(frames_.back().base);
        frames_.pop_back();
        ElementDone();
    }
    /// A value that is not a container has been read.
    void Value() { ElementDone(); }

    /// The pointer of the value being parsed.
    std::string Path() const {
        if (frames_.empty()) return path_;
        const Frame& f = frames_.back();
        if (f.array) return path_.substr(0, f.base) + "/" + std::to_string(f.index);
        return f.hasKey ? path_ : path_.substr(0, f.base);
    }
    /// The first kMaxDuplicates duplicate keys' pointers, and how many there were.
    const std::vector<std::string>& Duplicates() const { return duplicates_; }
    size_t DuplicateCount() const { return duplicateCount_; }
    KeyOrder TakeKeyOrder() { return std::move(order_); }

    static constexpr size_t kMaxDuplicates = 10;

  private:
    struct Frame {
        Frame(bool isArray, size_t pathLength, uint64_t pointerHash)
            : array(isArray), base(pathLength), hash(pointerHash) {}
        bool array;
        size_t base;            ///< the length of this container's own pointer in path_
        uint64_t hash;          ///< PointerHash of that pointer
        uint64_t childHash = 0; ///< objects: of the current key's pointer
        size_t index = 0;
        bool hasKey = false;
        std::unordered_set<std::string> keys;
        std::vector<std::string>* order = nullptr;  ///< in order_ (its nodes do not move)
    };
    static uint64_t Extend(uint64_t h, std::string_view token) {
        for (unsigned char c : token) h = (h ^ c) * 0x100000001b3ull;
        return h;
    }
    /// A container value starts: its pointer into path_ (an array's element index
    /// appended), and that pointer's hash.
    uint64_t EnterValue() {
        if (frames_.empty()) return PointerHash("");
        const Frame& f = frames_.back();
        if (!f.array) return f.childHash;
        path_.resize(f.base);
        const size_t tokenStart = path_.size();
        path_ += '/';
        path_ += std::to_string(f.index);
        return Extend(f.hash, std::string_view(path_).substr(tokenStart));
    }
    void ElementDone() {
        if (!frames_.empty() && frames_.back().array) ++frames_.back().index;
    }
    /// A pointer hundreds of levels long as its first and last tokens.
    static std::string Abbreviated(const std::string& pointer) {
        std::vector<size_t> slashes;
        for (size_t i = 0; i < pointer.size(); ++i)
            if (pointer[i] == '/') slashes.push_back(i);
        std::string out = pointer;
        if (slashes.size() > 8)
            out = pointer.substr(0, slashes[4]) +
                  StringPrintf("/...(%zu levels)...", slashes.size() - 6) + pointer.substr(slashes[slashes.size() - 2]);
        if (out.size() > 240) out = out.substr(0, 200) + "...";
        return out;
    }

    const Reader& r_;
    std::vector<Frame> frames_;
    std::string path_;
    std::vector<std::string> duplicates_;
    size_t duplicateCount_ = 0;
    KeyOrder order_;
};

/// nlohmann's SAX events into a Json (std::map-backed: a duplicate key's last value wins),
/// with the PathTracker told of each. Not nlohmann's callback parser: its end of an object
/// searches the enclosing container for discarded values, so 300,000 objects in one array
/// take 11 s.
class TrackingSax {
  public:
    TrackingSax(Json* root, PathTracker* tracker) : root_(root), tracker_(tracker) {}

    bool null() { return Add(Json(nullptr)); }
    bool boolean(bool v) { return Add(Json(v)); }
    bool number_integer(Json::number_integer_t v) { return Add(Json(v)); }
    bool number_unsigned(Json::number_unsigned_t v) { return Add(Json(v)); }
    bool number_float(Json::number_float_t v, const Json::string_t&) { return Add(Json(v)); }
    bool string(Json::string_t& v) { return Add(Json(std::move(v))); }
    bool binary(Json::binary_t& v) { return Add(Json::binary(std::move(v))); }
    bool start_object(std::size_t) { return Open(false); }
    bool start_array(std::size_t) { return Open(true); }
    bool key(Json::string_t& k) {
        tracker_->Key(k);
        slot_ = &(*stack_.back())[k];
        return true;
    }
    bool end_object() { return Close(); }
    bool end_array() { return Close(); }
    template <class Exception>
    bool parse_error(std::size_t, const std::string&, const Exception& ex) {
        throw ex;
    }

  private:
    Json* Place(Json&& v) {
        if (stack_.empty()) {
            *root_ = std::move(v);
            return root_;
        }
        Json& top = *stack_.back();
        if (top.is_array()) {
            top.push_back(std::move(v));
            return &top.back();
        }
        *slot_ = std::move(v);
        return slot_;
    }
    bool Add(Json&& v) {
        Place(std::move(v));
        tracker_->Value();
        return true;
    }
    bool Open(bool array) {
        tracker_->StartContainer(array);
        stack_.push_back(Place(array ? Json::array() : Json::object()));
        return true;
    }
    bool Close() {
        stack_.pop_back();
        tracker_->EndContainer();
        return true;
    }

    Json* root_;
    PathTracker* tracker_;
    std::vector<Json*> stack_;  ///< the open containers (an array does not grow while a child is open)
    Json* slot_ = nullptr;      ///< the open object's value for the last key
};

/// Line and column (1-based) of byte offset `pos` of `text`.
std::pair<size_t, size_t> LineColumn(const std::string& text, size_t pos) {
    size_t line = 1, column = 1;
    for (size_t i = 0; i < pos && i < text.size(); ++i) {
        if (text[i] == '\n') {
            ++line;
            column = 1;
        } else {
            ++column;
        }
    }
    return {line, column};
}

Json ParseJson(Reader& r, const std::string& text) {
    if (text.find_first_not_of(" \t\r\n") == std::string::npos) r.Fail("", "the file is empty");
    PathTracker tracker(r);
    Json root;
    try {
        TrackingSax sax(&root, &tracker);
        Json::sax_parse(text, &sax);
    } catch (const Json::parse_error& e) {
        // nlohmann: "[json.exception.parse_error.101] parse error at line L, column C: why".
        std::string what = e.what();
        size_t line = 0, column = 0;
        std::string why = what;
        if (size_t at = what.find(" at line ");
            at != std::string::npos &&
            std::sscanf(what.c_str() + at, " at line %zu, column %zu", &line, &column) == 2) {
            if (size_t colon = what.find(": ", at); colon != std::string::npos)
                why = what.substr(colon + 2);
        } else {
            std::tie(line, column) = LineColumn(text, e.byte > 0 ? e.byte - 1 : 0);
            if (size_t colon = what.find(": "); colon != std::string::npos)
                why = what.substr(colon + 2);
        }
        if (why.size() > 160) why = why.substr(0, 157) + "...";
        throw Error(SourceLoc{r.File(), line, column, ""}, "parse error: " + why);
    } catch (const Json::out_of_range& e) {
        // A number too large for a double, e.g. 1e999 (JSON has no NaN or infinity).
        std::string what = e.what(), token;
        if (size_t q = what.find('\''); q != std::string::npos)
            token = what.substr(q + 1, what.rfind('\'') - q - 1);
        std::string where;
        if (size_t pos = token.empty() ? std::string::npos : text.find(token);
            pos != std::string::npos) {
            auto [line, column] = LineColumn(text, pos);
            where = StringPrintf(" (line %zu, column %zu)", line, column);
        }
        r.Fail(tracker.Path(),
               StringPrintf("number %s is out of range%s", token.c_str(), where.c_str()));
    } catch (const Json::exception& e) {
        r.Fail(tracker.Path(), std::string("cannot parse: ") + e.what());
    }
    for (const std::string& path : tracker.Duplicates())
        r.Lenient(path, "duplicate key", "duplicate key (the last value is used)");
    if (tracker.DuplicateCount() > tracker.Duplicates().size())
        r.Warn(r.File() + StringPrintf(": ... and %zu more duplicate keys (the last value of each is used)",
                                       tracker.DuplicateCount() - tracker.Duplicates().size()));
    r.SetKeyOrder(tracker.TakeKeyOrder());
    return root;
}

int SettingInt(const Reader& r, const Json& j, const std::string& path, const RenderSetting& s) {
    return Int(r, j, path, static_cast<int>(s.lo), static_cast<int>(s.hi));
}

float SettingFloat(const Reader& r, const Json& j, const std::string& path, const RenderSetting& s) {
    if (s.lo == 0 && std::isinf(s.hi)) return NonNegative(r, j, path);
    const float f = Float(r, j, path);
    // In float, as the CLI compares: 0.01 is 0.0099999998f.
    if (!(f >= static_cast<float>(s.lo) && f <= static_cast<float>(s.hi)))
        r.Fail(path, StringPrintf("must be between %g and %g, got ", s.lo, s.hi) + NumberText(j));
    return f;
}

std::string SettingChoice(const Reader& r, const Json& j, const std::string& path, const RenderSetting& s) {
    return Enum(r, j, path, s.choices);
}

}  // namespace lm::json
