#include "lightmesh/scene/json_reader.h"

#include <algorithm>
#include <cctype>
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
        case Json::value_t::number_float: return StringPrintf("the number %g", j.get<double>());
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
    if (!std::isfinite(f)) r.Fail(path, StringPrintf("number out of range, got %g", v));
    return f;
}

float NonNegative(const Reader& r, const Json& j, const std::string& path) {
    const float v = Float(r, j, path);
    if (v < 0) r.Fail(path, StringPrintf("must not be negative, got %g", v));
    return v;
}

int Int(const Reader& r, const Json& j, const std::string& path, int lo, int hi) {
    if (!j.is_number()) r.Fail(path, "expected an integer, got " + Describe(j));
    const double v = j.get<double>();
    if (v != std::floor(v)) r.Fail(path, StringPrintf("expected an integer, got %g", v));
    if (v < lo || v > hi)
        r.Fail(path, StringPrintf("must be between %d and %d, got %.15g", lo, hi, v));
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

/// Follows the parser's position as a JSON pointer (nlohmann's parser callback reports
/// structure, not locations), and collects duplicate keys on the way.
class PathTracker {
  public:
    bool OnEvent(Json::parse_event_t event, const Json& parsed) {
        using E = Json::parse_event_t;
        switch (event) {
            case E::object_start: {
                std::vector<std::string>* keys = &order_[Path()];
                frames_.emplace_back(false);
                frames_.back().order = keys;
                break;
            }
            case E::array_start: frames_.emplace_back(true); break;
            case E::key: {
                Frame& f = frames_.back();
                f.key = parsed.get<std::string>();
                f.hasKey = true;
                if (!f.keys.insert(f.key).second)
                    duplicates_.push_back(Path());
                else if (f.order)
                    f.order->push_back(f.key);
                break;
            }
            case E::object_end:
            case E::array_end:
                frames_.pop_back();
                ElementDone();
                break;
            case E::value: ElementDone(); break;
        }
        return true;
    }

    /// The pointer of the value being parsed.
    std::string Path() const {
        std::string p;
        for (const Frame& f : frames_) {
            if (!f.array && !f.hasKey) continue;
            p += '/';
            p += f.array ? std::to_string(f.index) : PointerToken(f.key);
        }
        return p;
    }
    const std::vector<std::string>& Duplicates() const { return duplicates_; }
    KeyOrder TakeKeyOrder() { return std::move(order_); }

  private:
    struct Frame {
        explicit Frame(bool isArray) : array(isArray) {}
        bool array;
        size_t index = 0;
        bool hasKey = false;
        std::string key;
        std::unordered_set<std::string> keys;
        std::vector<std::string>* order = nullptr;  ///< in order_ (its nodes do not move)
    };
    void ElementDone() {
        if (!frames_.empty() && frames_.back().array) ++frames_.back().index;
    }
    std::vector<Frame> frames_;
    std::vector<std::string> duplicates_;
    KeyOrder order_;
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
    PathTracker tracker;
    Json root;
    try {
        root = Json::parse(text, [&tracker](int, Json::parse_event_t e, Json& parsed) {
            return tracker.OnEvent(e, parsed);
        });
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
        r.Fail(path, StringPrintf("must be between %g and %g, got %g", s.lo, s.hi, f));
    return f;
}

std::string SettingChoice(const Reader& r, const Json& j, const std::string& path, const RenderSetting& s) {
    return Enum(r, j, path, s.choices);
}

}  // namespace lm::json
